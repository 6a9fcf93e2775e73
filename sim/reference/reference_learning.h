// Visibility-aware selection for the converged reference (issue 40; docs/metrics.md "How the reference is
// sampled"). The pilot's light distributions weigh each light by what it would give unshadowed; in an occluded
// many-light scene, or under a sun that a wall hides, most of those samples then go where the pixel cannot see.
// The pilot traces their shadow rays anyway: this learns from them, per screen tile, how much of each light
// group's and each sky strategy's unshadowed contribution actually arrives, and the main pass reshapes its
// distributions by it.
//
// What stays unbiased: the learned factors are a function of the pilot's random numbers only, which are
// independent of the main pass's; the main pass's densities are those of the reshaped distributions it draws from;
// every light with power keeps the defensive power share δ (core/light_selection_kernel.h) and every sky strategy
// that can contribute keeps its defensive share (sim/reference/reference_sky.h), so nothing that contributes can
// get probability 0 however wrong the learning is. The learning only decides how much noise is left.
//
// The statistic: for a group (or strategy) s of a tile, over the pilot samples that chose it, the ratio
// r_s = Σ delivered / Σ unshadowed of their light terms (the visible share of what they carried: a
// contribution-weighted visibility), shrunk towards a prior by pseudo-samples: V_s = (n_s r_s + κ V₀) / (n_s + κ).
// A group the tile never sampled gets the tile's overall ratio V₀ (in a many-room scene, the share of the tile's
// unshadowed contribution that arrives at all: small, as it should be for a light the pilot never found useful).
// Pure functions of their inputs; sim/reference/reference.cpp feeds them in a fixed order (a tile's rows by one
// thread), so the result is the same bits on any thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "sim/reference/reference_sky.h"

namespace restir {

// Pixels per side of a learning tile: 8 × 8 pixels × 16 pilot samples = 1024 samples to share between the groups.
inline constexpr int kLearningTile = 8;
// Pseudo-samples of the prior in V_s's shrinkage.
inline constexpr float kLearningPseudoSamples = 1.0f;

// Sums over the pilot samples that chose one group or strategy.
struct LightTermSums {
  double unshadowed = 0.0;  // Σ luminance of the light term, visibility not applied
  double delivered = 0.0;   // Σ luminance of the light term where its shadow ray was unoccluded
  uint32_t samples = 0;     // how many chose it

  void Add(float unshadowedLuma, bool visible) {
    unshadowed += unshadowedLuma;
    if (visible) delivered += unshadowedLuma;
    ++samples;
  }
  void Add(const LightTermSums& o) {
    unshadowed += o.unshadowed;
    delivered += o.delivered;
    samples += o.samples;
  }
  // r_s, or `otherwise` where nothing unshadowed was carried.
  double Ratio(double otherwise) const { return unshadowed > 0.0 ? delivered / unshadowed : otherwise; }
};

// V_s = (n r + κ prior) / (n + κ): the learned factor of a group or strategy, shrunk towards `prior`.
inline float ShrunkVisibility(const LightTermSums& s, double prior) {
  const double n = s.samples;
  return static_cast<float>((n * s.Ratio(prior) + kLearningPseudoSamples * prior) / (n + kLearningPseudoSamples));
}

// One tile's learned factors over the light groups: sampled groups by their own shrunk ratio, the rest by the
// tile's overall ratio. `reshape` is false where the tile learned nothing it can use (its pilot carried no light
// that arrived): its distributions then stay as they were.
struct TileLightLearning {
  std::vector<uint32_t> groups;  // the groups its pilot sampled, ascending
  std::vector<float> factor;     // their V_s
  float unsampled = 1.0f;        // V₀: every other group's factor
  bool reshape = false;
};

// What a tile's pilot carried per light group, accumulated sample by sample (in the order the samples come, which
// the caller keeps fixed), then turned into the tile's factors.
class TileLightSums {
 public:
  void Add(uint32_t group, float unshadowedLuma, bool visible);
  TileLightLearning Learn() const;
  void Clear() {
    entries_.clear();
    index_.clear();
  }

 private:
  struct Entry {
    uint32_t group;
    LightTermSums sums;
  };
  std::vector<Entry> entries_;  // in first-seen order; a tile meets at most its pilot's sample count of groups
  std::unordered_map<uint32_t, uint32_t> index_;  // group → its entry (lookup only: nothing iterates it)
};

// Per-pixel probes, where the frame has at most kMaxProbedGroups light groups (per-pixel distributions): the pilot
// traces one shadow ray from the pixel to a point drawn uniformly on each group its distribution weighs. A tile's
// factor is the tile's average; a light that one pixel of the tile sees and the others do not (door_ajar's panel
// seen through the door from one wall pixel) gets a small factor from the tile and then almost no samples at the
// one pixel it lights, which its replicates cannot see (tests/sim/reference/brute_force_reference_test.cpp). A probe
// per group costs at most twice the pilot's 16 rays a pixel.
inline constexpr size_t kMaxProbedGroups = 32;
struct PixelProbes {
  uint32_t probed = 0;   // bit l: group l was probed (its distribution weighed it, its point faced the receiver)
  uint32_t visible = 0;  // bit l: that probe's shadow ray was unoccluded
};

// The groups a receiver's distribution weighs beyond their power share (bit l for group l < kMaxProbedGroups): those
// its unshadowed estimate gave weight, the ones worth a probe.
uint32_t WeighedGroups(const float* cdf, const float* powerPmf, size_t groups);

// The difference estimator (sim/reference/reference.h ReferenceParams::differenceShadows; docs/metrics.md "How the
// reference is sampled"): at a diffuse receiver, a light group that the receiver's pilot saw unoccluded and its tile
// learned is mostly visible is estimated as its exact unshadowed contribution U_l (core/polygon_irradiance.h
// ClippedPolygonProjectedSolidAngle) minus a sampled estimate of what its shadows take away, f (1 − V) / p, instead
// of as f V / p: a control variate whose mean is known exactly (Owen 2013, "Monte Carlo theory, methods and
// examples", §8.9; the unbiased, additive counterpart of the ratio estimator of Heitz et al. 2018, "Combining
// Analytic Direct Illumination and Stochastic Shadows"). Where the group is unoccluded every such sample is 0, so
// an unoccluded diffuse receiver's estimate is exact and only the shadows' noise is left.
// Its selection weight becomes the unshadowed weight times max(1 − V, kDifferenceFloor), what is left to estimate:
// kept at the unshadowed weight times V, a pixel whose groups were part differenced and part not had samples of two
// kinds, 0 and about the whole light, where the plain estimate had samples all about the whole light
// (window_bars_pan frame 0: mean relative standard error 5.2% → 9.4%). And only a group that the receiver's own
// pilot drew at least kDifferenceLeastDraws times, every one of those draws' shadow rays unoccluded, is
// differenced there: with the tile's factor alone, a pixel in a shadow the tile does not share had its rare samples
// of the hidden light carry all of U_l (asset_table, 3 frames: mean 1.9% → 4.1%, 99th percentile 24% → 49%); with
// one draw enough, a light partly hidden in a way one draw did not see did the same to fewer pixels (frame 0, with a
// since dropped rounding of the allocation: p99 14.6% → 19.0% on asset_table, 13.7% → 15.7% on window_bars_pan;
// with two draws, as kept, 13.6% and 12.5%: docs/metrics.md).
// A group is differenced where its learned factor is above this.
inline constexpr float kDifferenceVisibility = 0.5f;
// At most this many groups a receiver are differenced (the largest unshadowed weights), and only those with at
// least this share of its unshadowed weight: each costs an exact integral per receiver (a fifth of the flagship's
// reference time at 16 groups and no least share, perf), and a group that gives little adds little noise either way.
inline constexpr size_t kMaxDifferencedGroups = 8;
inline constexpr float kDifferenceLeastShare = 0.01f;
// The least share of its unshadowed weight a differenced group keeps: max(1 − V, this).
inline constexpr float kDifferenceFloor = 0.1f;
// The fewest of the receiver's pilot draws of a group, all arriving, that let it be differenced.
inline constexpr size_t kDifferenceLeastDraws = 2;
// A receiver's groups that its pilot drew at least kDifferenceLeastDraws times, every draw arriving (the first
// kMaxDifferencedGroups of them).
struct PilotVisibleGroups {
  uint16_t group[kMaxDifferencedGroups] = {};  // ascending
  uint8_t count = 0;
};

struct DifferencedGroups {
  const PilotVisibleGroups* eligible = nullptr;  // in: the groups its pilot drew and saw (none: nothing is differenced)
  uint32_t count = 0;                            // out: entries of group[] in use
  uint32_t group[kMaxDifferencedGroups] = {};    // out: the differenced groups, ascending
};

// Group l's learned factor at a receiver: the tile's (its own shrunk ratio where the tile's pilot sampled it, else
// the tile's overall V₀), and where the receiver probed l, its probe shrunk towards that: (v + κ V_l) / (1 + κ).
float LearnedFactor(const TileLightLearning& tile, uint32_t l, const PixelProbes* probes);

// Reshapes one receiver's light distribution (a cdf over the groups, as core/light_selection_kernel.h writes a row;
// any positive scale) in place: P'(l) = (1 − δ) q_l / Σ q + δ Φ_l, q_l = max(0, P(l) − δ Φ_l) × V_l, i.e. the
// unshadowed weight the row was built from, times the group's learned factor. powerPmf[l] is group l's Φ / Σ Φ.
// With probes, a probed group's factor is its probe shrunk towards the tile's: (v + κ V_l) / (1 + κ), v ∈ {0, 1}.
// Where Σ q is 0 or not finite, the row becomes the power distribution. Returns false, leaving the row alone,
// where neither the tile nor a probe has anything to reshape it by.
// With `differenced` set (a diffuse receiver under the difference estimator), the groups of its `eligible` list
// whose factor passes kDifferenceVisibility, whose unshadowed weight is at least kDifferenceLeastShare of the row
// and among the kMaxDifferencedGroups largest are listed there and weighed q_l = max(0, P(l) − δ Φ_l) × max(1 − V_l,
// kDifferenceFloor) instead; without it, the same bits as before.
bool ReshapeLightRow(const TileLightLearning& tile, const float* powerPmf, size_t groups, float* cdf,
                     const PixelProbes* probes = nullptr, DifferencedGroups* differenced = nullptr);

// The allocation's relative variances with each pixel's neighbours heard (docs/metrics.md "How the reference is
// sampled", step 3): v'_i = max(v_i, the mean of max(0, v_j) over the active pixels j within kSpreadRadius of i in
// x and y, i among them). A pixel's v comes from its 16 pilot samples, which miss a light that reaches it rarely (a
// crack, a slit, a shadow that takes a sliver of a light every draw saw arrive): it is then far below the truth, the
// pixel gets few samples, and their replicates, missing the light as the pilot did, give it a small standard error
// too. Its neighbours see nearly the same lights through nearly the same gaps, and some of their pilots find them.
// Taking the larger of its own and the neighbourhood's mean never lowers a pixel's v, so it only moves samples
// towards where light is rare (door_ajar, frame 0 at its defaults: mean relative standard error 27.9% → 15.1%;
// sun_street_night's 99th percentile 31% → 9.6%). A function of the pilot's values only, so the main pass stays
// unbiased; negative v (the pilot saw no light) counts as 0 and stays negative where the neighbourhood saw none
// either. Inactive pixels neither give nor take.
inline constexpr int kSpreadRadius = 2;
std::vector<float> SpreadRelativeVariance(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                          int width, int height);

// The sky strategies' sums at one pixel or tile: local lights, sun, environment.
struct StrategySums {
  LightTermSums s[3];
};

// The receiver's light mixture with each strategy's estimate scaled by its learned factor: the pixel's own ratio
// shrunk towards the tile's (itself shrunk towards 1, unshadowed, where the tile saw little), then
// MixLightStrategies as the pilot did, so every strategy that could contribute keeps its defensive share.
LightMixture ReshapeMixture(const float (&estimates)[3], const StrategySums& pixel, const StrategySums& tile);

}  // namespace restir
