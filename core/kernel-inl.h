// Per-target Highway basics every SIMD kernel shares: the lane types and the canonical NaN of the kernels'
// outputs. Include after "hwy/foreach_target.h" and "hwy/highway.h", outside any namespace: like every Highway
// -inl header it is compiled once per target and opens restir::HWY_NAMESPACE itself.

#include <limits>

// Highway's per-target include guard: the body is compiled once for each target foreach_target.h toggles.
#if defined(RESTIR_CORE_KERNEL_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_KERNEL_INL_H_
#undef RESTIR_CORE_KERNEL_INL_H_
#else
#define RESTIR_CORE_KERNEL_INL_H_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// One packet of lanes.
using DF = hn::ScalableTag<float>;
using DI = hn::RebindToSigned<DF>;
using D8 = hn::Rebind<uint8_t, DI>;
using VF = hn::Vec<DF>;
using VI = hn::Vec<DI>;
using MF = hn::Mask<DF>;

// CanonicalNaN (core/math.h) per lane. IsNaN, not Ne(v, v): Highway's float Ne is the ordered compare (false for
// NaN) on AVX2 and AVX-512 but the unordered one on SSE4.
HWY_INLINE VF CanonicalNaNV(VF v) {
  return hn::IfThenElse(hn::IsNaN(v), hn::Set(DF(), std::numeric_limits<float>::quiet_NaN()), v);
}

// The largest per-lane count of a packet, clamped to [0, rows]: how far a packet's loops over inputs (or draws)
// run, the lanes with fewer being masked off.
HWY_INLINE int PacketMaxCount(VI counts, int rows) {
  const int m = static_cast<int>(hn::GetLane(hn::MaxOfLanes(DI(), counts)));
  return m < 0 ? 0 : (m > rows ? rows : m);
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_KERNEL_INL_H_ toggle
