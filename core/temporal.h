// Temporal reuse's two guards on the previous frame's reservoir (seed 003 §4.3 and §5; DESIGN §4 "Temporal
// reuse"): how much history it may stand for, and how far its target may have moved. Pure functions, so the pass
// and its tests evaluate them alike.
#pragma once

#include <algorithm>

namespace restir {

// The confidence a previous-frame reservoir brings into temporal reuse (seed 003 §4.3):
// M_represented = min(M_prev, M_maxHistory). Without the cap history outweighs every new candidate and old samples
// become too hard to replace. RTXDI's maxHistoryLength plays the same part (rtxdi-runtime
// DI/TemporalResampling.hlsli, `prevSample.M = min(prevSample.M, historyLimit)`), its limit scaled by the current
// reservoir's M; seed 003's is the cap itself. Callers pass finite confidences (FiniteReservoir): a NaN
// `confidence` would come back as NaN (std::min's order).
inline float CappedHistoryConfidence(float confidence, float maxHistory) { return std::min(confidence, maxHistory); }

// The bounds of the target-ratio clamp (seed 003 §5): a sample whose importance changed by more than 10× between
// the previous and the current surface is probably no longer the same local problem.
inline constexpr float kMinTargetRatio = 0.1f;
inline constexpr float kMaxTargetRatio = 10.0f;

// Seed 003 §5's target-ratio clamp: the previous sample is kept when
// targetRatio = p̂(x, y_prev) / p̂(x_prev, y_prev) lies in [0.1, 10] (bounds included). A previous target that is
// not > 0 (zero, negative, NaN) gives the ratio 0, and a NaN or infinite ratio is outside, so both are rejected.
inline bool TargetRatioInRange(float currentTarget, float previousTarget) {
  const float ratio = previousTarget > 0.0f ? currentTarget / previousTarget : 0.0f;
  return ratio >= kMinTargetRatio && ratio <= kMaxTargetRatio;
}

}  // namespace restir
