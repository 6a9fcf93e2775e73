// Stochastic pairwise MIS (seed 004 §3-4; DESIGN §4): unbiased reuse from the M pixels of a screen-space cell
// while evaluating only N of them. The deterministic pairwise weights (core/mis.h, seed 004 Eq. 11) are replaced
// by unbiased estimates built from random draws, so E[m̃_i] = m_i and the GRIS estimator stays unbiased.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/math.h"
#include "core/mis.h"

namespace restir {

// Stochastic resampling MIS weight (seed 004 Eq. 15-16): with N draws with replacement, P(i) the probability of
// drawing i in one draw and K(i) how often it was drawn, m̃_i = K(i) / (N P(i)) · m_i. E[K(i)] = N P(i).
inline float StochasticMisWeight(float multiplicity, float drawCount, float probability, float misWeight) {
  return probability > 0.0f && drawCount > 0.0f ? multiplicity / (drawCount * probability) * misWeight : 0.0f;
}

// Non-canonical stochastic pairwise weight (seed 004 Eq. 16-17): m̃_i(Y_i) with m_i from Eq. 11a.
inline float StochasticPairwiseNonCanonical(float multiplicity, float drawCount, float probability, float ci,
                                            float cBar, float cc, float targetI, float targetC) {
  return StochasticMisWeight(multiplicity, drawCount, probability,
                             MisPairwiseNonCanonical(ci, cBar, cc, targetI, targetC));
}

// One draw's term of the canonical stochastic pairwise weight (seed 004 Eq. 18-19):
// K_c(j) / (N_c P_c(j)) · c_j/(c̄+c_c) · c_c p̂_c(Y_c) / (c̄ p̂_j(Y_c) + c_c p̂_c(Y_c)).
// The canonical weight is MisPairwiseCanonicalBase(c̄, c_c) plus this term summed over the distinct drawn j.
inline float StochasticPairwiseCanonicalTerm(float multiplicity, float drawCount, float probability, float cj,
                                             float cBar, float cc, float targetJ, float targetC) {
  return StochasticMisWeight(multiplicity, drawCount, probability,
                             MisPairwiseCanonicalTerm(cj, cBar, cc, targetJ, targetC));
}

// Confidence adjustment (seed 004 §4.3): each non-canonical confidence, hence c̄, is scaled by N/M, because
// the estimator effectively reuses N of the M candidates; without it the canonical sample's share collapses as
// M grows (dark pepper noise, seed 004 Fig. 2). Capped at 1 when N > M (the paper is silent there): N draws
// cannot reuse more than the M candidates, so the cell counts at most its own Σ c_i. Uncapped, a small cell
// would claim more confidence than it holds (a 2-pixel cell drawn 10 times: 5× its history), shrinking the
// canonical sample's share below what deterministic pairwise MIS over the whole cell gives it (the estimator's
// limit as N grows) and inflating the output confidence temporal reuse carries on. The factor, once per pixel:
inline float ConfidenceScale(float drawCount, float candidateCount) {
  return candidateCount > 0.0f ? std::min(1.0f, drawCount / candidateCount) : 1.0f;
}
inline float ScaledConfidence(float confidence, float drawCount, float candidateCount) {
  return confidence * ConfidenceScale(drawCount, candidateCount);
}

// Selection weight of cell pixel i for the N non-canonical draws (seed 004 Eq. 17): P(i) ∝ c_i p̂_i(X_i) W_i, the
// pixel's own unshifted estimate weighted by its confidence (0 for an empty reservoir).
inline float StochasticPairwiseDrawWeight(float confidence, float targetPdf, float W) {
  return confidence * targetPdf * W;
}

// Index drawn from a discrete distribution given by its running (inclusive) cumulative sums, by bisection.
// `u` in [0, 1). Zero-probability entries are never returned.
inline int SampleCumulative(const float* cumulative, int count, float u) {
  const float target = u * cumulative[count - 1];
  int lo = 0, hi = count - 1;
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (cumulative[mid] > target) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

// Octahedral quantisation of a unit normal into bins x bins cells (Meyer et al. 2010 octahedral map), for
// grouping the pixels of a tile by orientation.
inline uint32_t QuantiseNormal(const Vec3& n, uint32_t bins) {
  const float l1 = std::abs(n.x) + std::abs(n.y) + std::abs(n.z);
  float px = n.x / l1, py = n.y / l1;
  if (n.z < 0.0f) {
    const float ox = (1.0f - std::abs(py)) * (px >= 0.0f ? 1.0f : -1.0f);
    const float oy = (1.0f - std::abs(px)) * (py >= 0.0f ? 1.0f : -1.0f);
    px = ox, py = oy;
  }
  const auto bin = [bins](float v) {
    const int b = static_cast<int>((v * 0.5f + 0.5f) * static_cast<float>(bins));
    return static_cast<uint32_t>(std::clamp(b, 0, static_cast<int>(bins) - 1));
  };
  return bin(px) + bins * bin(py);
}

// PCG hash (O'Neill 2014; the RXS-M-XS 32-bit output function as used for GPU hashing) for cell keys.
inline uint32_t PcgHash(uint32_t v) {
  const uint32_t state = v * 747796405u + 2891336453u;
  const uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// Cell key of seed 004 §5: a hash of (tile, object id, quantised normal).
inline uint32_t CellKey(uint32_t tile, uint32_t objectId, uint32_t quantisedNormal) {
  return PcgHash(tile ^ PcgHash(objectId ^ PcgHash(quantisedNormal)));
}

}  // namespace restir
