#include "core/simd.h"

#include <atomic>

#include "hwy/highway.h"
#include "hwy/targets.h"

namespace restir {

namespace {

std::atomic<int> gRequested{static_cast<int>(SimdTarget::kAuto)};

int64_t HwyBit(SimdTarget t) {
  switch (t) {
    case SimdTarget::kSse4: return HWY_SSE4;
    case SimdTarget::kAvx2: return HWY_AVX2;
    case SimdTarget::kAvx512: return HWY_AVX3;
    default: return 0;
  }
}

// Targets the CPU supports and this binary compiles, ignoring any restriction SetSimdTarget made. Computed once,
// before the first restriction (SetSimdTarget calls it first).
int64_t CpuTargets() {
  static const int64_t targets = [] {
    hwy::SetSupportedTargetsForTest(0);
    return hwy::SupportedTargets() & HWY_TARGETS;
  }();
  return targets;
}

// Highway's dispatch picks the lowest set bit (the best target) of the supported, compiled targets.
int64_t BestBit(int64_t targets) { return targets & -targets; }

SimdTarget FromBit(int64_t bit) {
  if (bit == HWY_AVX3) return SimdTarget::kAvx512;
  if (bit == HWY_AVX2) return SimdTarget::kAvx2;
  if (bit == HWY_SSE4) return SimdTarget::kSse4;
  return SimdTarget::kAuto;  // some other Highway target
}

}  // namespace

const char* SimdTargetName(SimdTarget target) {
  switch (target) {
    case SimdTarget::kAuto: return "auto";
    case SimdTarget::kScalar: return "scalar";
    case SimdTarget::kSse4: return "sse4";
    case SimdTarget::kAvx2: return "avx2";
    case SimdTarget::kAvx512: return "avx512";
  }
  return "auto";
}

std::optional<SimdTarget> ParseSimdTarget(std::string_view name) {
  for (SimdTarget t : {SimdTarget::kAuto, SimdTarget::kScalar, SimdTarget::kSse4, SimdTarget::kAvx2,
                       SimdTarget::kAvx512})
    if (name == SimdTargetName(t)) return t;
  return std::nullopt;
}

bool SimdTargetSupported(SimdTarget target) {
  if (target == SimdTarget::kAuto || target == SimdTarget::kScalar) return true;
  return (CpuTargets() & HwyBit(target)) != 0;
}

std::vector<SimdTarget> SupportedSimdTargets() {
  std::vector<SimdTarget> out{SimdTarget::kScalar};
  for (SimdTarget t : {SimdTarget::kSse4, SimdTarget::kAvx2, SimdTarget::kAvx512})
    if (SimdTargetSupported(t)) out.push_back(t);
  return out;
}

bool SetSimdTarget(SimdTarget target) {
  if (!SimdTargetSupported(target)) return false;
  CpuTargets();  // capture the unrestricted set before restricting it
  const int64_t bit = HwyBit(target);
  // 0 lifts the restriction (kAuto; kScalar never reaches Highway's dispatch).
  hwy::SetSupportedTargetsForTest(bit);
  // Re-resolve the dispatch tables now rather than relying on the next call to notice.
  hwy::GetChosenTarget().Update(hwy::SupportedTargets());
  gRequested.store(static_cast<int>(target));
  return true;
}

SimdTarget RequestedSimdTarget() { return static_cast<SimdTarget>(gRequested.load()); }

SimdTarget ActiveSimdTarget() {
  const SimdTarget r = RequestedSimdTarget();
  if (r != SimdTarget::kAuto) return r;
  return FromBit(BestBit(CpuTargets()));
}

const char* ActiveSimdTargetName() {
  const SimdTarget r = RequestedSimdTarget();
  if (r != SimdTarget::kAuto) return SimdTargetName(r);
  const int64_t best = BestBit(CpuTargets());
  const SimdTarget t = FromBit(best);
  return t != SimdTarget::kAuto ? SimdTargetName(t) : hwy::TargetName(best);
}

bool UseScalarTwins() { return RequestedSimdTarget() == SimdTarget::kScalar; }

}  // namespace restir
