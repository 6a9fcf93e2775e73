#include "sim/reference/reference_learning.h"

#include <algorithm>
#include <cmath>

#include "core/light_selection_kernel.h"  // kDefensivePowerShare

namespace restir {

namespace {
// A share of a row (normalised to 1) below which its unshadowed weight counts as none: float rounding of
// P(l) − δ Φ_l for a light that has only its power share is a few 1e-8.
constexpr float kNoWeight = 1e-6f;
}  // namespace

void TileLightSums::Add(uint32_t group, float unshadowedLuma, bool visible) {
  const auto [it, inserted] = index_.try_emplace(group, static_cast<uint32_t>(entries_.size()));
  if (inserted) entries_.push_back(Entry{group, {}});
  entries_[it->second].sums.Add(unshadowedLuma, visible);
}

TileLightLearning TileLightSums::Learn() const {
  TileLightLearning t;
  LightTermSums all;
  for (const Entry& e : entries_) all.Add(e.sums);  // first-seen order: fixed by the caller's sample order
  if (!(all.delivered > 0.0)) return t;             // nothing arrived: nothing to learn from
  t.reshape = true;
  const double prior = all.Ratio(1.0);
  t.unsampled = static_cast<float>(prior);
  std::vector<const Entry*> sorted;
  for (const Entry& e : entries_) sorted.push_back(&e);
  std::sort(sorted.begin(), sorted.end(), [](const Entry* a, const Entry* b) { return a->group < b->group; });
  for (const Entry* e : sorted) {
    t.groups.push_back(e->group);
    t.factor.push_back(ShrunkVisibility(e->sums, prior));
  }
  return t;
}

uint32_t WeighedGroups(const float* cdf, const float* powerPmf, size_t groups) {
  if (groups == 0 || !(cdf[groups - 1] > 0.0f)) return 0;
  const float scale = 1.0f / cdf[groups - 1];
  uint32_t weighed = 0;
  for (size_t l = 0; l < std::min(groups, kMaxProbedGroups); ++l) {
    const float base = (cdf[l] - (l ? cdf[l - 1] : 0.0f)) * scale - kDefensivePowerShare * powerPmf[l];
    if (base > kNoWeight) weighed |= 1u << l;
  }
  return weighed;
}

namespace {
// A probed group's factor: its probe's answer shrunk towards the tile's v.
float WithProbe(float v, uint32_t l, const PixelProbes* probes) {
  if (!probes || l >= kMaxProbedGroups || !(probes->probed >> l & 1u)) return v;
  const float seen = (probes->visible >> l & 1u) ? 1.0f : 0.0f;
  return (seen + kLearningPseudoSamples * v) / (1.0f + kLearningPseudoSamples);
}

// The candidates for differencing seen so far, at most kMaxDifferencedGroups, the one of least weight replaced
// when a heavier one comes (ties keep the earlier seen, i.e. the higher group: the row is walked from the back).
struct DifferenceCandidates {
  size_t count = 0;
  uint32_t group[kMaxDifferencedGroups];
  float base[kMaxDifferencedGroups];
  float factor[kMaxDifferencedGroups];
  void Offer(uint32_t l, float b, float v) {
    size_t slot = count;
    if (count == kMaxDifferencedGroups) {
      slot = 0;
      for (size_t j = 1; j < count; ++j)
        if (base[j] < base[slot]) slot = j;
      if (!(b > base[slot])) return;
    } else {
      ++count;
    }
    group[slot] = l;
    base[slot] = b;
    factor[slot] = v;
  }
};
}  // namespace

float LearnedFactor(const TileLightLearning& tile, uint32_t l, const PixelProbes* probes) {
  float v = tile.unsampled;
  const auto it = std::lower_bound(tile.groups.begin(), tile.groups.end(), l);
  if (it != tile.groups.end() && *it == l) v = tile.factor[static_cast<size_t>(it - tile.groups.begin())];
  return WithProbe(v, l, probes);
}

bool ReshapeLightRow(const TileLightLearning& tile, const float* powerPmf, size_t groups, float* cdf,
                     const PixelProbes* probes, DifferencedGroups* differenced) {
  if (differenced) differenced->count = 0;
  const bool probedVisible = probes && probes->visible != 0;
  if (!(tile.reshape || probedVisible) || groups == 0) return false;
  // q_l into cdf[] (one pass from the back keeps the cdf's earlier entries for the differences), then Σ q.
  const float scale = 1.0f / cdf[groups - 1];
  size_t next = tile.groups.size();  // the learned entries, walked from the back
  double total = 0.0;
  DifferenceCandidates candidates;
  for (size_t l = groups; l-- > 0;) {
    float v = tile.unsampled;
    while (next > 0 && tile.groups[next - 1] > l) --next;
    if (next > 0 && tile.groups[next - 1] == l) v = tile.factor[next - 1];
    v = WithProbe(v, static_cast<uint32_t>(l), probes);
    // What is left of P(l) after the power share; below kNoWeight it is the rounding of a light the row gave none.
    float base = (cdf[l] - (l ? cdf[l - 1] : 0.0f)) * scale - kDefensivePowerShare * powerPmf[l];
    if (!(base > kNoWeight)) base = 0.0f;
    if (differenced && v > kDifferenceVisibility && base >= kDifferenceLeastShare && differenced->eligible &&
        std::binary_search(differenced->eligible->group, differenced->eligible->group + differenced->eligible->count,
                           static_cast<uint16_t>(l)))
      candidates.Offer(static_cast<uint32_t>(l), base, v);
    cdf[l] = base * v;
    total += cdf[l];
  }
  if (differenced && candidates.count > 0) {
    // Re-weigh the chosen ones (Σ q again, in the row's order, so the sum does not depend on the candidates' order).
    for (size_t j = 0; j < candidates.count; ++j)
      cdf[candidates.group[j]] = candidates.base[j] * std::max(1.0f - candidates.factor[j], kDifferenceFloor);
    total = 0.0;
    for (size_t l = groups; l-- > 0;) total += cdf[l];
    differenced->count = static_cast<uint32_t>(candidates.count);
    std::copy(candidates.group, candidates.group + candidates.count, differenced->group);
    std::sort(differenced->group, differenced->group + differenced->count);
  }
  const bool weighted = total > 0.0 && std::isfinite(total);
  const double share = weighted ? (1.0 - kDefensivePowerShare) / total : 0.0;
  const double power = weighted ? kDefensivePowerShare : 1.0;
  double running = 0.0;
  for (size_t l = 0; l < groups; ++l) {
    running += double(cdf[l]) * share + power * double(powerPmf[l]);
    cdf[l] = static_cast<float>(running);
  }
  return true;
}

std::vector<float> SpreadRelativeVariance(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                          int width, int height) {
  std::vector<float> out = relVar;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      if (!active[i]) continue;
      double sum = 0.0;
      int count = 0;
      for (int yy = std::max(0, y - kSpreadRadius); yy <= std::min(height - 1, y + kSpreadRadius); ++yy)
        for (int xx = std::max(0, x - kSpreadRadius); xx <= std::min(width - 1, x + kSpreadRadius); ++xx) {
          const size_t j = static_cast<size_t>(yy) * width + xx;
          if (!active[j]) continue;
          sum += std::max(0.0f, relVar[j]);
          ++count;
        }
      const float neighbourhood = static_cast<float>(sum / count);  // count ≥ 1: i itself
      if (neighbourhood > 0.0f && neighbourhood > relVar[i]) out[i] = neighbourhood;
    }
  return out;
}

LightMixture ReshapeMixture(const float (&estimates)[3], const StrategySums& pixel, const StrategySums& tile) {
  float e[3];
  for (int s = 0; s < 3; ++s) {
    if (estimates[s] < 0.0f) {  // cannot contribute: stays out
      e[s] = estimates[s];
      continue;
    }
    const double tilePrior = ShrunkVisibility(tile.s[s], 1.0);
    e[s] = estimates[s] * ShrunkVisibility(pixel.s[s], tilePrior);
  }
  return MixLightStrategies(e[0], e[1], e[2]);
}

}  // namespace restir
