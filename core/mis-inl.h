// Per-target Highway versions of the pairwise MIS weights (core/mis.h MisPairwiseNonCanonical,
// MisPairwiseCanonicalTerm; seed 004 Eq. 11), shared by the GRIS kernel (core/gris_kernel.cpp) and the stochastic
// pairwise weights kernel (core/spmis_kernel.cpp), so that each has one SIMD form next to its one scalar form.
// Include after "hwy/foreach_target.h" and "hwy/highway.h", outside any namespace.
//
// Bit-exactness (DESIGN §3): grouped as core/mis.h writes them (c_j / total · (c_c p̂_c / denom)); each scalar
// branch is a mask built from the scalar test itself (!(x > 0), which differs from x <= 0 for NaN).

#include "core/kernel-inl.h"

#if defined(RESTIR_CORE_MIS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_MIS_INL_H_
#undef RESTIR_CORE_MIS_INL_H_
#else
#define RESTIR_CORE_MIS_INL_H_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {

// MisPairwiseCanonicalTerm (seed 004 Eq. 11b, one j); total = c̄ + c_c.
HWY_INLINE VF PairwiseCanonicalTermV(VF cj, VF cBar, VF cc, VF total, VF targetJ, VF targetC) {
  const VF zero = hn::Zero(DF());
  const VF denom = hn::Add(hn::Mul(cBar, targetJ), hn::Mul(cc, targetC));
  const VF share = hn::Div(cj, total);
  // !(denom > 0): neither domain produces y, the pair's mass goes to the canonical input (defensive).
  const VF term = hn::IfThenElse(hn::Gt(denom, zero), hn::Mul(share, hn::Div(hn::Mul(cc, targetC), denom)), share);
  return hn::IfThenElseZero(hn::Gt(total, zero), term);
}

// MisPairwiseNonCanonical (seed 004 Eq. 11a); total = c̄ + c_c.
HWY_INLINE VF PairwiseNonCanonicalV(VF ci, VF cBar, VF cc, VF total, VF targetI, VF targetC) {
  const VF zero = hn::Zero(DF());
  const VF denom = hn::Add(hn::Mul(cBar, targetI), hn::Mul(cc, targetC));
  const MF ok = hn::And(hn::Gt(total, zero), hn::Gt(denom, zero));
  return hn::IfThenElseZero(ok, hn::Mul(hn::Div(ci, total), hn::Div(hn::Mul(cBar, targetI), denom)));
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_MIS_INL_H_ toggle
