// Resampling MIS weights for GRIS combination (DESIGN §4). For ReSTIR DI the shift is the identity on the
// light point, so an input sample Y_i is evaluated directly in every domain. Each function returns m_i(y) for
// one input; tests check that every family is a partition of unity over the inputs that can produce y.
#pragma once

#include <cmath>
#include <cstdint>

namespace restir {

enum class MisFamily : uint8_t {
  kUniform,             // m_i = c_i / Σ c_j (Bitterli 2020, biased)
  kZ,                   // 1/Z: c_i / Σ_{j: p̂_j(y) > 0} c_j (Bitterli 2020, unbiased)
  kBalance,             // generalized balance heuristic (seed 000 Eq. 3)
  kPairwise,            // defensive pairwise (seed 004 Eq. 11)
  kStochasticPairwise,  // stochastic pairwise over screen-space cells (seed 004 Eq. 15-19)
};

// The family's name as presets and --set spell it ("uniform", "z", "balance", "pairwise", "stochastic-pairwise").
inline const char* MisFamilyName(MisFamily f) {
  switch (f) {
    case MisFamily::kUniform: return "uniform";
    case MisFamily::kZ: return "z";
    case MisFamily::kBalance: return "balance";
    case MisFamily::kPairwise: return "pairwise";
    case MisFamily::kStochasticPairwise: return "stochastic-pairwise";
  }
  return "?";
}

// Resampling weights must be finite; a NaN or Inf weight is dropped and counted by the caller (DESIGN §10).
inline bool IsFiniteWeight(float w) { return std::isfinite(w); }

// m_i = c_i / Σ_j c_j (Bitterli 2020, "uniform" weights; biased when some input cannot produce y).
inline float MisUniform(float confidence, float confidenceSum) {
  return confidenceSum > 0.0f ? confidence / confidenceSum : 0.0f;
}

// Generalized balance heuristic with confidence weights (seed 000 Eq. 3):
// m_i(y) = c_i p̂_i(y) / Σ_j c_j p̂_j(y). `targets[j]` holds p̂_j(y) for every input j.
inline float MisBalance(int i, const float* confidences, const float* targets, int count) {
  float denom = 0.0f;
  for (int j = 0; j < count; ++j) denom += confidences[j] * targets[j];
  return denom > 0.0f ? confidences[i] * targets[i] / denom : 0.0f;
}

// Defensive pairwise MIS, non-canonical input i (seed 004 Eq. 11a), with c̄ = Σ_{j≠c} c_j:
// m_i(y) = c_i/(c̄+c_c) · c̄ p̂_i(y) / (c̄ p̂_i(y) + c_c p̂_c(y)).
inline float MisPairwiseNonCanonical(float ci, float cBar, float cc, float targetI, float targetC) {
  const float total = cBar + cc;
  const float denom = cBar * targetI + cc * targetC;
  if (!(total > 0.0f) || !(denom > 0.0f)) return 0.0f;
  return ci / total * (cBar * targetI / denom);
}

// Defensive pairwise MIS, canonical input: one term of the sum in seed 004 Eq. 11b for non-canonical input j
// evaluated at the canonical sample y: c_j/(c̄+c_c) · c_c p̂_c(y) / (c̄ p̂_j(y) + c_c p̂_c(y)).
inline float MisPairwiseCanonicalTerm(float cj, float cBar, float cc, float targetJ, float targetC) {
  const float total = cBar + cc;
  const float denom = cBar * targetJ + cc * targetC;
  if (!(total > 0.0f)) return 0.0f;
  // When neither domain can produce y the pair's mass goes to the canonical input (defensive).
  if (!(denom > 0.0f)) return cj / total;
  return cj / total * (cc * targetC / denom);
}

// The canonical input's own share c_c/(c̄+c_c), to which MisPairwiseCanonicalTerm over j ≠ c is added
// (seed 004 Eq. 11b).
inline float MisPairwiseCanonicalBase(float cBar, float cc) {
  const float total = cBar + cc;
  return total > 0.0f ? cc / total : 0.0f;
}

}  // namespace restir
