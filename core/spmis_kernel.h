// Stochastic pairwise MIS weights kernel (seed 004 Eq. 15-19; DESIGN §4): a batch of independent combinations,
// one per SIMD lane, computing the weights m̃_t(Y_t) and canonical targets p̂_c(Y_t) that the spatial pass hands
// to GrisResampleBatch, bit for bit as the loop of core/spmis.h functions it replaces (sim/estimator/pipeline.cpp,
// "Stochastic pairwise (seed 004 Eq. 15-19)"):
//
//   pc[t]  = hasSample_t ? p̂_c(Y_t) : 0
//   mis[0] = hasSample_0 && pc[0] > 0
//              ? MisPairwiseCanonicalBase(c̄, c_c) + Σ_{d < D} StochasticPairwiseCanonicalTerm(K_c(d), N_c, P_c(d),
//                                                       c_j(d), c̄, c_c, p̂_j(d)(Y_c), pc[0])   (left to right)
//              : 0
//   mis[t] = hasSample_t && pc[t] > 0                                                        (t >= 1)
//              ? StochasticPairwiseNonCanonical(K(t), N, P(t), c_t, c̄, c_c, p̂_t(Y_t), pc[t]) : 0
//
// with c_c = confidence of input 0 and P_c(d) the probability of drawing draw d's pixel (1/M uniform, or ∝ c_j).
// Two implementations beside each other, as core/gris_kernel.h: a Highway kernel (SSE4, AVX2, AVX-512, a packet of combinations per register) and its
// scalar twin (that loop, literally). Same bits on every target (DESIGN §3); core/simd.h chooses which runs.
//
// Values the loop does not read may hold anything, NaN included (they never reach a result): every entry past a
// combination's input count or distinct-draw count, and c̄, N, N_c, K, P, P_c, c_j, p̂_t(Y_t), p̂_j(Y_c) of
// inputs whose weight the guards above set to 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/gris.h"
#include "core/gris_kernel.h"

namespace restir {

// Distinct canonical draws per combination at most (N_c <= kMaxGrisInputs - 1, sim/estimator/settings.cpp).
inline constexpr int kMaxCanonicalDraws = kMaxGrisInputs - 1;

// Inputs of `count` combinations, structure-of-arrays as GrisBatch: combination k's value for input t is
// element [t * stride + k] of each per-input array (inputRows rows), for canonical draw d element
// [d * stride + k] of each per-draw array (drawRows rows), and element [k] of each per-combination array.
struct StochasticPairwiseBatch {
  size_t count = 0;                    // combinations (one SIMD lane each)
  size_t stride = 0;                   // distance between rows, >= count
  int inputRows = kMaxGrisInputs;      // rows of the per-input arrays, 1..kMaxGrisInputs (GrisBatch::matrixSize)
  int drawRows = kMaxCanonicalDraws;   // rows of the per-draw arrays, 0..kMaxCanonicalDraws
  // Per combination.
  const int32_t* inputs = nullptr;     // n: inputs, 0..inputRows (input 0 canonical; 0: nothing is written)
  const int32_t* distinct = nullptr;   // D: distinct canonical draws, 0..drawRows
  const float* cBar = nullptr;         // c̄: scaled confidence sum of the cell (seed 004 §4.3)
  const float* drawCount = nullptr;    // N: non-canonical draws
  const float* canonicalDrawCount = nullptr;  // N_c: canonical draws
  // Per input t.
  const uint8_t* hasSample = nullptr;        // GrisInput::hasSample (nonzero: true)
  const float* confidence = nullptr;         // c_t, already scaled (input 0: c_c)
  const float* multiplicity = nullptr;       // K(t) (t >= 1)
  const float* probability = nullptr;        // P(t) (t >= 1)
  const float* canonicalTarget = nullptr;    // p̂_c(Y_t): target(0, t)
  const float* ownTarget = nullptr;          // p̂_t(Y_t): target(t, t) (t >= 1)
  // Per distinct canonical draw d (of pixel j).
  const float* drawnMultiplicity = nullptr;  // K_c(j)
  const float* drawnProbability = nullptr;   // P_c(j): the probability of drawing j in one canonical draw
  const float* drawnConfidence = nullptr;    // c_j, scaled as the inputs' confidences are
  const float* drawnTarget = nullptr;        // p̂_j(Y_c): target(count + d, 0)
};

// Where the results go, rows of the batch's stride: element [t * stride + k] for t < inputs[k] is written and
// nothing else, so these can be GrisBatchArrays::mis and ::canonicalTarget of the GrisBatch the weights are
// for. A NaN is written as std::numeric_limits<float>::quiet_NaN() (as core/gris_kernel.h GrisBatchOutput;
// GrisResample treats every NaN alike). `canonicalTarget` may be the batch's canonicalTarget array itself.
struct StochasticPairwiseOutput {
  float* mis = nullptr;              // m̃_t(Y_t) (GrisBatch::mis)
  float* canonicalTarget = nullptr;  // hasSample_t ? p̂_c(Y_t) : 0 (GrisBatch::canonicalTarget)
};

// The arrays a GrisBatchArrays lacks, owned: the batch takes count, stride, inputRows (matrixSize), inputs,
// hasSample and confidence from the GrisBatchArrays the weights are for, so a caller fills that one as for
// GrisResampleBatch, then these.
struct StochasticPairwiseArrays {
  size_t stride = 0;
  int inputRows = kMaxGrisInputs;
  int drawRows = kMaxCanonicalDraws;
  std::vector<int32_t> distinct;                                              // per combination
  std::vector<float> cBar, drawCount, canonicalDrawCount;                    // per combination
  std::vector<float> multiplicity, probability, canonicalTarget, ownTarget;  // per input
  std::vector<float> drawnMultiplicity, drawnProbability, drawnConfidence, drawnTarget;  // per draw

  // Sizes every array for `gris` (its stride and matrixSize) and `draws` rows of draws, zero-filled.
  void Resize(const GrisBatchArrays& gris, int draws = kMaxCanonicalDraws) {
    stride = gris.stride;
    inputRows = gris.matrixSize;
    drawRows = draws;
    distinct.assign(stride, 0);
    for (auto* v : {&cBar, &drawCount, &canonicalDrawCount}) v->assign(stride, 0.0f);
    for (auto* v : {&multiplicity, &probability, &canonicalTarget, &ownTarget})
      v->assign(static_cast<size_t>(inputRows) * stride, 0.0f);
    for (auto* v : {&drawnMultiplicity, &drawnProbability, &drawnConfidence, &drawnTarget})
      v->assign(static_cast<size_t>(drawRows) * stride, 0.0f);
  }
  // Element of input t, and of canonical draw d, of combination k.
  size_t At(int t, size_t k) const { return static_cast<size_t>(t) * stride + k; }
  size_t DrawAt(int d, size_t k) const { return static_cast<size_t>(d) * stride + k; }

  StochasticPairwiseBatch View(const GrisBatchArrays& gris) const {
    StochasticPairwiseBatch b;
    b.count = gris.count;
    b.stride = gris.stride;
    b.inputRows = gris.matrixSize;
    b.drawRows = drawRows;
    b.inputs = gris.inputs.data();
    b.hasSample = gris.hasSample.data();
    b.confidence = gris.confidence.data();
    b.distinct = distinct.data();
    b.cBar = cBar.data();
    b.drawCount = drawCount.data();
    b.canonicalDrawCount = canonicalDrawCount.data();
    b.multiplicity = multiplicity.data();
    b.probability = probability.data();
    b.canonicalTarget = canonicalTarget.data();
    b.ownTarget = ownTarget.data();
    b.drawnMultiplicity = drawnMultiplicity.data();
    b.drawnProbability = drawnProbability.data();
    b.drawnConfidence = drawnConfidence.data();
    b.drawnTarget = drawnTarget.data();
    return b;
  }
};

// The output rows GrisResampleBatch reads for `gris`.
inline StochasticPairwiseOutput StochasticPairwiseOutputInto(GrisBatchArrays& gris) {
  return StochasticPairwiseOutput{gris.mis.data(), gris.canonicalTarget.data()};
}

// The weights of every combination, on the target core/simd.h selects (the scalar twin for SimdTarget::kScalar).
void StochasticPairwiseWeights(const StochasticPairwiseBatch& batch, const StochasticPairwiseOutput& out);
// The scalar twin: the per-combination loop of core/spmis.h functions (tests and benchmarks).
void StochasticPairwiseWeightsScalar(const StochasticPairwiseBatch& batch, const StochasticPairwiseOutput& out);

// Name of the Highway target StochasticPairwiseWeights runs on now, e.g. "AVX3", or "scalar" for the twin.
const char* StochasticPairwiseKernelDispatchedTargetName();

}  // namespace restir
