// Dynamic dispatch (DESIGN §3; issue 6 `--simd`): forcing a target makes every kernel run on exactly that
// Highway target, and the scalar choice on its plain C++ twin.
#include <gtest/gtest.h>

#include "core/gris_kernel.h"
#include "core/ris_kernel.h"
#include "core/shadow_ray_kernel.h"
#include "core/simd.h"
#include "core/spmis_kernel.h"
#include "core/target_kernel.h"

#include "core/kernel_test_support.h"

namespace restir {
namespace {

class SimdDispatch : public test::SimdTargetTest {};

TEST_F(SimdDispatch, EveryKernelRunsOnTheForcedTarget) {
  const std::pair<const char*, const char* (*)()> kernels[] = {
      {"ris", RisKernelDispatchedTargetName},
      {"target", TargetKernelDispatchedTargetName},
      {"gris", GrisKernelDispatchedTargetName},
      {"shadow-ray", ShadowRayKernelDispatchedTargetName},
      {"stochastic-pairwise", StochasticPairwiseKernelDispatchedTargetName}};
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    for (const auto& [kernel, name] : kernels)
      EXPECT_STREQ(name(), test::ExpectedDispatchName(t)) << kernel << " forced to " << SimdTargetName(t);
  }
}

}  // namespace
}  // namespace restir
