#include "sim/reference/reference_learning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "core/light_selection_kernel.h"  // kDefensivePowerShare
#include "core/sampling.h"

namespace restir {
namespace {

// A cdf from a pmf, at scale `scale` (the rows the selection kernel writes are at any positive scale).
std::vector<float> Cdf(const std::vector<double>& pmf, double scale) {
  std::vector<float> cdf;
  double running = 0.0;
  for (double p : pmf) cdf.push_back(static_cast<float>(running += p * scale));
  return cdf;
}

// A row as the selection kernel builds it: P(l) = (1 − δ) w_l / Σ w + δ Φ_l.
std::vector<double> SelectionPmf(const std::vector<double>& power, const std::vector<double>& unshadowed) {
  std::vector<double> p;
  for (size_t l = 0; l < power.size(); ++l)
    p.push_back((1.0 - kDefensivePowerShare) * unshadowed[l] + kDefensivePowerShare * power[l]);
  return p;
}

std::vector<double> Pmf(const std::vector<float>& cdf) {
  std::vector<double> p;
  for (size_t l = 0; l < cdf.size(); ++l) p.push_back(CdfPmf(cdf.data(), cdf.size(), static_cast<uint32_t>(l)));
  return p;
}

// The shrinkage is the stated formula: a group seen n times with ratio r gets (n r + κ V₀) / (n + κ).
TEST(TileLightSums, LearnsEachSampledGroupsShrunkRatioAndTheTilesOverallRatioForTheRest) {
  TileLightSums sums;
  // Group 7: three samples, one visible carrying 2 of 6 unshadowed. Group 3: one visible sample of 4. Group 9:
  // two occluded samples of 1.
  sums.Add(7, 2.0f, true);
  sums.Add(9, 1.0f, false);
  sums.Add(7, 3.0f, false);
  sums.Add(3, 4.0f, true);
  sums.Add(7, 1.0f, false);
  sums.Add(9, 1.0f, false);
  const TileLightLearning t = sums.Learn();
  ASSERT_TRUE(t.reshape);
  const double prior = (2.0 + 4.0) / (6.0 + 4.0 + 2.0);
  EXPECT_NEAR(t.unsampled, prior, 1e-6);
  ASSERT_EQ(t.groups, (std::vector<uint32_t>{3, 7, 9}));  // ascending
  const double k = kLearningPseudoSamples;
  EXPECT_NEAR(t.factor[0], (1.0 * 1.0 + k * prior) / (1.0 + k), 1e-6);
  EXPECT_NEAR(t.factor[1], (3.0 * (2.0 / 6.0) + k * prior) / (3.0 + k), 1e-6);
  EXPECT_NEAR(t.factor[2], (2.0 * 0.0 + k * prior) / (2.0 + k), 1e-6);
}

// A tile whose pilot delivered nothing (every draw occluded, or no draw carried light) learns nothing: its
// distributions stay as they are rather than collapsing onto the defensive share.
TEST(TileLightSums, LearnsNothingWhereNothingArrived) {
  TileLightSums sums;
  EXPECT_FALSE(sums.Learn().reshape);
  sums.Add(1, 5.0f, false);
  sums.Add(2, 0.0f, true);
  EXPECT_FALSE(sums.Learn().reshape);
}

// The reshaped distribution is P'(l) = (1 − δ) q_l / Σ q + δ Φ_l with q_l = (P(l) − δ Φ_l) V_l, whatever the row's
// scale; every light with power keeps at least δ Φ_l (the estimator's unbiasedness), and a tile that does not
// reshape leaves the row's bits alone.
TEST(ReshapeLightRow, KeepsTheDefensivePowerShareAndScalesTheUnshadowedWeightsByTheLearnedFactors) {
  const std::vector<double> power = {0.1, 0.2, 0.3, 0.15, 0.25};
  const std::vector<double> unshadowed = {0.5, 0.0, 0.2, 0.3, 0.0};  // w_l / Σ w
  const std::vector<double> p = SelectionPmf(power, unshadowed);
  std::vector<float> powerPmf(power.begin(), power.end());
  TileLightLearning tile;
  tile.reshape = true;
  tile.groups = {0, 3};
  tile.factor = {0.02f, 0.9f};
  tile.unsampled = 0.25f;
  for (double scale : {1.0, 1e-30, 3e20}) {
    std::vector<float> cdf = Cdf(p, scale);
    ASSERT_TRUE(ReshapeLightRow(tile, powerPmf.data(), cdf.size(), cdf.data()));
    const std::vector<double> v = {0.02, 0.25, 0.25, 0.9, 0.25};
    double sumQ = 0.0;
    for (size_t l = 0; l < p.size(); ++l) sumQ += (1.0 - kDefensivePowerShare) * unshadowed[l] * v[l];
    const std::vector<double> got = Pmf(cdf);
    for (size_t l = 0; l < p.size(); ++l) {
      const double want = (1.0 - kDefensivePowerShare) * (1.0 - kDefensivePowerShare) * unshadowed[l] * v[l] / sumQ +
                          kDefensivePowerShare * power[l];
      EXPECT_NEAR(got[l], want, 2e-6) << "light " << l << " at scale " << scale;
      EXPECT_GE(got[l], kDefensivePowerShare * power[l] * (1.0 - 1e-5));
    }
  }
  std::vector<float> cdf = Cdf(p, 1.0);
  const std::vector<float> before = cdf;
  EXPECT_FALSE(ReshapeLightRow(TileLightLearning{}, powerPmf.data(), cdf.size(), cdf.data()));
  EXPECT_EQ(cdf, before);
}

// Under the difference estimator: the groups its pilot saw (eligible) whose factor passes kDifferenceVisibility and
// whose unshadowed share reaches kDifferenceLeastShare are listed, ascending, and weighed by what is left to estimate,
// max(1 − V, kDifferenceFloor); the others as before; the defensive share stays.
TEST(ReshapeLightRow, DifferencedGroupsAreTheSeenMostlyVisibleOnesWeighedByWhatTheirShadowsTake) {
  const std::vector<double> power = {0.1, 0.2, 0.3, 0.15, 0.25};
  const std::vector<double> unshadowed = {0.5, 0.0, 0.2, 0.3, 0.0};
  const std::vector<double> p = SelectionPmf(power, unshadowed);
  std::vector<float> powerPmf(power.begin(), power.end());
  TileLightLearning tile;
  tile.reshape = true;
  tile.groups = {0, 2, 3};
  tile.factor = {0.02f, 0.8f, 0.95f};
  tile.unsampled = 0.25f;
  PilotVisibleGroups seen;
  seen.count = 3;
  seen.group[0] = 2, seen.group[1] = 3, seen.group[2] = 4;  // 0 not seen; 4 seen but gives nothing unshadowed
  std::vector<float> cdf = Cdf(p, 1.0);
  DifferencedGroups d;
  d.eligible = &seen;
  ASSERT_TRUE(ReshapeLightRow(tile, powerPmf.data(), cdf.size(), cdf.data(), nullptr, &d));
  ASSERT_EQ(d.count, 2u);
  EXPECT_EQ(d.group[0], 2u);
  EXPECT_EQ(d.group[1], 3u);
  const std::vector<double> q = {(1 - kDefensivePowerShare) * 0.5 * 0.02, 0.0,
                                 (1 - kDefensivePowerShare) * 0.2 * (1.0 - 0.8), (1 - kDefensivePowerShare) * 0.3 * 0.1,
                                 0.0};
  double sumQ = 0.0;
  for (double v : q) sumQ += v;
  const std::vector<double> got = Pmf(cdf);
  for (size_t l = 0; l < p.size(); ++l)
    EXPECT_NEAR(got[l], (1.0 - kDefensivePowerShare) * q[l] / sumQ + kDefensivePowerShare * power[l], 2e-6) << l;
  // Nothing eligible: nothing differenced, the row as without the estimator.
  std::vector<float> plain = Cdf(p, 1.0), none = Cdf(p, 1.0);
  DifferencedGroups empty;
  ASSERT_TRUE(ReshapeLightRow(tile, powerPmf.data(), plain.size(), plain.data()));
  ASSERT_TRUE(ReshapeLightRow(tile, powerPmf.data(), none.size(), none.data(), nullptr, &empty));
  EXPECT_EQ(empty.count, 0u);
  EXPECT_EQ(plain, none);
}

// Where every learned factor is 0 (Σ q = 0: the pilot saw every weighted light occluded), the row is power alone;
// it never loses a light with power.
TEST(ReshapeLightRow, FallsBackToPowerWhereNoWeightIsLeft) {
  const std::vector<double> power = {0.4, 0.35, 0.25};
  const std::vector<double> unshadowed = {0.0, 1.0, 0.0};
  const std::vector<double> p = SelectionPmf(power, unshadowed);
  std::vector<float> powerPmf(power.begin(), power.end());
  TileLightLearning tile;
  tile.reshape = true;
  tile.groups = {1};
  tile.factor = {0.0f};
  tile.unsampled = 0.5f;
  std::vector<float> cdf = Cdf(p, 1.0);
  ASSERT_TRUE(ReshapeLightRow(tile, powerPmf.data(), cdf.size(), cdf.data()));
  const std::vector<double> got = Pmf(cdf);
  for (size_t l = 0; l < power.size(); ++l) EXPECT_NEAR(got[l], power[l], 1e-6);
}

// A pixel's probes (PixelProbes) override its tile's factor for the groups they probed: (v + κ V_l) / (1 + κ), v = 1
// where the probe arrived and 0 where it was blocked; unprobed groups keep the tile's factor and every group keeps
// its defensive power share. A tile that learned nothing (reshape false) is still reshaped where a probe arrived,
// and WeighedGroups names exactly the groups with unshadowed weight beyond their power share.
TEST(ReshapeLightRow, ProbesOverrideTheTilesFactorAtTheirPixel) {
  const std::vector<double> power = {0.1, 0.2, 0.3, 0.15, 0.25};
  const std::vector<double> unshadowed = {0.5, 0.0, 0.2, 0.3, 0.0};
  const std::vector<double> p = SelectionPmf(power, unshadowed);
  std::vector<float> powerPmf(power.begin(), power.end());
  {
    const std::vector<float> cdf = Cdf(p, 7.0);
    EXPECT_EQ(WeighedGroups(cdf.data(), powerPmf.data(), cdf.size()), 0b01101u);
  }
  TileLightLearning tile;
  tile.reshape = true;
  tile.groups = {0, 3};
  tile.factor = {0.02f, 0.9f};
  tile.unsampled = 0.25f;
  PixelProbes probes;
  probes.probed = 0b01101u;  // groups 0, 2, 3
  probes.visible = 0b00001u;  // only group 0's probe arrived
  const float k = kLearningPseudoSamples;
  for (const bool learned : {true, false}) {
    TileLightLearning t = learned ? tile : TileLightLearning{};
    std::vector<float> cdf = Cdf(p, 1.0);
    ASSERT_TRUE(ReshapeLightRow(t, powerPmf.data(), cdf.size(), cdf.data(), &probes));
    const double v0 = learned ? 0.02 : 1.0, v2 = learned ? 0.25 : 1.0, v3 = learned ? 0.9 : 1.0;
    const std::vector<double> v = {(1.0 + k * v0) / (1.0 + k), learned ? 0.25 : 1.0, k * v2 / (1.0 + k),
                                   k * v3 / (1.0 + k), learned ? 0.25 : 1.0};
    double sumQ = 0.0;
    for (size_t l = 0; l < p.size(); ++l) sumQ += unshadowed[l] * v[l];
    const std::vector<double> got = Pmf(cdf);
    for (size_t l = 0; l < p.size(); ++l) {
      const double want =
          (1.0 - kDefensivePowerShare) * unshadowed[l] * v[l] / sumQ + kDefensivePowerShare * power[l];
      EXPECT_NEAR(got[l], want, 2e-6) << "light " << l << (learned ? " (tile learned)" : " (tile learned nothing)");
    }
  }
  // Probes that all came back blocked over a tile that learned nothing: nothing to reshape by.
  PixelProbes blocked;
  blocked.probed = 0b01101u;
  std::vector<float> cdf = Cdf(p, 1.0);
  const std::vector<float> before = cdf;
  EXPECT_FALSE(ReshapeLightRow(TileLightLearning{}, powerPmf.data(), cdf.size(), cdf.data(), &blocked));
  EXPECT_EQ(cdf, before);
}

// Sky strategies: a pixel whose sun draws were all occluded moves its draws to what arrives, yet every strategy
// that can contribute keeps its defensive share, and one that cannot stays at 0.
TEST(ReshapeMixture, MovesDrawsFromAnOccludedSunAndKeepsEveryDefensiveShare) {
  const float estimates[3] = {-1.0f, 9.0f, 1.0f};  // no local lights; the sun looks 9× the environment
  StrategySums pixel, tile;
  for (int k = 0; k < 14; ++k) pixel.s[1].Add(1.0f, false);  // the sun: all occluded
  for (int k = 0; k < 2; ++k) pixel.s[2].Add(0.5f, true);    // the environment: arrives
  tile = pixel;
  const LightMixture before = MixLightStrategies(estimates[0], estimates[1], estimates[2]);
  const LightMixture after = ReshapeMixture(estimates, pixel, tile);
  EXPECT_EQ(after.local, 0.0f);
  EXPECT_LT(after.sun, 0.25f * before.sun);
  EXPECT_GE(after.sun, kDefensiveStrategyShare / 2 - 1e-6f);
  EXPECT_GT(after.environment, 0.5f);
  EXPECT_NEAR(after.sun + after.environment, 1.0f, 1e-6f);
  // A pixel with no samples of its own follows its tile; a tile with none stays unshadowed (factor 1).
  const LightMixture unlearned = ReshapeMixture(estimates, StrategySums{}, StrategySums{});
  EXPECT_EQ(unlearned.sun, before.sun);
  EXPECT_EQ(unlearned.environment, before.environment);
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// The neighbourhood's mean, computed here by its definition: the active pixels within kSpreadRadius in x and y.
float NeighbourhoodMean(const std::vector<float>& v, const std::vector<uint8_t>& active, int w, int h, int x, int y) {
  double sum = 0.0;
  int n = 0;
  for (int dy = -kSpreadRadius; dy <= kSpreadRadius; ++dy)
    for (int dx = -kSpreadRadius; dx <= kSpreadRadius; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= w || yy >= h || !active[size_t(yy) * w + xx]) continue;
      sum += std::max(0.0f, v[size_t(yy) * w + xx]);
      ++n;
    }
  return static_cast<float>(sum / n);
}

TEST(SpreadRelativeVariance, APixelWhosePilotSawNothingAmidLitNeighboursTakesTheirMean) {
  const int w = 7, h = 6;
  std::vector<float> v(size_t(w) * h, 4.0f);
  std::vector<uint8_t> active(v.size(), 1);
  v[3 * w + 3] = -1.0f;  // its pilot saw no light
  const std::vector<float> out = SpreadRelativeVariance(v, active, w, h);
  // 24 neighbours at 4 and itself at 0, over 25.
  EXPECT_FLOAT_EQ(out[3 * w + 3], 24.0f * 4.0f / 25.0f);
  // Its neighbours keep their own v: the mean around them is below it.
  EXPECT_EQ(out[3 * w + 4], 4.0f);
}

TEST(SpreadRelativeVariance, NeverLowersAPixelAndIgnoresInactivePixels) {
  // A grid of tilted cases: random v with pixels that saw nothing, inactive pixels holding large values that must
  // not leak, borders where the window is clipped.
  std::mt19937 rng(40);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {1, 9}, {9, 1}, {5, 5}, {17, 11}, {64, 36}}) {
    std::vector<float> v(size_t(w) * h);
    std::vector<uint8_t> active(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      active[i] = u(rng) < 0.8f;
      const float r = u(rng);
      v[i] = !active[i] ? 1e6f : r < 0.3f ? -1.0f : std::pow(10.0f, 4.0f * u(rng) - 2.0f);
    }
    const std::vector<float> out = SpreadRelativeVariance(v, active, w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * w + x;
        if (!active[i]) {
          EXPECT_EQ(out[i], v[i]);
          continue;
        }
        EXPECT_GE(out[i], v[i]) << w << "x" << h << " at " << x << "," << y;
        const float mean = NeighbourhoodMean(v, active, w, h, x, y);
        EXPECT_FLOAT_EQ(out[i], mean > 0.0f && mean > v[i] ? mean : v[i]) << w << "x" << h << " at " << x << "," << y;
        EXPECT_LT(out[i], 1e5f) << "an inactive pixel's value leaked";
      }
  }
}

TEST(SpreadRelativeVariance, LeavesAPixelDarkWhereNoNeighbourSawLightAndAConstantFieldAlone) {
  const int w = 12, h = 8;
  std::vector<float> dark(size_t(w) * h, -1.0f), constant(size_t(w) * h, 0.25f);
  const std::vector<uint8_t> active(dark.size(), 1);
  EXPECT_EQ(SpreadRelativeVariance(dark, active, w, h), dark);
  EXPECT_EQ(SpreadRelativeVariance(constant, active, w, h), constant);
}

}  // namespace
}  // namespace restir
