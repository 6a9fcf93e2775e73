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

// Streams inputs with given MIS weights m_i(Y_i) and canonical targets p̂_c(Y_i) (seed 000 Eq. 1-2): the shared
// core of every family, deterministic or stochastic. The output W here is Σ w_i / p̂_c(Y) (the z family
// rescales it after selection).
inline GrisResult GrisResample(const GrisInput* in, const float* mis, const float* canonicalTarget, int count,
                               const float* u, VisibilityCarry carry) {
  GrisResult r;
  float canonicalTargetOfSelected = 0.0f, visWeighted = 0.0f;
  for (int i = 0; i < count; ++i) {
    r.confidence += in[i].confidence;
    if (!in[i].hasSample) continue;
    if (!IsFiniteWeight(in[i].W) || !IsFiniteWeight(canonicalTarget[i]) || !IsFiniteWeight(mis[i])) {
      ++r.guarded;  // a NaN or infinite input is dropped and counted (DESIGN §10)
      continue;
    }
    if (!(in[i].W > 0.0f) || !(canonicalTarget[i] > 0.0f)) continue;
    const float w = GrisWeight(mis[i], canonicalTarget[i], in[i].W);
    if (!IsFiniteWeight(w)) {
      ++r.guarded;
      continue;
    }
    if (!(w > 0.0f)) continue;
    r.weightSum += w;
    visWeighted += in[i].visibility * w;
    if (u[i] * r.weightSum < w) {
      r.selected = i;
      canonicalTargetOfSelected = canonicalTarget[i];
    }
  }
  if (r.selected < 0) return r;
  r.W = GrisContributionWeight(r.weightSum, canonicalTargetOfSelected);
  r.visibility = carry == VisibilityCarry::kWeighted ? visWeighted / r.weightSum : in[r.selected].visibility;
  return r;
}

// Combines `count` inputs with one deterministic MIS family. `u[i]` are uniforms in [0, 1) for the streaming
// selection.
template <typename TargetFn>
GrisResult GrisCombine(MisFamily family, const GrisInput* in, int count, TargetFn&& target, const float* u,
                       VisibilityCarry carry) {
  float confidenceSum = 0.0f;
  for (int i = 0; i < count; ++i) confidenceSum += in[i].confidence;
  const float cc = in[0].confidence;
  const float cBar = confidenceSum - cc;
  float mis[kMaxGrisInputs], pc[kMaxGrisInputs];
  for (int i = 0; i < count; ++i) {
    mis[i] = 0.0f;
    pc[i] = 0.0f;
    // Targets are only evaluated for inputs that can contribute (callers may trace rays for them).
    if (!in[i].hasSample || !(in[i].W > 0.0f) || !IsFiniteWeight(in[i].W)) continue;
    pc[i] = target(0, i);  // p̂_c(Y_i)
    if (!(pc[i] > 0.0f) || !IsFiniteWeight(pc[i])) continue;
    switch (family) {
      case MisFamily::kUniform:
        mis[i] = MisUniform(in[i].confidence, confidenceSum);
        break;
      case MisFamily::kZ:
        // 1/Z is applied after selection (Bitterli 2020): resample with c_i alone.
        mis[i] = in[i].confidence;
        break;
      case MisFamily::kBalance: {
        float c[kMaxGrisInputs], t[kMaxGrisInputs];
        for (int j = 0; j < count; ++j) c[j] = in[j].confidence, t[j] = j == 0 ? pc[i] : target(j, i);
        mis[i] = MisBalance(i, c, t, count);
        break;
      }
      case MisFamily::kPairwise:
      case MisFamily::kStochasticPairwise:
        if (i == 0) {
          mis[i] = MisPairwiseCanonicalBase(cBar, cc);
          for (int j = 1; j < count; ++j)
            mis[i] += MisPairwiseCanonicalTerm(in[j].confidence, cBar, cc, target(j, 0), pc[0]);
        } else {
          mis[i] = MisPairwiseNonCanonical(in[i].confidence, cBar, cc, target(i, i), pc[i]);
        }
        break;
    }
  }
  GrisResult r = GrisResample(in, mis, pc, count, u, carry);
  if (family == MisFamily::kZ && r.selected >= 0) {
    // Z = Σ c_j over inputs whose domain can produce Y (target > 0, with visibility when ray traced).
    float z = 0.0f;
    for (int j = 0; j < count; ++j)
      if ((j == 0 ? pc[r.selected] : target(j, r.selected)) > 0.0f) z += in[j].confidence;
    r.W = z > 0.0f ? r.W / z : 0.0f;
  }
  return r;
}

}  // namespace restir
