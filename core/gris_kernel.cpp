// Highway kernel and scalar twins of the GRIS combination (core/gris_kernel.h). The per-target part below is
// compiled once per Highway target (foreach_target.h); the scalar twins and the dispatchers once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): each lane runs GrisCombine's expression tree for its combination, term for term in
// the same order (sums left to right from +0, products and quotients grouped as written in core/gris.h and
// core/mis.h), with per-lane IEEE operations only: no MulAdd, no approximate reciprocals. Every branch of the
// scalar code becomes a mask built from the scalar test itself (!(x > 0) where it says so, which differs from
// x <= 0 for NaN), so a value the scalar code would not compute, or a matrix entry it would not read, is
// computed on every lane but never selected into a result. A lane's loops stop at its own input count through
// the `live` masks.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/gris_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "core/gris_kernel.h"
#include "core/math.h"
#include "core/mis-inl.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
// Unnamed: the helpers' names must not collide with other kernels' per-target helpers (ODR).
namespace {


// What a packet computes: one deterministic family of GrisCombine, or GrisResample with given weights.
enum class Mode { kUniform, kZ, kBalance, kPairwise, kGiven };

// A packet's rows: the batch's arrays offset to the packet's first combination.
struct Rows {
  const int32_t* inputs;
  const uint8_t* hasSample;
  const float* W;
  const float* confidence;
  const float* visibility;
  const float* u;
  const float* target;
  const float* mis;
  const float* canonicalTarget;
  size_t stride;
  int M;
};

struct OutRows {
  int32_t* selected;
  float* weightSum;
  float* W;
  float* confidence;
  float* visibility;
  int32_t* guarded;
};

// Entries p̂_j(Y_i) of the packet's combinations.
HWY_INLINE VF TargetRow(const Rows& in, int j, int i) {
  return hn::LoadU(DF(), in.target + (static_cast<size_t>(j) * static_cast<size_t>(in.M) + i) * in.stride);
}

// One packet of Lanes(DF) combinations; `in` and `out` point at its first one.
template <Mode kMode, bool kWeighted>
HWY_INLINE void GrisPacket(const Rows& in, const OutRows& out) {
  const DF df;
  const DI di;
  const D8 d8;
  const VF zero = hn::Zero(df);
  const size_t s = in.stride;
  const VI n = hn::LoadU(di, in.inputs);
  // The loops run to the packet's largest count; lanes with fewer inputs are masked by `live`.
  const int maxN = PacketMaxCount(n, in.M);

  MF live[kMaxGrisInputs], has[kMaxGrisInputs];
  VF c[kMaxGrisInputs], W[kMaxGrisInputs], pc[kMaxGrisInputs], mis[kMaxGrisInputs];
  // Σ c_i in input order (GrisCombine's confidenceSum; GrisResample's r.confidence is the same sum).
  VF cs = zero;
  for (int i = 0; i < maxN; ++i) {
    live[i] = hn::RebindMask(df, hn::Gt(n, hn::Set(di, i)));
    c[i] = hn::LoadU(df, in.confidence + i * s);
    W[i] = hn::LoadU(df, in.W + i * s);
    const VI flag = hn::PromoteTo(di, hn::LoadU(d8, in.hasSample + i * s));
    has[i] = hn::And(live[i], hn::RebindMask(df, hn::Ne(flag, hn::Zero(di))));
    cs = hn::IfThenElse(live[i], hn::Add(cs, c[i]), cs);
  }

  if constexpr (kMode == Mode::kGiven) {
    for (int i = 0; i < maxN; ++i) {
      pc[i] = hn::LoadU(df, in.canonicalTarget + i * s);
      mis[i] = hn::LoadU(df, in.mis + i * s);
    }
  } else if (maxN > 0) {
    const auto target = [&](int j, int i) { return TargetRow(in, j, i); };
    const VF cc = c[0];
    const VF cBar = hn::Sub(cs, cc);
    const VF total = hn::Add(cBar, cc);
    for (int i = 0; i < maxN; ++i) {
      pc[i] = zero;
      mis[i] = zero;
      // GrisCombine evaluates targets only for inputs that can contribute.
      const MF eligible = hn::And(has[i], hn::And(hn::Gt(W[i], zero), hn::IsFinite(W[i])));
      if (hn::AllFalse(df, eligible)) continue;
      pc[i] = hn::IfThenElseZero(eligible, target(0, i));  // p̂_c(Y_i)
      const MF valid = hn::And(eligible, hn::And(hn::Gt(pc[i], zero), hn::IsFinite(pc[i])));
      if (hn::AllFalse(df, valid)) continue;
      VF m;
      if constexpr (kMode == Mode::kUniform) {
        m = hn::IfThenElseZero(hn::Gt(cs, zero), hn::Div(c[i], cs));  // MisUniform
      } else if constexpr (kMode == Mode::kZ) {
        m = c[i];  // 1/Z after selection (Bitterli 2020)
      } else if constexpr (kMode == Mode::kBalance) {
        // MisBalance (seed 000 Eq. 3): Σ_j c_j p̂_j(Y_i) in j order, p̂_0(Y_i) = p̂_c(Y_i).
        VF denom = zero, ti = pc[i];
        for (int j = 0; j < maxN; ++j) {
          const VF tj = j == 0 ? pc[i] : target(j, i);
          if (j == i) ti = tj;
          denom = hn::IfThenElse(live[j], hn::Add(denom, hn::Mul(c[j], tj)), denom);
        }
        m = hn::IfThenElseZero(hn::Gt(denom, zero), hn::Div(hn::Mul(c[i], ti), denom));
      } else {
        if (i == 0) {
          // Seed 004 Eq. 11b: the base share, then the terms of j = 1, 2, ... added in order.
          m = hn::IfThenElseZero(hn::Gt(total, zero), hn::Div(cc, total));
          for (int j = 1; j < maxN; ++j) {
            const VF term = PairwiseCanonicalTermV(c[j], cBar, cc, total, target(j, 0), pc[0]);
            m = hn::IfThenElse(live[j], hn::Add(m, term), m);
          }
        } else {
          m = PairwiseNonCanonicalV(c[i], cBar, cc, total, target(i, i), pc[i]);  // seed 004 Eq. 11a
        }
      }
      mis[i] = hn::IfThenElseZero(valid, m);
    }
  }

  // GrisResample (seed 000 Eq. 1-2): streaming selection over w_i = m_i p̂_c(Y_i) W_i.
  const VI one = hn::Set(di, 1);
  VF wSum = zero, visW = zero, pcSel = zero, visSel = zero;
  VI sel = hn::Set(di, -1), guarded = hn::Zero(di);
  for (int i = 0; i < maxN; ++i) {
    if (hn::AllFalse(df, has[i])) continue;
    const MF finite = hn::And(hn::IsFinite(W[i]), hn::And(hn::IsFinite(pc[i]), hn::IsFinite(mis[i])));
    guarded = hn::Add(guarded, hn::IfThenElseZero(hn::RebindMask(di, hn::AndNot(finite, has[i])), one));
    const MF positive = hn::And(hn::And(has[i], finite), hn::And(hn::Gt(W[i], zero), hn::Gt(pc[i], zero)));
    const VF w = hn::Mul(hn::Mul(mis[i], pc[i]), W[i]);  // GrisWeight
    const MF wFinite = hn::IsFinite(w);
    guarded = hn::Add(guarded, hn::IfThenElseZero(hn::RebindMask(di, hn::AndNot(wFinite, positive)), one));
    const MF add = hn::And(hn::And(positive, wFinite), hn::Gt(w, zero));
    wSum = hn::IfThenElse(add, hn::Add(wSum, w), wSum);
    const VF v = hn::LoadU(df, in.visibility + i * s);
    if constexpr (kWeighted) visW = hn::IfThenElse(add, hn::Add(visW, hn::Mul(v, w)), visW);
    const MF take = hn::And(add, hn::Lt(hn::Mul(hn::LoadU(df, in.u + i * s), wSum), w));
    sel = hn::IfThenElse(hn::RebindMask(di, take), hn::Set(di, i), sel);
    pcSel = hn::IfThenElse(take, pc[i], pcSel);
    if constexpr (!kWeighted) visSel = hn::IfThenElse(take, v, visSel);
  }
  const MF any = hn::RebindMask(df, hn::Gt(sel, hn::Set(di, -1)));
  VF outW = hn::IfThenElseZero(hn::And(any, hn::Gt(pcSel, zero)), hn::Div(wSum, pcSel));  // GrisContributionWeight

  if constexpr (kMode == Mode::kZ) {
    // Z = Σ c_j over j in order whose p̂_j(Y_s) > 0, s the lane's selected input. Row j at each lane's column s
    // is selected from the row's loads at the columns some lane selected: contiguous loads, and no index
    // arithmetic that could overflow.
    VF z = zero;
    MF chose[kMaxGrisInputs];
    bool anyChose[kMaxGrisInputs];
    for (int i = 0; i < maxN; ++i) {
      chose[i] = hn::RebindMask(df, hn::Eq(sel, hn::Set(di, i)));
      anyChose[i] = !hn::AllFalse(df, chose[i]);
    }
    for (int j = 0; j < maxN; ++j) {
      VF tj = pcSel;
      if (j > 0) {
        tj = zero;
        for (int i = 0; i < maxN; ++i)
          if (anyChose[i]) tj = hn::IfThenElse(chose[i], TargetRow(in, j, i), tj);
      }
      z = hn::IfThenElse(hn::And(hn::And(any, live[j]), hn::Gt(tj, zero)), hn::Add(z, c[j]), z);
    }
    outW = hn::IfThenElse(any, hn::IfThenElseZero(hn::Gt(z, zero), hn::Div(outW, z)), outW);
  }

  // seed 000 Eq. 4: V_X = Σ V_i w_i / Σ w_i, or V of the selected sample; 0 when nothing was selected.
  const VF vis = hn::IfThenElseZero(any, kWeighted ? hn::Div(visW, wSum) : visSel);
  hn::StoreU(sel, di, out.selected);
  hn::StoreU(CanonicalNaNV(wSum), df, out.weightSum);
  hn::StoreU(CanonicalNaNV(outW), df, out.W);
  hn::StoreU(CanonicalNaNV(cs), df, out.confidence);
  hn::StoreU(CanonicalNaNV(vis), df, out.visibility);
  hn::StoreU(guarded, di, out.guarded);
}

Rows RowsAt(const GrisBatch& b, size_t k) {
  Rows r;
  r.inputs = b.inputs + k;
  r.hasSample = b.hasSample + k;
  r.W = b.W + k;
  r.confidence = b.confidence + k;
  r.visibility = b.visibility + k;
  r.u = b.u + k;
  r.target = b.target ? b.target + k : nullptr;
  r.mis = b.mis ? b.mis + k : nullptr;
  r.canonicalTarget = b.canonicalTarget ? b.canonicalTarget + k : nullptr;
  r.stride = b.stride;
  r.M = b.matrixSize;
  return r;
}

OutRows OutAt(const GrisBatchOutput& o, size_t k) {
  return {o.selected + k, o.weightSum + k, o.W + k, o.confidence + k, o.visibility + k, o.guarded + k};
}

template <Mode kMode, bool kWeighted>
void GrisRun(const GrisBatch& b, const GrisBatchOutput& o) {
  const DF df;
  const size_t N = hn::Lanes(df);
  size_t k = 0;
  for (; k + N <= b.count; k += N) GrisPacket<kMode, kWeighted>(RowsAt(b, k), OutAt(o, k));
  if (k == b.count) return;

  // Tail: the remaining combinations copied into a packet of stride N whose extra lanes have no inputs (so
  // every mask is false there and their zeros are never read as values).
  constexpr size_t kLanes = hn::MaxLanes(DF());
  constexpr size_t kRows = kMaxGrisInputs;
  const size_t rest = b.count - k;
  const size_t M = static_cast<size_t>(b.matrixSize);
  const Rows src = RowsAt(b, k);
  HWY_ALIGN int32_t inputs[kLanes];
  uint8_t hasSample[kRows * kLanes];
  HWY_ALIGN float f[6][kRows * kLanes];
  HWY_ALIGN float target[kRows * kRows * kLanes];
  const auto copy = [&](auto* dst, const auto* from, size_t rows) {
    for (size_t r = 0; r < rows; ++r)
      for (size_t l = 0; l < N; ++l) dst[r * N + l] = l < rest ? from[r * b.stride + l] : 0;
  };
  copy(inputs, src.inputs, 1);
  copy(hasSample, src.hasSample, M);
  Rows in = src;
  in.stride = N;
  in.inputs = inputs;
  in.hasSample = hasSample;
  const float* fields[6] = {src.W, src.confidence, src.visibility, src.u, src.mis, src.canonicalTarget};
  const float** dst[6] = {&in.W, &in.confidence, &in.visibility, &in.u, &in.mis, &in.canonicalTarget};
  for (int a = 0; a < 6; ++a) {
    if (!fields[a]) continue;
    copy(f[a], fields[a], M);
    *dst[a] = f[a];
  }
  if (kMode != Mode::kGiven) {
    copy(target, src.target, M * M);
    in.target = target;
  }
  HWY_ALIGN int32_t selected[kLanes], guarded[kLanes];
  HWY_ALIGN float weightSum[kLanes], W[kLanes], confidence[kLanes], visibility[kLanes];
  GrisPacket<kMode, kWeighted>(in, OutRows{selected, weightSum, W, confidence, visibility, guarded});
  const OutRows d = OutAt(o, k);
  for (size_t l = 0; l < rest; ++l) {
    d.selected[l] = selected[l];
    d.weightSum[l] = weightSum[l];
    d.W[l] = W[l];
    d.confidence[l] = confidence[l];
    d.visibility[l] = visibility[l];
    d.guarded[l] = guarded[l];
  }
}

template <Mode kMode>
void GrisRunCarry(VisibilityCarry carry, const GrisBatch& b, const GrisBatchOutput& o) {
  if (carry == VisibilityCarry::kWeighted) GrisRun<kMode, true>(b, o);
  else GrisRun<kMode, false>(b, o);
}

}  // namespace

void GrisCombineKernel(MisFamily family, VisibilityCarry carry, const GrisBatch& b, const GrisBatchOutput& o) {
  switch (family) {
    case MisFamily::kUniform: return GrisRunCarry<Mode::kUniform>(carry, b, o);
    case MisFamily::kZ: return GrisRunCarry<Mode::kZ>(carry, b, o);
    case MisFamily::kBalance: return GrisRunCarry<Mode::kBalance>(carry, b, o);
    case MisFamily::kPairwise:
    case MisFamily::kStochasticPairwise: return GrisRunCarry<Mode::kPairwise>(carry, b, o);
  }
}

void GrisResampleKernel(VisibilityCarry carry, const GrisBatch& b, const GrisBatchOutput& o) {
  GrisRunCarry<Mode::kGiven>(carry, b, o);
}

const char* GrisDispatchedTargetName() { return hwy::TargetName(HWY_TARGET); }

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

#include <cmath>

#include "core/simd.h"

namespace restir {

HWY_EXPORT(GrisCombineKernel);
HWY_EXPORT(GrisResampleKernel);
HWY_EXPORT(GrisDispatchedTargetName);

namespace {


// Combination k's inputs as GrisCombine takes them.
int InputsAt(const GrisBatch& b, size_t k, GrisInput* in, float* u) {
  const int n = b.inputs[k];
  for (int i = 0; i < n; ++i) {
    const size_t e = static_cast<size_t>(i) * b.stride + k;
    in[i] = GrisInput{b.hasSample[e] != 0, b.W[e], b.confidence[e], b.visibility[e]};
    u[i] = b.u[e];
  }
  return n;
}

void Store(const GrisResult& r, const GrisBatchOutput& o, size_t k) {
  o.selected[k] = r.selected;
  o.weightSum[k] = CanonicalNaN(r.weightSum);
  o.W[k] = CanonicalNaN(r.W);
  o.confidence[k] = CanonicalNaN(r.confidence);
  o.visibility[k] = CanonicalNaN(r.visibility);
  o.guarded[k] = r.guarded;
}

}  // namespace

void GrisCombineBatchScalar(MisFamily family, VisibilityCarry carry, const GrisBatch& b,
                            const GrisBatchOutput& o) {
  const size_t M = static_cast<size_t>(b.matrixSize);
  for (size_t k = 0; k < b.count; ++k) {
    GrisInput in[kMaxGrisInputs];
    float u[kMaxGrisInputs];
    const int n = InputsAt(b, k, in, u);
    const auto target = [&](int j, int i) {
      return b.target[(static_cast<size_t>(j) * M + static_cast<size_t>(i)) * b.stride + k];
    };
    Store(GrisCombine(family, in, n, target, u, carry), o, k);
  }
}

void GrisResampleBatchScalar(VisibilityCarry carry, const GrisBatch& b, const GrisBatchOutput& o) {
  for (size_t k = 0; k < b.count; ++k) {
    GrisInput in[kMaxGrisInputs];
    float u[kMaxGrisInputs], mis[kMaxGrisInputs], pc[kMaxGrisInputs];
    const int n = InputsAt(b, k, in, u);
    for (int i = 0; i < n; ++i) {
      const size_t e = static_cast<size_t>(i) * b.stride + k;
      mis[i] = b.mis[e];
      pc[i] = b.canonicalTarget[e];
    }
    Store(GrisResample(in, mis, pc, n, u, carry), o, k);
  }
}

void GrisCombineBatch(MisFamily family, VisibilityCarry carry, const GrisBatch& batch, const GrisBatchOutput& out) {
  if (UseScalarTwins()) return GrisCombineBatchScalar(family, carry, batch, out);
  HWY_DYNAMIC_DISPATCH(GrisCombineKernel)(family, carry, batch, out);
}

void GrisResampleBatch(VisibilityCarry carry, const GrisBatch& batch, const GrisBatchOutput& out) {
  if (UseScalarTwins()) return GrisResampleBatchScalar(carry, batch, out);
  HWY_DYNAMIC_DISPATCH(GrisResampleKernel)(carry, batch, out);
}

const char* GrisKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(GrisDispatchedTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
