// The randomised-QMC point kernel (core/qmc_kernel.h): every SIMD target this machine supports reproduces the
// scalar twin bit for bit (DESIGN §3) over shifts at the edges of [0, 1), the Roberts sequences' own alphas
// and random ones, point indices up to 2^16 and counts around every vector width (tails written next to
// memory that faults); the twin is RobertsCoordinate of each point. Likewise the uniforms (UniformFloats): every
// target reproduces core/rng.h UniformFloat over keys with every field at its extremes, dimension strides (within
// and between rows) that wrap past 2^20 (where RandomBits folds the dimension) and 2^32, and the uniforms are
// uniform (chi-square).
#include "core/qmc_kernel.h"

#include <gtest/gtest.h>

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
  std::vector<double> alphas;
  const RobertsSequence<5> r5;
  const RobertsSequence<7> r7;
  for (double a : r5.alpha) alphas.push_back(a);
  for (double a : r7.alpha) alphas.push_back(a);
  for (int i = 0; i < 6; ++i) alphas.push_back(std::uniform_real_distribution<double>(1e-6, 1.0)(rng));
  size_t compared = 0;
  for (double alpha : alphas)
    for (size_t copies : {1, 3, 16})
      for (size_t count : {0, 1, 2, 3, 5, 8, 9, 16, 17, 33, 47, 64, 100, 4096, 65536}) {
        std::vector<float> shifts(copies);
        for (size_t r = 0; r < copies; ++r) shifts[r] = r == 0 ? 0.0f : r == 1 ? 0x1.fffffep-1f : u(rng);
        GuardedArray<float> twin(copies * count);
        RobertsCoordinatesScalar(shifts.data(), copies, count, alpha, twin.data());
        for (size_t r = 0; r < copies; ++r)
          for (size_t k = 0; k < count; k += 1 + k / 64)
            ASSERT_EQ(Bits(twin.data()[r * count + k]),
                      Bits(RobertsCoordinate(shifts[r], static_cast<int>(k), alpha)));
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

TEST_F(QmcKernel, UniformsMatchUniformFloatOnEveryTarget) {
  std::mt19937 rng(5);
  std::vector<RngKey> keys{{0, 0, 0, 0}, {~0u, ~0u, ~0u, 0xFFFu}, {0x5EFE12ECu, 17, 230399, 9}};
  for (int i = 0; i < 5; ++i) keys.push_back(RngKey{rng(), rng(), rng(), rng() & 0xFFFu});
  size_t compared = 0;
  for (const RngKey& key : keys)
    for (uint32_t first : {0u, 3u, 0xFFFFFu, 0xFFFFFFF0u})
      for (uint32_t stride : {1u, 5u, 7u, 4097u, 0x80000001u})
        for (size_t count : {0, 1, 3, 4, 5, 8, 15, 16, 17, 33, 48, 768, 1000})
          for (const auto [rows, rowStride] : {std::pair<size_t, uint32_t>{1, 0}, {3, 1}, {7, 0xFFFFFu}}) {
            GuardedArray<float> twin(rows * count);
            UniformFloatsScalar(key, first, stride, count, twin.data(), rows, rowStride);
            for (size_t r = 0; r < rows; ++r)
              for (size_t k = 0; k < count; ++k)
                ASSERT_EQ(Bits(twin.data()[r * count + k]),
                          Bits(UniformFloat(key, first + static_cast<uint32_t>(r) * rowStride +
                                                     static_cast<uint32_t>(k) * stride)));
            for (SimdTarget t : SupportedSimdTargets()) {
              ASSERT_TRUE(SetSimdTarget(t));
              GuardedArray<float> got(rows * count);
              UniformFloats(key, first, stride, count, got.data(), rows, rowStride);
              for (size_t i = 0; i < rows * count; ++i)
                ASSERT_EQ(Bits(got.data()[i]), Bits(twin.data()[i]))
                    << SimdTargetName(t) << " first " << first << " stride " << stride << " rows " << rows
                    << " at " << i;
              compared += rows * count;
            }
          }
  EXPECT_GT(compared, 100000u);
}

// The dispatched uniforms fill [0, 1) evenly: 2^18 of them in 64 bins, Pearson chi-square with 63 degrees of
// freedom below 140.1 (P = 8.6e-8 for uniform draws: a false failure once in 10^7).
TEST_F(QmcKernel, UniformsAreUniform) {
  constexpr size_t kCount = 1 << 18, kBins = 64;
  std::vector<float> u(kCount);
  UniformFloats(RngKey{7, 1, 12345, 3}, 2, 5, kCount, u.data());
  std::vector<double> bins(kBins, 0.0);
  for (float x : u) {
    ASSERT_GE(x, 0.0f);
    ASSERT_LT(x, 1.0f);
    bins[static_cast<size_t>(x * kBins)] += 1.0;
  }
  const double expected = double(kCount) / kBins;
  double chi2 = 0.0;
  for (double b : bins) chi2 += (b - expected) * (b - expected) / expected;
  EXPECT_LT(chi2, 140.1);
}

}  // namespace
}  // namespace restir
