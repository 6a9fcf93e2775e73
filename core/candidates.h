// Candidate sources of initial sampling (DESIGN §4 "Candidate sources"; RTXDI's InitialSamplingFunctions):
// points on local lights, directions in the sun's cone, directions from the environment map and BSDF-sampled
// rays, each with its count. A candidate y from any source enters streaming RIS with the weight
//   w(y) = p̂(y) / Σ_t M_t p_t(y)                                      (multiple-importance RIS, balance heuristic)
// where the sum runs over every source t that could have produced y, in y's own measure (area for a point on a
// local light, solid angle for a direction), and the reservoir is finalised W = Σ w / p̂(Y). This is RIS with the
// balance heuristic over the sources as MIS weights, m_s(y) = p_s(y) / Σ_t M_t p_t(y), which sum to one over the
// M = Σ M_t candidates wherever any source can produce y (Talbot et al. 2005 §4; seed 000 Eq. 1-3 with the
// generalized balance weights), so the estimator stays unbiased for every mix of counts.
//
// A sample on a local light lives on the lights' surfaces and a direction on the sky's sphere: the two domains
// are disjoint, so a local point is produced by the local-light and BSDF sources only, a direction by the sun,
// environment and BSDF sources only. A BSDF ray that hits a front-facing emitter gives that point; one that hits
// nothing gives its direction; one that hits anything else gives no candidate (it still counts in M_b).
#pragma once

#include <cmath>
#include <limits>

#include "core/math.h"

namespace restir {

// How many candidates each source draws for one pixel (RTXDI's numPrimaryLocalLightSamples,
// numPrimaryInfiniteLightSamples, numPrimaryEnvironmentSamples, numPrimaryBrdfSamples). A source with nothing to
// sample (no local lights, no sun, no environment) must be given 0: its candidates would count in M without
// being able to produce anything, and Σ_t M_t p_t would no longer match the candidates drawn.
struct CandidateCounts {
  int local = 0;        // M_l: a light by power (or uniformly), then a uniform point on it
  int sun = 0;          // M_s: a direction uniform in the sun's cone
  int environment = 0;  // M_e: a direction from the environment map's importance sampler
  int brdf = 0;         // M_b: a direction from the BSDF, traced to an emitter or the sky
  int Total() const { return local + sun + environment + brdf; }
};

// The longest a BSDF ray is traced (RTXDI_BrdfMaxDistanceFromPdf): with cutoff c > 0, sqrt((1/c - 1) pdf), so a
// direction the BSDF samples rarely only finds lights near the receiver, where the light sampler's area density
// converted to solid angle is weak too. c = 0 traces to infinity. The same distance decides whether the BSDF
// source could have produced a local point (BrdfAreaPdf), which keeps the weights consistent with the rays.
inline float BrdfRayMaxDistance(float cutoff, float bsdfPdf) {
  return cutoff > 0.0f ? std::sqrt((1.0f / cutoff - 1.0f) * bsdfPdf) : std::numeric_limits<float>::infinity();
}

// The BSDF source's density of a point y on a local light, in area measure: p_bsdf(ω) cos θ_y / d², zero beyond
// the ray's maximum distance (the ray would have stopped short of y).
inline float BrdfAreaPdf(float bsdfPdf, float cosY, float distance, float cutoff) {
  if (!(bsdfPdf > 0.0f) || !(cosY > 0.0f) || distance > BrdfRayMaxDistance(cutoff, bsdfPdf)) return 0.0f;
  return bsdfPdf * cosY / (distance * distance);
}

// Σ_t M_t p_t(y) for a point on a local light: M_l p_area(y) + M_b p_bsdf,area(y).
inline float MixedPointPdf(const CandidateCounts& m, float lightPdfArea, float brdfPdfArea) {
  return static_cast<float>(m.local) * lightPdfArea + static_cast<float>(m.brdf) * brdfPdfArea;
}

// Σ_t M_t p_t(ω) for a direction to the sky, in solid angle: M_s p_sun(ω) + M_e p_env(ω) + M_b p_bsdf(ω). The BSDF
// ray towards the sky is never shortened (RTXDI's cutoff "does not apply to environment map sampling"): where the
// sky is visible along ω the ray escapes, so the BSDF source produces ω with density p_bsdf(ω).
inline float MixedDirectionPdf(const CandidateCounts& m, float sunPdf, float environmentPdf, float bsdfPdf) {
  return static_cast<float>(m.sun) * sunPdf + static_cast<float>(m.environment) * environmentPdf +
         static_cast<float>(m.brdf) * bsdfPdf;
}

// The resampling weight of a candidate: p̂(y) / Σ_t M_t p_t(y); 0 when no source has density there.
inline float MixedRisWeight(float targetPdf, float mixedPdf) {
  return mixedPdf > 0.0f ? targetPdf / mixedPdf : 0.0f;
}

// W of a reservoir streamed with MixedRisWeight: Σ w / p̂(Y) (the 1/M of FinalizeRis is inside the weights).
inline float MixedRisContributionWeight(float weightSum, float targetPdf) {
  return targetPdf > 0.0f ? weightSum / targetPdf : 0.0f;
}

}  // namespace restir
