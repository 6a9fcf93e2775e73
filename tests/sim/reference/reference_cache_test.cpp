// The reference cache's entries: any change to an entry's bytes (a flipped bit anywhere, a cut, an appended byte,
// another frame's entry under this name) is refused, and only a whole, finite, non-negative entry for this key
// and size is accepted.
#include "sim/reference/reference_cache.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>

namespace restir {
namespace {

const std::string kKey = "0123456789abcdef";

ImageRgb Ramp(int w, int h, float scale) {
  ImageRgb img(w, h);
  for (size_t i = 0; i < img.Size(); ++i)
    img.pixels[i] = Vec3(scale * float(i), scale * float(i) + 0.5f, scale * 0.25f * float(i * i));
  return img;
}

std::vector<float> LumaRamp(int w, int h, float scale) {
  std::vector<float> v(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < v.size(); ++i) v[i] = scale * float(i + 1);
  return v;
}

std::string Encode(const ImageRgb& mean, const ImageRgb& se) {
  return EncodeReferenceCacheEntry(kKey, mean, se, LumaRamp(mean.width, mean.height, 0.003f));
}

bool Decodes(const std::string& bytes, const std::string& key, int w, int h, std::string* why = nullptr) {
  ImageRgb mean, se;
  std::vector<float> lumaSe;
  std::string problem;
  const bool ok = DecodeReferenceCacheEntry(bytes, key, w, h, mean, se, lumaSe, problem);
  if (why) *why = problem;
  return ok;
}

TEST(ReferenceCacheEntry, RoundTripsBitForBit) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{7, 3}, std::pair{64, 36}}) {
    const ImageRgb mean = Ramp(w, h, 0.125f), se = Ramp(w, h, 1e-3f);
    const std::vector<float> lumaSe = LumaRamp(w, h, 7e-4f);
    const std::string bytes = EncodeReferenceCacheEntry(kKey, mean, se, lumaSe);
    EXPECT_EQ(bytes.size(), ReferenceCacheEntrySize(kKey, w, h));
    ImageRgb m, s;
    std::vector<float> l;
    std::string problem;
    ASSERT_TRUE(DecodeReferenceCacheEntry(bytes, kKey, w, h, m, s, l, problem)) << problem;
    EXPECT_EQ(HashImage(m), HashImage(mean));
    EXPECT_EQ(HashImage(s), HashImage(se));
    EXPECT_EQ(l, lumaSe);
  }
}

// Exhaustive over a small entry: every bit of every byte, header, key, payload and checksum alike.
TEST(ReferenceCacheEntry, EverySingleBitFlipIsRefused) {
  const std::string good = Encode(Ramp(3, 2, 0.5f), Ramp(3, 2, 0.01f));
  for (size_t i = 0; i < good.size(); ++i)
    for (int bit = 0; bit < 8; ++bit) {
      std::string bad = good;
      bad[i] = static_cast<char>(bad[i] ^ (1 << bit));
      EXPECT_FALSE(Decodes(bad, kKey, 3, 2)) << "byte " << i << " bit " << bit;
    }
}

TEST(ReferenceCacheEntry, EveryCutAndAnyAppendedByteIsRefused) {
  const std::string good = Encode(Ramp(4, 3, 0.5f), Ramp(4, 3, 0.01f));
  for (size_t n = 0; n < good.size(); ++n) EXPECT_FALSE(Decodes(good.substr(0, n), kKey, 4, 3)) << n;
  EXPECT_FALSE(Decodes(good + '\0', kKey, 4, 3));
  EXPECT_FALSE(Decodes(good + good, kKey, 4, 3));
}

TEST(ReferenceCacheEntry, AnotherKeyOrSizeIsRefusedAndSaysWhy) {
  const std::string good = Encode(Ramp(4, 3, 0.5f), Ramp(4, 3, 0.01f));
  std::string why;
  EXPECT_FALSE(Decodes(good, "fedcba9876543210", 4, 3, &why));
  EXPECT_NE(why.find("another frame"), std::string::npos) << why;
  EXPECT_FALSE(Decodes(good, kKey, 3, 4, &why));
  EXPECT_NE(why.find("4x3"), std::string::npos) << why;
  EXPECT_FALSE(Decodes(good, kKey, 4, 4));
  EXPECT_FALSE(Decodes("", kKey, 4, 3));
  EXPECT_FALSE(Decodes(std::string(100, '\0'), kKey, 1, 1));
}

bool PrintableAscii(const std::string& s) {
  for (char c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) return false;
  return true;
}

// Another key with a valid checksum (an entry written by another version, or forged): the refusal names the key
// it found, but the key's bytes come from the file, so control bytes are escaped and a long key is cut (the fuzzer
// found a key holding a newline, which would have split the one-line message).
TEST(ReferenceCacheEntry, AForeignKeyIsShownEscapedOnOneShortLine) {
  const ImageRgb mean = Ramp(2, 2, 0.5f), se = Ramp(2, 2, 0.01f);
  const std::vector<float> lumaSe = LumaRamp(2, 2, 0.01f);
  const std::string keys[] = {std::string("ab\ncd\r\t", 8), std::string("k\0ey\x1b[31m", 9),
                              std::string("\xff\x80\x7f\\", 4), std::string(5000, 'z'), std::string()};
  for (const std::string& foreign : keys) {
    std::string why;
    EXPECT_FALSE(Decodes(EncodeReferenceCacheEntry(foreign, mean, se, lumaSe), kKey, 2, 2, &why));
    EXPECT_NE(why.find("another frame"), std::string::npos) << why;
    EXPECT_TRUE(PrintableAscii(why)) << why;
    EXPECT_LT(why.size(), 200u) << why;
  }
  std::string why;
  Decodes(EncodeReferenceCacheEntry("ab\ncd", mean, se, lumaSe), kKey, 2, 2, &why);
  EXPECT_NE(why.find("ab\\x0acd"), std::string::npos) << why;
}

// A valid checksum over invalid values (written by a broken renderer, or forged) is refused too.
// Non-finite values anywhere and negative standard errors are refused; a negative mean is an estimate the
// difference estimator can make (sim/reference/reference_learning.h) and is kept.
TEST(ReferenceCacheEntry, NonFiniteValuesAndNegativeSpreadsAreRefusedEvenWithAValidChecksum) {
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity(), -1e-30f, -5.0f};
  for (float v : bad)
    for (int image = 0; image < 3; ++image) {
      ImageRgb mean = Ramp(3, 3, 0.5f), se = Ramp(3, 3, 0.01f);
      std::vector<float> lumaSe = LumaRamp(3, 3, 0.01f);
      if (image < 2) (image ? se : mean).pixels[4].y = v;
      else lumaSe[4] = v;
      std::string why;
      const bool decodes = Decodes(EncodeReferenceCacheEntry(kKey, mean, se, lumaSe), kKey, 3, 3, &why);
      if (image == 0 && std::isfinite(v)) {
        EXPECT_TRUE(decodes) << v << ": " << why;
        continue;
      }
      EXPECT_FALSE(decodes) << v;
      EXPECT_NE(why.find("non-finite"), std::string::npos) << why;
    }
  ImageRgb zero(2, 2), negativeZero(2, 2);
  negativeZero.pixels[0] = Vec3(-0.0f);
  EXPECT_TRUE(Decodes(Encode(zero, zero), kKey, 2, 2));
  EXPECT_TRUE(Decodes(Encode(negativeZero, zero), kKey, 2, 2));
}

// How the samples were spent travels with the entry (a cached frame reports a cap as a rendered one does), and a
// scale outside (0, 1] or a non-finite or negative sample count is refused like a bad pixel.
TEST(ReferenceCacheEntry, AllocationRoundTripsAndOutOfRangeIsRefused) {
  const ImageRgb mean = Ramp(3, 2, 0.5f), se = Ramp(3, 2, 0.01f);
  const std::vector<float> lumaSe = LumaRamp(3, 2, 0.01f);
  for (const ReferenceAllocation a : {ReferenceAllocation{48.0, 1.0}, ReferenceAllocation{4095.75, 0.0371},
                                      ReferenceAllocation{0.0, std::ldexp(1.0, -20)}}) {
    ImageRgb m, s;
    std::vector<float> l;
    std::string problem;
    ReferenceAllocation back{-1.0, -1.0};
    ASSERT_TRUE(DecodeReferenceCacheEntry(EncodeReferenceCacheEntry(kKey, mean, se, lumaSe, a), kKey, 3, 2, m, s, l,
                                          problem, &back))
        << problem;
    EXPECT_EQ(back.meanSamplesPerPixel, a.meanSamplesPerPixel);
    EXPECT_EQ(back.scale, a.scale);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const ReferenceAllocation a : {ReferenceAllocation{48.0, 0.0}, ReferenceAllocation{48.0, 1.0000001},
                                      ReferenceAllocation{48.0, -0.5}, ReferenceAllocation{48.0, nan},
                                      ReferenceAllocation{-1.0, 1.0}, ReferenceAllocation{inf, 1.0},
                                      ReferenceAllocation{nan, 0.5}}) {
    std::string why;
    EXPECT_FALSE(Decodes(EncodeReferenceCacheEntry(kKey, mean, se, lumaSe, a), kKey, 3, 2, &why))
        << a.meanSamplesPerPixel << " " << a.scale;
    EXPECT_NE(why.find("allocation"), std::string::npos) << why;
  }
}

// The fuzz target's seed (tests/fuzz/cache_seeds/) stays a valid entry for the key and size the target asks for,
// so the fuzzer starts from the accepting path.
TEST(ReferenceCacheEntry, FuzzSeedIsAValidEntry) {
  std::ifstream f("tests/fuzz/cache_seeds/entry.bin", std::ios::binary);
  ASSERT_TRUE(f) << "tests/fuzz/cache_seeds/entry.bin";
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::string why;
  EXPECT_TRUE(Decodes(bytes, "fuzz0000fuzz0000", 3, 2, &why)) << why;
}

}  // namespace
}  // namespace restir
