// Every EXR compression stores the same pixels, read back through OpenImageIO's OpenEXR reader. The preview's
// 8-bit codes (sim/output/frame_writer.h PreviewByte) are the definition's: lround(255 sRGB(clamp(v))),
// non-finite values black. The implementation counts precomputed step points; these tests evaluate the
// definition itself, written here from the sRGB standard (IEC 61966-2-1), and compare every float near each
// step point the standard's inverse predicts, a sweep of the whole [0, 1] range and the special values.
#include "sim/output/frame_writer.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <bit>
#include <filesystem>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <random>

namespace restir {
namespace {

int Definition(float v) {
  if (!std::isfinite(v)) v = 0.0f;
  v = std::min(std::max(v, 0.0f), 1.0f);
  const float encoded = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return static_cast<int>(std::lround(255.0f * encoded));
}

// The linear value where code b begins, from the standard's decoding function in double precision.
double StepPoint(int b) {
  const double c = (b - 0.5) / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

TEST(PreviewByte, EqualsTheDefinitionAtEveryFloatNearEachStep) {
  constexpr int64_t kUlps = 16384;  // far wider than powf's error moves a step (a few ulps)
  int64_t compared = 0;
  for (int b = 1; b <= 255; ++b) {
    const int64_t centre = std::bit_cast<uint32_t>(static_cast<float>(StepPoint(b)));
    for (int64_t k = centre - kUlps; k <= centre + kUlps; ++k) {
      const float v = std::bit_cast<float>(static_cast<uint32_t>(k));
      ASSERT_EQ(PreviewByte(v), Definition(v)) << "code " << b << ", v = " << v << " (bits " << k << ")";
      ++compared;
    }
  }
  EXPECT_EQ(compared, 255 * (2 * kUlps + 1));
}

TEST(PreviewByte, EqualsTheDefinitionAcrossTheUnitRangeAndBeyond) {
  const uint32_t one = std::bit_cast<uint32_t>(1.0f);
  for (uint32_t bits = 0; bits <= one; bits += 997) {  // every 997th float of [0, 1], denormals included
    const float v = std::bit_cast<float>(bits);
    ASSERT_EQ(PreviewByte(v), Definition(v)) << v;
  }
  const float specials[] = {0.0f,
                            -0.0f,
                            -1e-30f,
                            -1.0f,
                            std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::min(),
                            0.0031308f,
                            std::nextafter(0.0031308f, 1.0f),
                            1.0f,
                            std::nextafter(1.0f, 2.0f),
                            1e3f,
                            std::numeric_limits<float>::max(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN()};
  for (float v : specials) EXPECT_EQ(PreviewByte(v), Definition(v)) << v;
  EXPECT_EQ(PreviewByte(std::numeric_limits<float>::infinity()), 0);  // non-finite is black, not white
  EXPECT_EQ(PreviewByte(2.0f), 255);
}

TEST(TonemapPreview, EveryChannelIsTheDefinitionOfItsExposedValue) {
  ImageRgb img(37, 11);
  std::mt19937 rng(7);
  std::lognormal_distribution<float> radiance(-1.0f, 2.5f);  // HDR: many values clip at both ends
  for (Vec3& p : img.pixels) p = Vec3(radiance(rng), radiance(rng), radiance(rng));
  img.pixels[3] = Vec3(std::numeric_limits<float>::quiet_NaN(), -2.0f, std::numeric_limits<float>::infinity());
  const float exposure = 0.731f;
  const std::vector<unsigned char> rgb = TonemapPreview(img, exposure);
  ASSERT_EQ(rgb.size(), img.Size() * 3);
  for (size_t i = 0; i < img.Size(); ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(rgb[i * 3 + c], Definition(img.pixels[i][c] * exposure)) << i << " " << c;
}

TEST(WriteFrameExr, EveryCompressionStoresTheSameBitsAndSaysWhichItUsed) {
  const int w = 23, h = 19;  // more than one 16-line zip chunk, odd sizes
  std::mt19937 rng(11);
  std::lognormal_distribution<float> radiance(0.0f, 3.0f);
  ImageRgb estimate(w, h), reference(w, h), stderrs(w, h);
  for (size_t i = 0; i < estimate.Size(); ++i) {
    estimate.pixels[i] = Vec3(radiance(rng), radiance(rng), radiance(rng));
    reference.pixels[i] = Vec3(radiance(rng), 0.0f, radiance(rng));  // a flat channel: run-length compresses it
    stderrs.pixels[i] = Vec3(1e-3f * radiance(rng));
  }
  estimate.pixels[5] = Vec3(-0.0f, 1e-40f, std::numeric_limits<float>::max());  // signed zero, denormal, huge
  GBuffer g;
  g.Resize(w, h);
  for (size_t i = 0; i < g.Size(); ++i) {
    g.depth[i] = 1.0f + 0.25f * static_cast<float>(i % 7);
    g.nsX[i] = 0.0f, g.nsY[i] = 1.0f, g.nsZ[i] = 0.0f;
    g.disoccluded[i] = i % 5 == 0;
  }
  std::vector<float> flip(estimate.Size());
  for (float& f : flip) f = std::uniform_real_distribution<float>(0.0f, 1.0f)(rng);
  FrameLayers layers;
  layers.estimate = &estimate, layers.reference = &reference, layers.referenceStdError = &stderrs;
  layers.flip = &flip, layers.gbuffer = &g;
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "frame_writer_compression";
  std::filesystem::create_directories(dir);
  std::vector<float> first;
  std::vector<std::string> firstNames;
  std::map<std::string, uintmax_t> sizes;
  for (ExrCompression c : {ExrCompression::kNone, ExrCompression::kRle, ExrCompression::kZip}) {
    const std::string name = ExrCompressionName(c);
    ASSERT_EQ(ParseExrCompression(name), c);
    const std::string path = (dir / (name + ".exr")).string();
    WriteFrameExr(path, layers, c);
    sizes[name] = std::filesystem::file_size(path);
    auto in = OIIO::ImageInput::open(path);
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    EXPECT_EQ(spec.get_string_attribute("compression"), name) << path;
    ASSERT_EQ(spec.width, w);
    ASSERT_EQ(spec.nchannels, 18);  // RGB, reference, reference_stderr, error: 12; 5 G-buffer channels; flip
    std::vector<float> pixels(static_cast<size_t>(w) * h * spec.nchannels);
    ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data())) << in->geterror();
    // The estimate's channels hold its bits, wherever the file put them.
    const int r = spec.channelindex("R"), b = spec.channelindex("B"), flipY = spec.channelindex("flip.Y");
    ASSERT_GE(r, 0);
    ASSERT_GE(flipY, 0);
    for (size_t i = 0; i < estimate.Size(); ++i) {
      ASSERT_EQ(std::bit_cast<uint32_t>(pixels[i * spec.nchannels + r]), std::bit_cast<uint32_t>(estimate.pixels[i].x));
      ASSERT_EQ(std::bit_cast<uint32_t>(pixels[i * spec.nchannels + b]), std::bit_cast<uint32_t>(estimate.pixels[i].z));
      ASSERT_EQ(pixels[i * spec.nchannels + flipY], flip[i]);
    }
    if (first.empty()) {
      first = pixels, firstNames = spec.channelnames;
    } else {
      EXPECT_EQ(spec.channelnames, firstNames);
      ASSERT_EQ(pixels.size(), first.size());
      EXPECT_EQ(std::memcmp(pixels.data(), first.data(), pixels.size() * sizeof(float)), 0) << name;
    }
  }
  // Stored: the raw floats and little else; the compressed files are smaller on these flat channels.
  EXPECT_GE(sizes["none"], size_t{18} * w * h * sizeof(float));
  EXPECT_LT(sizes["rle"], sizes["none"]);
  EXPECT_LT(sizes["zip"], sizes["none"]);
  EXPECT_FALSE(ParseExrCompression("piz"));
  EXPECT_FALSE(ParseExrCompression("RLE"));
}

}  // namespace
}  // namespace restir
