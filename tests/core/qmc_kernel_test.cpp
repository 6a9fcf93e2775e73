// The randomised-QMC point kernel (core/qmc_kernel.h): every SIMD target this machine supports reproduces the
// scalar twin bit for bit (DESIGN §3) over shifts at the edges of [0, 1), the Roberts sequences' own alphas
// and random ones, point indices up to 2^16 and counts around every vector width (tails written next to
// memory that faults); the twin is RobertsCoordinate of each point.
#include "core/qmc_kernel.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/kernel_test_support.h"
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

}  // namespace
}  // namespace restir
