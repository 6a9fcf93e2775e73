// The reservoir and streaming RIS (seed 003 §1; DESIGN §4). Pure functions: every random number is an
// argument, so scalar and SIMD twins and tests drive them identically.
#pragma once

#include <cstdint>

#include "core/light.h"

namespace restir {

struct Reservoir {
  LightSample sample;       // selected light point Y (light id, p_y, n_y, L_e, p_src)
  float weightSum = 0.0f;   // running sum of resampling weights w_j
  float targetPdf = 0.0f;   // p̂(Y) at the receiver that selected it
  float W = 0.0f;           // unbiased contribution weight of Y (0: empty)
  float confidence = 0.0f;  // c: candidates (or frames) this reservoir represents
  float visibility = 1.0f;  // carried visibility estimate V in [0, 1] (seed 000 Eq. 4)
  bool HasSample() const { return W > 0.0f; }
};

// Resampling weight of one RIS candidate: w_j = p̂(y_j) / p_src(y_j) (seed 003 §1). Zero when p_src is 0.
inline float RisWeight(float targetPdf, float sourcePdf) {
  return sourcePdf > 0.0f ? targetPdf / sourcePdf : 0.0f;
}

// Streams one candidate into the reservoir: wSum += w; keep it with probability w / wSum (seed 003 §1).
// `u` is uniform in [0, 1). Returns true when the candidate was selected.
inline bool StreamCandidate(Reservoir& r, const LightSample& candidate, float candidateTarget, float weight,
                            float u) {
  if (!(weight > 0.0f)) return false;
  r.weightSum += weight;
  if (u * r.weightSum < weight) {
    r.sample = candidate;
    r.targetPdf = candidateTarget;
    return true;
  }
  return false;
}

// Finalisation after M candidates: W = wSum / (M p̂(Y)), 0 when p̂(Y) = 0 (seed 003 §1). Sets confidence to
// the number of candidates; callers that count frames instead reset it to 1.
inline void FinalizeRis(Reservoir& r, float candidateCount) {
  r.W = (r.targetPdf > 0.0f && candidateCount > 0.0f) ? r.weightSum / (candidateCount * r.targetPdf) : 0.0f;
  r.confidence = candidateCount;
}

}  // namespace restir
