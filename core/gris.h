// Generalized RIS combination of reservoirs (seed 000 Eq. 1-2; seed 004 Eq. 5-7; DESIGN §4). For DI the shift
// is the identity on the light point with Jacobian 1. Input 0 is the canonical one (the pixel's own reservoir).
//
// The caller supplies target(j, i) = p̂_j(Y_i): the target function of input j's domain (its surface, frame and,
// with ray-traced bias correction, its visibility) evaluated at input i's sample. target(0, i) is also the
// output's target p̂_c. Only the entries a family needs are requested, so callers may trace rays lazily.
#pragma once

#include <cstdint>

#include "core/mis.h"

namespace restir {

inline constexpr int kMaxGrisInputs = 16;

struct GrisInput {
  bool hasSample = false;  // false: an empty or rejected reservoir (it still counts its confidence)
  float W = 0.0f;          // unbiased contribution weight of Y_i in its own domain
  float confidence = 0.0f; // c_i (already capped by the caller)
  float visibility = 1.0f; // V_i carried for the visibility estimate (seed 000 Eq. 4)
};

// How the output's carried visibility is formed.
enum class VisibilityCarry : uint8_t {
  kSelected,  // keep V of the selected sample (Wyman & Panteleev 2021; seed 000's "previous method")
  kWeighted,  // V_X = Σ V_i w_i / Σ w_i (seed 000 Eq. 4, Algorithm 1)
};

struct GrisResult {
  int selected = -1;          // index of the chosen input; -1 when every weight was zero
  float weightSum = 0.0f;     // Σ w_i
  float W = 0.0f;             // unbiased contribution weight of the selected sample in the canonical domain
  float confidence = 0.0f;    // Σ c_i
  float visibility = 0.0f;    // carried visibility of the output
  int guarded = 0;            // non-finite weights dropped (reported, DESIGN §10)
};

// Resampling weight of input i: w_i = m_i(Y_i) p̂_c(Y_i) W_i (seed 000 Eq. 1).
inline float GrisWeight(float mis, float canonicalTarget, float W) { return mis * canonicalTarget * W; }

// Contribution weight of the output: W_Y = Σ w_i / p̂_c(Y) (seed 000 Eq. 2); 0 when p̂_c(Y) = 0.
inline float GrisContributionWeight(float weightSum, float canonicalTargetOfSelected) {
  return canonicalTargetOfSelected > 0.0f ? weightSum / canonicalTargetOfSelected : 0.0f;
}

// Combines `count` inputs with one MIS family. `u[i]` are uniforms in [0, 1) for the streaming selection.
template <typename TargetFn>
GrisResult GrisCombine(MisFamily family, const GrisInput* in, int count, TargetFn&& target, const float* u,
                       VisibilityCarry carry) {
  GrisResult r;
  float confidenceSum = 0.0f, cBar = 0.0f;
  for (int i = 0; i < count; ++i) confidenceSum += in[i].confidence;
  cBar = confidenceSum - in[0].confidence;
  const float cc = in[0].confidence;
  float canonicalTargetOfSelected = 0.0f, visWeighted = 0.0f;

  for (int i = 0; i < count; ++i) {
    if (!in[i].hasSample) continue;
    if (!IsFiniteWeight(in[i].W)) {  // a NaN or infinite W is dropped and counted (DESIGN §10)
      ++r.guarded;
      continue;
    }
    if (!(in[i].W > 0.0f)) continue;
    const float pc = target(0, i);  // p̂_c(Y_i)
    if (!IsFiniteWeight(pc)) {
      ++r.guarded;
      continue;
    }
    if (!(pc > 0.0f)) continue;
    float m = 0.0f;
    switch (family) {
      case MisFamily::kUniform:
        m = MisUniform(in[i].confidence, confidenceSum);
        break;
      case MisFamily::kZ:
        // 1/Z is applied after selection (Bitterli 2020): resample with c_i alone.
        m = in[i].confidence;
        break;
      case MisFamily::kBalance: {
        float c[kMaxGrisInputs], t[kMaxGrisInputs];
        for (int j = 0; j < count; ++j) c[j] = in[j].confidence, t[j] = j == 0 ? pc : target(j, i);
        m = MisBalance(i, c, t, count);
        break;
      }
      case MisFamily::kPairwise:
      case MisFamily::kStochasticPairwise:
        if (i == 0) {
          m = MisPairwiseCanonicalBase(cBar, cc);
          for (int j = 1; j < count; ++j)
            m += MisPairwiseCanonicalTerm(in[j].confidence, cBar, cc, target(j, 0), pc);
        } else {
          m = MisPairwiseNonCanonical(in[i].confidence, cBar, cc, target(i, i), pc);
        }
        break;
    }
    const float w = GrisWeight(m, pc, in[i].W);
    if (!IsFiniteWeight(w)) {
      ++r.guarded;
      continue;
    }
    if (!(w > 0.0f)) continue;
    r.weightSum += w;
    visWeighted += in[i].visibility * w;
    if (u[i] * r.weightSum < w) {
      r.selected = i;
      canonicalTargetOfSelected = pc;
    }
  }
  r.confidence = confidenceSum;
  if (r.selected < 0) return r;
  float wSum = r.weightSum;
  if (family == MisFamily::kZ) {
    // Z = Σ c_j over inputs whose domain can produce Y (target > 0, with visibility when ray traced).
    float z = 0.0f;
    for (int j = 0; j < count; ++j)
      if ((j == 0 ? canonicalTargetOfSelected : target(j, r.selected)) > 0.0f) z += in[j].confidence;
    wSum = z > 0.0f ? wSum / z : 0.0f;
  }
  r.W = GrisContributionWeight(wSum, canonicalTargetOfSelected);
  r.visibility = carry == VisibilityCarry::kWeighted ? (r.weightSum > 0.0f ? visWeighted / r.weightSum : 0.0f)
                                                     : in[r.selected].visibility;
  return r;
}

}  // namespace restir
