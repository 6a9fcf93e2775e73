// Highway kernel and scalar twin of the stochastic pairwise MIS weights (core/spmis_kernel.h). The per-target
// part below is compiled once per Highway target (foreach_target.h); the scalar twin and the dispatcher once
// (HWY_ONCE).
//
// Bit-exactness (DESIGN §3), as core/gris_kernel.cpp: each lane evaluates the expression trees of core/spmis.h
// and core/mis.h for its combination, grouped as written there (c_j / total · (c_c p̂_c / denom), K / (N P) · m,
// the canonical sum from the base share over d = 0, 1, ... in order), with per-lane IEEE operations only: no
// MulAdd, no approximate reciprocals. Every scalar branch
// becomes a mask built from the scalar test itself (!(x > 0) where it says so, which differs from x <= 0 for
// NaN), so values the scalar code would not compute are computed on every lane but never selected.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/spmis_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <algorithm>
#include <limits>

#include "core/mis-inl.h"
#include "core/spmis_kernel.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
// Unnamed: the helpers' names must not collide with other kernels' per-target helpers (ODR).
namespace {


// core/spmis.h StochasticMisWeight (seed 004 Eq. 15-16): K / (N P) · m.
HWY_INLINE VF StochasticMisWeight(VF multiplicity, VF drawCount, VF probability, VF misWeight) {
  const VF zero = hn::Zero(DF());
  const MF ok = hn::And(hn::Gt(probability, zero), hn::Gt(drawCount, zero));
  return hn::IfThenElseZero(ok, hn::Mul(hn::Div(multiplicity, hn::Mul(drawCount, probability)), misWeight));
}

// A packet's rows: the batch's arrays offset to the packet's first combination.
struct Rows {
  const int32_t* inputs;
  const int32_t* distinct;
  const float* cBar;
  const float* drawCount;
  const float* canonicalDrawCount;
  const uint8_t* hasSample;
  const float* confidence;
  const float* multiplicity;
  const float* probability;
  const float* canonicalTarget;
  const float* ownTarget;
  const float* drawnMultiplicity;
  const float* drawnProbability;
  const float* drawnConfidence;
  const float* drawnTarget;
  size_t stride;
  int inputRows;
  int drawRows;
};

// One packet of Lanes(DF) combinations; `in` and the output rows point at its first one.
HWY_INLINE void SpmisPacket(const Rows& in, float* outMis, float* outPc) {
  const DF df;
  const DI di;
  const D8 d8;
  const VF zero = hn::Zero(df);
  const size_t s = in.stride;
  const VI n = hn::LoadU(di, in.inputs);
  // The loops run to the packet's largest counts; lanes with fewer inputs or draws are masked.
  const int maxN = PacketMaxCount(n, in.inputRows);
  if (maxN == 0) return;

  MF live[kMaxGrisInputs], valid[kMaxGrisInputs];
  VF pc[kMaxGrisInputs], mis[kMaxGrisInputs];
  // Every canonicalTarget row is loaded before any output row is stored: the output may alias it.
  for (int t = 0; t < maxN; ++t) {
    live[t] = hn::RebindMask(df, hn::Gt(n, hn::Set(di, t)));
    const VI flag = hn::PromoteTo(di, hn::LoadU(d8, in.hasSample + t * s));
    const MF has = hn::And(live[t], hn::RebindMask(df, hn::Ne(flag, hn::Zero(di))));
    pc[t] = hn::IfThenElseZero(has, hn::LoadU(df, in.canonicalTarget + t * s));
    // The pipeline weighs an input only where it has a sample its canonical domain can produce.
    valid[t] = hn::And(has, hn::Gt(pc[t], zero));
    mis[t] = zero;
  }

  const VF cc = hn::LoadU(df, in.confidence);
  const VF cBar = hn::LoadU(df, in.cBar);
  const VF total = hn::Add(cBar, cc);  // c̄ + c_c, as every core/mis.h function forms it

  if (!hn::AllFalse(df, valid[0])) {
    // Seed 004 Eq. 18-19: the base share c_c / (c̄ + c_c), then the terms of the distinct canonical draws.
    VF m = hn::IfThenElseZero(hn::Gt(total, zero), hn::Div(cc, total));
    const VI D = hn::LoadU(di, in.distinct);
    const int maxD = PacketMaxCount(D, in.drawRows);
    if (maxD > 0) {
      const VF nc = hn::LoadU(df, in.canonicalDrawCount);
      for (int d = 0; d < maxD; ++d) {
        const MF drawn = hn::RebindMask(df, hn::Gt(D, hn::Set(di, d)));
        const VF pair = PairwiseCanonicalTermV(hn::LoadU(df, in.drawnConfidence + d * s), cBar, cc, total,
                                              hn::LoadU(df, in.drawnTarget + d * s), pc[0]);
        const VF term = StochasticMisWeight(hn::LoadU(df, in.drawnMultiplicity + d * s), nc,
                                            hn::LoadU(df, in.drawnProbability + d * s), pair);
        m = hn::IfThenElse(drawn, hn::Add(m, term), m);
      }
    }
    mis[0] = hn::IfThenElseZero(valid[0], m);
  }

  bool anyNonCanonical = false;
  for (int t = 1; t < maxN; ++t) anyNonCanonical = anyNonCanonical || !hn::AllFalse(df, valid[t]);
  if (anyNonCanonical) {
    // Seed 004 Eq. 16-17: K(t) / (N P(t)) times the deterministic pairwise weight of Eq. 11a.
    const VF bigN = hn::LoadU(df, in.drawCount);
    for (int t = 1; t < maxN; ++t) {
      if (hn::AllFalse(df, valid[t])) continue;
      const VF pair = PairwiseNonCanonicalV(hn::LoadU(df, in.confidence + t * s), cBar, cc, total,
                                           hn::LoadU(df, in.ownTarget + t * s), pc[t]);
      const VF m = StochasticMisWeight(hn::LoadU(df, in.multiplicity + t * s), bigN,
                                       hn::LoadU(df, in.probability + t * s), pair);
      mis[t] = hn::IfThenElseZero(valid[t], m);
    }
  }

  // Only a lane's own inputs are written: entries past its count belong to the caller (GrisBatchArrays rows).
  for (int t = 0; t < maxN; ++t) {
    hn::BlendedStore(CanonicalNaNV(mis[t]), live[t], df, outMis + t * s);
    hn::BlendedStore(CanonicalNaNV(pc[t]), live[t], df, outPc + t * s);
  }
}

Rows RowsAt(const StochasticPairwiseBatch& b, size_t k) {
  const auto at = [k](const auto* p) { return p ? p + k : p; };
  Rows r;
  r.inputs = at(b.inputs);
  r.distinct = at(b.distinct);
  r.cBar = at(b.cBar);
  r.drawCount = at(b.drawCount);
  r.canonicalDrawCount = at(b.canonicalDrawCount);
  r.hasSample = at(b.hasSample);
  r.confidence = at(b.confidence);
  r.multiplicity = at(b.multiplicity);
  r.probability = at(b.probability);
  r.canonicalTarget = at(b.canonicalTarget);
  r.ownTarget = at(b.ownTarget);
  r.drawnMultiplicity = at(b.drawnMultiplicity);
  r.drawnProbability = at(b.drawnProbability);
  r.drawnConfidence = at(b.drawnConfidence);
  r.drawnTarget = at(b.drawnTarget);
  r.stride = b.stride;
  // The packet's per-row state is sized for these bounds.
  r.inputRows = std::clamp(b.inputRows, 0, kMaxGrisInputs);
  r.drawRows = std::clamp(b.drawRows, 0, kMaxCanonicalDraws);
  return r;
}

}  // namespace

void StochasticPairwiseKernel(const StochasticPairwiseBatch& b, const StochasticPairwiseOutput& o) {
  const DF df;
  const size_t N = hn::Lanes(df);
  size_t k = 0;
  for (; k + N <= b.count; k += N) SpmisPacket(RowsAt(b, k), o.mis + k, o.canonicalTarget + k);
  if (k == b.count) return;

  // Tail: the remaining combinations copied into a packet of stride N whose extra lanes have no inputs (so
  // every mask is false there and their zeros are never read as values).
  constexpr size_t kLanes = hn::MaxLanes(DF());
  constexpr size_t kRows = kMaxGrisInputs;
  const size_t rest = b.count - k;
  const Rows src = RowsAt(b, k);
  const size_t inputRows = static_cast<size_t>(src.inputRows), drawRows = static_cast<size_t>(src.drawRows);
  HWY_ALIGN int32_t ints[2][kLanes];
  HWY_ALIGN uint8_t hasSample[kRows * kLanes];
  HWY_ALIGN float perCombination[3][kLanes];
  HWY_ALIGN float perInput[5][kRows * kLanes];
  HWY_ALIGN float perDraw[4][kRows * kLanes];
  const auto copy = [&](auto* dst, const auto* from, size_t rows) {
    for (size_t r = 0; r < rows; ++r)
      for (size_t l = 0; l < N; ++l) dst[r * N + l] = l < rest ? from[r * b.stride + l] : 0;
  };
  Rows in = src;
  in.stride = N;
  copy(ints[0], src.inputs, 1);
  in.inputs = ints[0];
  copy(ints[1], src.distinct, 1);
  in.distinct = ints[1];
  copy(hasSample, src.hasSample, inputRows);
  in.hasSample = hasSample;
  const float* const combinationFrom[3] = {src.cBar, src.drawCount, src.canonicalDrawCount};
  const float** const combinationTo[3] = {&in.cBar, &in.drawCount, &in.canonicalDrawCount};
  for (int a = 0; a < 3; ++a) {
    copy(perCombination[a], combinationFrom[a], 1);
    *combinationTo[a] = perCombination[a];
  }
  const float* const inputFrom[5] = {src.confidence, src.multiplicity, src.probability, src.canonicalTarget,
                                     src.ownTarget};
  const float** const inputTo[5] = {&in.confidence, &in.multiplicity, &in.probability, &in.canonicalTarget,
                                    &in.ownTarget};
  for (int a = 0; a < 5; ++a) {
    copy(perInput[a], inputFrom[a], inputRows);
    *inputTo[a] = perInput[a];
  }
  const float* const drawFrom[4] = {src.drawnMultiplicity, src.drawnProbability, src.drawnConfidence,
                                    src.drawnTarget};
  const float** const drawTo[4] = {&in.drawnMultiplicity, &in.drawnProbability, &in.drawnConfidence,
                                   &in.drawnTarget};
  for (int a = 0; a < 4; ++a) {
    copy(perDraw[a], drawFrom[a], drawRows);
    *drawTo[a] = perDraw[a];
  }
  HWY_ALIGN float mis[kRows * kLanes], pc[kRows * kLanes];
  SpmisPacket(in, mis, pc);
  for (size_t l = 0; l < rest; ++l) {
    const int n = std::clamp(static_cast<int>(ints[0][l]), 0, src.inputRows);
    for (int t = 0; t < n; ++t) {
      o.mis[static_cast<size_t>(t) * b.stride + k + l] = mis[static_cast<size_t>(t) * N + l];
      o.canonicalTarget[static_cast<size_t>(t) * b.stride + k + l] = pc[static_cast<size_t>(t) * N + l];
    }
  }
}

const char* SpmisDispatchedTargetName() { return hwy::TargetName(HWY_TARGET); }

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

#include <cmath>

#include "core/simd.h"
#include "core/spmis.h"

namespace restir {

HWY_EXPORT(StochasticPairwiseKernel);
HWY_EXPORT(SpmisDispatchedTargetName);

namespace {


}  // namespace

void StochasticPairwiseWeightsScalar(const StochasticPairwiseBatch& b, const StochasticPairwiseOutput& o) {
  const auto at = [&b](int row, size_t k) { return static_cast<size_t>(row) * b.stride + k; };
  for (size_t k = 0; k < b.count; ++k) {
    const int n = std::clamp(static_cast<int>(b.inputs[k]), 0, std::min(b.inputRows, kMaxGrisInputs));
    if (n == 0) continue;
    const int distinct = std::clamp(static_cast<int>(b.distinct[k]), 0, std::min(b.drawRows, kMaxCanonicalDraws));
    const float cBar = b.cBar[k], cc = b.confidence[at(0, k)];
    const float bigN = b.drawCount[k], nc = b.canonicalDrawCount[k];
    float mis[kMaxGrisInputs] = {}, pc[kMaxGrisInputs] = {};  // initialised for GCC, which cannot see n >= 1
    for (int t = 0; t < n; ++t) {
      mis[t] = 0.0f;
      pc[t] = b.hasSample[at(t, k)] ? b.canonicalTarget[at(t, k)] : 0.0f;
    }
    // Seed 004 Eq. 18-19: base share plus the N_c draws (by P_c) of the pairwise terms.
    if (b.hasSample[at(0, k)] && pc[0] > 0.0f) {
      mis[0] = MisPairwiseCanonicalBase(cBar, cc);
      for (int d = 0; d < distinct; ++d)
        mis[0] += StochasticPairwiseCanonicalTerm(b.drawnMultiplicity[at(d, k)], nc, b.drawnProbability[at(d, k)],
                                                  b.drawnConfidence[at(d, k)], cBar, cc, b.drawnTarget[at(d, k)],
                                                  pc[0]);
    }
    // Seed 004 Eq. 16-17.
    for (int t = 1; t < n; ++t)
      if (b.hasSample[at(t, k)] && pc[t] > 0.0f)
        mis[t] = StochasticPairwiseNonCanonical(b.multiplicity[at(t, k)], bigN, b.probability[at(t, k)],
                                                b.confidence[at(t, k)], cBar, cc, b.ownTarget[at(t, k)], pc[t]);
    for (int t = 0; t < n; ++t) {
      o.mis[at(t, k)] = CanonicalNaN(mis[t]);
      o.canonicalTarget[at(t, k)] = CanonicalNaN(pc[t]);
    }
  }
}

void StochasticPairwiseWeights(const StochasticPairwiseBatch& batch, const StochasticPairwiseOutput& out) {
  if (UseScalarTwins()) return StochasticPairwiseWeightsScalar(batch, out);
  HWY_DYNAMIC_DISPATCH(StochasticPairwiseKernel)(batch, out);
}

const char* StochasticPairwiseKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(SpmisDispatchedTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
