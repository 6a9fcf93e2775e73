// The randomised-QMC point kernel (core/qmc_kernel.h): every SIMD target this machine supports reproduces the
// scalar twin bit for bit (DESIGN §3) over shifts at the edges of the word, the Roberts sequences' own alphas
// and random ones, point indices up to 2^16 and counts around every vector width (tails written next to
// memory that faults); the twin is RobertsCoordinate of each point. Likewise the random words (PixelRandomWords4):
// every target reproduces core/rng.h RandomWords4 over keys with every field at its extremes, pixels and group
// indices that wrap past 2^20 (where RandomWords4 folds the group) and 2^32, and the words' floats are uniform
// (chi-square) and uncorrelated.
#include "core/qmc_kernel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "core/kernel_test_support.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/simd.h"

namespace restir {
namespace {

class QmcKernel : public test::SimdTargetTest {};

using test::Bits;
using test::GuardedArray;

TEST_F(QmcKernel, EveryTargetMatchesScalarTwinBitForBit) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<uint32_t> alphas;
  const RobertsSequence<5> r5;
  const RobertsSequence<7> r7;
  for (uint32_t a : r5.alpha) alphas.push_back(a);
  for (uint32_t a : r7.alpha) alphas.push_back(a);
  for (int i = 0; i < 6; ++i) alphas.push_back(static_cast<uint32_t>(rng()));
  alphas.push_back(~0u);
  size_t compared = 0;
  for (uint32_t alpha : alphas)
    for (size_t copies : {1, 3, 4, 8, 16, 32})
      for (size_t count : {0, 1, 2, 3, 5, 8, 9, 16, 17, 33, 47, 64, 100, 4096, 65536}) {
        std::vector<uint32_t> shifts(copies);
        for (size_t r = 0; r < copies; ++r) shifts[r] = r == 0 ? 0u : r == 1 ? ~0u : static_cast<uint32_t>(rng());
        GuardedArray<float> twin(copies * count);
        RobertsCoordinatesScalar(shifts.data(), copies, count, alpha, twin.data());
        for (size_t r = 0; r < copies; ++r)
          for (size_t k = 0; k < count; k += 1 + k / 64)
            ASSERT_EQ(Bits(twin.data()[k * copies + r]),
                      Bits(RobertsCoordinate(shifts[r], static_cast<uint32_t>(k), alpha)));
        for (SimdTarget t : SupportedSimdTargets()) {
          ASSERT_TRUE(SetSimdTarget(t));
          EXPECT_STREQ(QmcKernelDispatchedTargetName(), test::ExpectedDispatchName(t));
          GuardedArray<float> got(copies * count);
          RobertsCoordinates(shifts.data(), copies, count, alpha, got.data());
          for (size_t i = 0; i < copies * count; ++i)
            ASSERT_EQ(Bits(got.data()[i]), Bits(twin.data()[i]))
                << SimdTargetName(t) << " alpha " << alpha << " copies " << copies << " count " << count
                << " at " << i;
          compared += copies * count;
        }
      }
  EXPECT_GT(compared, 1000000u);
}

TEST_F(QmcKernel, PixelWordsMatchRandomWords4OnEveryTarget) {
  std::mt19937 rng(5);
  std::vector<RngKey> keys{{0, 0, 0, 0}, {~0u, ~0u, ~0u, 0xFFFu}, {0x5EFE12ECu, 17, 0, 6}};
  for (int i = 0; i < 5; ++i) {
    const uint32_t a = static_cast<uint32_t>(rng()), b = static_cast<uint32_t>(rng());
    keys.push_back(RngKey{a, b, 0, static_cast<uint32_t>(rng() & 0xFFFu)});
  }
  size_t compared = 0;
  for (const RngKey& key : keys)
    for (uint32_t first : {0u, 3u, 0xFFFFEu, 0xFFFFFFF0u})
      for (size_t count : {1, 3, 4, 5, 8, 15, 16, 17})
        for (size_t groups : {1, 2, 12, 28}) {
          std::vector<uint32_t> pixels(count);
          for (size_t p = 0; p < count; ++p) pixels[p] = p % 3 == 0 ? ~0u - static_cast<uint32_t>(p) : rng();
          GuardedArray<uint32_t> twin(4 * groups * count);
          PixelRandomWords4Scalar(key, pixels.data(), count, first, groups, twin.data());
          for (size_t g = 0; g < groups; ++g)
            for (size_t p = 0; p < count; ++p) {
              uint32_t words[4];
              RandomWords4(RngKey{key.seed, key.frame, pixels[p], key.pass}, first + static_cast<uint32_t>(g), words);
              for (size_t i = 0; i < 4; ++i) ASSERT_EQ(twin.data()[(4 * g + i) * count + p], words[i]);
            }
          for (SimdTarget t : SupportedSimdTargets()) {
            ASSERT_TRUE(SetSimdTarget(t));
            GuardedArray<uint32_t> got(4 * groups * count);
            PixelRandomWords4(key, pixels.data(), count, first, groups, got.data());
            for (size_t i = 0; i < 4 * groups * count; ++i)
              ASSERT_EQ(got.data()[i], twin.data()[i]) << SimdTargetName(t) << " first " << first << " at " << i;
            compared += 4 * groups * count;
          }
        }
  EXPECT_GT(compared, 100000u);
}

// Each of the four words, as floats, fills [0, 1) evenly over pixels and groups: 2^16 of each in 64 bins, Pearson
// chi-square with 63 degrees of freedom below 140.1 (P = 8.6e-8 for uniform draws: a false failure once in 1e7
// per word, 3.4e-7 for the four); and neighbouring words are not correlated (|Pearson r| < 0.03 over 2^16 pairs,
// 7.7 standard errors).
TEST_F(QmcKernel, WordsAreUniformAndIndependent) {
  constexpr size_t kPixels = 256, kGroups = 256, kBins = 64;
  std::vector<uint32_t> pixels(kPixels);
  for (size_t p = 0; p < kPixels; ++p) pixels[p] = static_cast<uint32_t>(p * 641);
  std::vector<uint32_t> words(4 * kGroups * kPixels);
  PixelRandomWords4(RngKey{7, 1, 0, 5}, pixels.data(), kPixels, 2, kGroups, words.data());
  for (size_t i = 0; i < 4; ++i) {
    std::vector<double> bins(kBins, 0.0);
    for (size_t g = 0; g < kGroups; ++g)
      for (size_t p = 0; p < kPixels; ++p) {
        const float x = BitsToUnitFloat(words[(4 * g + i) * kPixels + p]);
        ASSERT_GE(x, 0.0f);
        ASSERT_LT(x, 1.0f);
        bins[static_cast<size_t>(x * kBins)] += 1.0;
      }
    const double expected = double(kGroups * kPixels) / kBins;
    double chi2 = 0.0;
    for (double b : bins) chi2 += (b - expected) * (b - expected) / expected;
    EXPECT_LT(chi2, 140.1) << "word " << i;
  }
  for (size_t i = 0; i + 1 < 4; ++i) {
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    const double n = double(kGroups * kPixels);
    for (size_t g = 0; g < kGroups; ++g)
      for (size_t p = 0; p < kPixels; ++p) {
        const double x = BitsToUnitFloat(words[(4 * g + i) * kPixels + p]);
        const double y = BitsToUnitFloat(words[(4 * g + i + 1) * kPixels + p]);
        sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
      }
    const double r = (sxy - sx * sy / n) / std::sqrt((sxx - sx * sx / n) * (syy - sy * sy / n));
    EXPECT_LT(std::fabs(r), 0.03) << "words " << i << " and " << i + 1;
  }
}

}  // namespace
}  // namespace restir
