// GRIS-combination kernel (DESIGN §2 "TemporalReuse", "SpatialReuse"; §4 GRIS combine): a batch of independent
// combinations, one per SIMD lane, computing what core/gris.h GrisCombine (deterministic MIS families) and
// GrisResample (given MIS weights: stochastic pairwise) compute, bit for bit.
//
// Two implementations beside each other, as core/ris_kernel.h: a Highway kernel (dynamic dispatch over SSE4,
// AVX2, AVX-512: a packet of combinations per register) and its scalar twin (a loop of GrisCombine /
// GrisResample). Same bits on every target (DESIGN §3); core/simd.h chooses which one runs.
//
// Which target entries must hold the values GrisCombine would read (every other entry may hold anything, NaN
// included: it never reaches a result). With p̂_c(Y_i) = target(0, i), input i "eligible" when it has a sample
// with 0 < W_i < ∞, and "valid" when eligible and 0 < p̂_c(Y_i) < ∞:
//   every family: target(0, i) for eligible i;
//   kBalance:     target(j, i) for every j < inputs and valid i (seed 000 Eq. 3);
//   kPairwise:    target(j, 0) for 1 <= j < inputs when input 0 is valid, target(i, i) for valid i >= 1
//                 (seed 004 Eq. 11);
//   kZ:           target(j, s) for 1 <= j < inputs, s the selected input (known only after selection: a
//                 caller that evaluates entries lazily finds s with a dry run, as sim/estimator/pipeline.cpp does);
//   kUniform:     nothing more.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/gris.h"
#include "core/mis.h"

namespace restir {

// Inputs of `count` combinations, structure-of-arrays: combination k's value for input i is element
// [i * stride + k] of each per-input array (rows i < matrixSize must exist).
struct GrisBatch {
  size_t count = 0;                   // combinations (one SIMD lane each)
  size_t stride = 0;                  // distance between rows, >= count
  int matrixSize = kMaxGrisInputs;    // M: inputs per combination at most, 1..kMaxGrisInputs; sizes the matrix
  const int32_t* inputs = nullptr;    // per combination: its number of inputs, 0..M (input 0 canonical; 0: empty)
  const uint8_t* hasSample = nullptr; // GrisInput::hasSample (nonzero: true)
  const float* W = nullptr;           // GrisInput::W
  const float* confidence = nullptr;  // GrisInput::confidence
  const float* visibility = nullptr;  // GrisInput::visibility
  const float* u = nullptr;           // streaming-selection uniforms u[i] (GrisCombine's `u`)
  const float* target = nullptr;  // GrisCombineBatch only: p̂_j(Y_i) (target(j, i)) at [(j * M + i) * stride + k]
  const float* mis = nullptr;              // GrisResampleBatch only: m_i(Y_i) at [i * stride + k]
  const float* canonicalTarget = nullptr;  // GrisResampleBatch only: p̂_c(Y_i) at [i * stride + k]
};

// A GrisBatch's arrays, owned: callers fill the vectors (rows of `stride`, matrixSize rows per input array and
// matrixSize² for the matrix) and pass View().
struct GrisBatchArrays {
  size_t count = 0;                  // GrisBatch::count
  size_t stride = 0;                 // GrisBatch::stride
  int matrixSize = kMaxGrisInputs;   // GrisBatch::matrixSize
  std::vector<int32_t> inputs;       // GrisBatch::inputs
  std::vector<uint8_t> hasSample;    // GrisBatch::hasSample
  std::vector<float> W, confidence, visibility, u;  // GrisBatch's per-input arrays
  std::vector<float> target;                        // GrisBatch::target
  std::vector<float> mis, canonicalTarget;          // GrisBatch::mis, GrisBatch::canonicalTarget
  GrisBatch View() const {
    GrisBatch b;
    b.count = count;
    b.stride = stride;
    b.matrixSize = matrixSize;
    b.inputs = inputs.data();
    b.hasSample = hasSample.data();
    b.W = W.data();
    b.confidence = confidence.data();
    b.visibility = visibility.data();
    b.u = u.data();
    b.target = target.data();
    b.mis = mis.data();
    b.canonicalTarget = canonicalTarget.data();
    return b;
  }
  // Element of input i of combination k, and of target(j, i) of combination k.
  size_t At(int i, size_t k) const { return static_cast<size_t>(i) * stride + k; }
  size_t TargetAt(int j, int i, size_t k) const {
    return (static_cast<size_t>(j) * static_cast<size_t>(matrixSize) + static_cast<size_t>(i)) * stride + k;
  }
};

// Per combination: the fields of its GrisResult. A NaN is written as std::numeric_limits<float>::quiet_NaN():
// its payload would otherwise depend on how the compiler ordered the operands of a commutative operation, not
// on the inputs (as core/target_kernel.h).
struct GrisBatchOutput {
  int32_t* selected = nullptr;  // GrisResult::selected (-1: every weight was zero)
  float* weightSum = nullptr;   // GrisResult::weightSum
  float* W = nullptr;           // GrisResult::W
  float* confidence = nullptr;  // GrisResult::confidence
  float* visibility = nullptr;  // GrisResult::visibility
  int32_t* guarded = nullptr;   // GrisResult::guarded
};

// GrisCombine(family, ...) per combination, on the target core/simd.h selects (the scalar twin for
// SimdTarget::kScalar). kStochasticPairwise combines as kPairwise, as GrisCombine does.
void GrisCombineBatch(MisFamily family, VisibilityCarry carry, const GrisBatch& batch, const GrisBatchOutput& out);
// The scalar twin: a loop of GrisCombine reading the matrix (tests and benchmarks).
void GrisCombineBatchScalar(MisFamily family, VisibilityCarry carry, const GrisBatch& batch,
                            const GrisBatchOutput& out);

// GrisResample(inputs, mis, canonicalTarget, ...) per combination (batch.mis and batch.canonicalTarget given;
// entries of inputs without a sample are never read).
void GrisResampleBatch(VisibilityCarry carry, const GrisBatch& batch, const GrisBatchOutput& out);
// The scalar twin: a loop of GrisResample.
void GrisResampleBatchScalar(VisibilityCarry carry, const GrisBatch& batch, const GrisBatchOutput& out);

// Name of the Highway target the dispatched kernels run on now, e.g. "AVX3", or "scalar" for the twins (tests).
const char* GrisKernelDispatchedTargetName();

}  // namespace restir
