// The reference's light mixture under a sky (sim/reference/reference_sky.h): the strategy probabilities (a partition of
// unity with the defensive floor, zero exactly where a strategy cannot contribute), the strategy choice that
// realises them, the per-receiver estimates that shape them, and the mixture's density of a sky direction.
// Deterministic; tests/sim/reference/sky_closed_form_test.cpp proves the estimator built on them unbiased.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/reference/reference_sky.h"

namespace restir {
namespace {

float Sum(const LightMixture& m) { return m.local + m.sun + m.environment; }

TEST(ReferenceSky, MixtureIsLocalAloneWhenOnlyLocalLightsCanContribute) {
  for (const float local : {0.0f, 5.0f, NAN}) {
    const LightMixture m = MixLightStrategies(local, -1.0f, -1.0f);
    EXPECT_EQ(m.local, 1.0f);  // exactly: the local sample's density is then unchanged
    EXPECT_EQ(m.sun, 0.0f);
    EXPECT_EQ(m.environment, 0.0f);
  }
}

TEST(ReferenceSky, MixtureIsDefensiveAndSumsToOne) {
  // Sun and environment able, local lights absent: P = 0.9 e / Σ e + 0.1 / 2.
  LightMixture m = MixLightStrategies(-1.0f, 3.0f, 1.0f);
  EXPECT_EQ(m.local, 0.0f);
  EXPECT_NEAR(m.sun, 0.9f * 0.75f + 0.05f, 1e-7f);
  EXPECT_NEAR(m.environment, 0.9f * 0.25f + 0.05f, 1e-7f);
  EXPECT_NEAR(Sum(m), 1.0f, 1e-7f);
  // A strategy estimated at 0 keeps the floor δ/k; all three at 0: a third each.
  m = MixLightStrategies(10.0f, 0.0f, 2.0f);
  EXPECT_NEAR(m.sun, kDefensiveStrategyShare / 3.0f, 1e-7f);
  EXPECT_GT(m.local, m.environment);
  EXPECT_NEAR(Sum(m), 1.0f, 1e-7f);
  m = MixLightStrategies(0.0f, 0.0f, 0.0f);
  EXPECT_NEAR(m.local, 1.0f / 3.0f, 1e-7f);
  EXPECT_NEAR(m.sun, 1.0f / 3.0f, 1e-7f);
  EXPECT_NEAR(Sum(m), 1.0f, 1e-7f);
  // Wildly different estimates never push an able strategy below its floor.
  m = MixLightStrategies(1e30f, 1e-30f, INFINITY);
  EXPECT_GE(m.sun, kDefensiveStrategyShare / 3.0f * 0.999999f);
  EXPECT_GE(m.environment, kDefensiveStrategyShare / 3.0f * 0.999999f);
  EXPECT_TRUE(std::isfinite(Sum(m)));
  // Nothing can contribute: no light sampling at all.
  m = MixLightStrategies(-1.0f, -1.0f, -1.0f);
  EXPECT_EQ(Sum(m), 0.0f);
}

TEST(ReferenceSky, StrategyChoiceRealisesTheMixture) {
  for (const LightMixture& m : {LightMixture{0.2f, 0.5f, 0.3f}, LightMixture{0.0f, 1.0f, 0.0f},
                                LightMixture{0.4f, 0.0f, 0.6f}, LightMixture{1.0f, 0.0f, 0.0f},
                                MixLightStrategies(2.0f, 0.5f, 0.25f)}) {
    // The share of a fine uniform grid of u each strategy gets is its probability (to the grid's spacing).
    constexpr int kGrid = 1 << 20;
    int count[3] = {0, 0, 0};
    for (int k = 0; k < kGrid; ++k) ++count[static_cast<int>(ChooseLightStrategy(m, (k + 0.5f) / kGrid))];
    EXPECT_NEAR(double(count[0]) / kGrid, m.local, 2e-6);
    EXPECT_NEAR(double(count[1]) / kGrid, m.sun, 2e-6);
    EXPECT_NEAR(double(count[2]) / kGrid, m.environment, 2e-6);
    // A strategy of probability 0 is never chosen, not even at the ends of [0, 1).
    for (const float u : {0.0f, 0x1.fffffep-1f}) {
      const LightStrategy s = ChooseLightStrategy(m, u);
      const float p[3] = {m.local, m.sun, m.environment};
      EXPECT_GT(p[static_cast<int>(s)], 0.0f) << "u " << u;
    }
  }
}

// A diffuse receiver at the origin facing +Y.
ShadingPoint Receiver(const Vec3& normal = Vec3(0.0f, 1.0f, 0.0f)) {
  ShadingPoint sp;
  sp.position = Vec3(0.0f);
  sp.geometricNormal = sp.shadingNormal = normal;
  sp.wo = normal;
  sp.bsdf = Bsdf{BsdfType::kDiffuse, Vec3(0.5f)};
  sp.errorScale = 1.0f;
  return sp;
}

TEST(ReferenceSky, SunEstimateIsTheDiscsIrradianceAndMinusOneBelowTheHorizon) {
  Sky sky;
  sky.hasSun = true;
  const float diameter = 5.0f;
  const double alpha = 0.5 * diameter * M_PI / 180.0;
  const SkySummary none = SummarizeSky(Sky{});
  EXPECT_EQ(none.sunSolidAngle, 0.0f);
  for (const double elevation : {90.0, 30.0, 2.0, 0.0, -2.0, -2.6}) {
    const double e = elevation * M_PI / 180.0;
    sky.sun = MakeSunDisc(Vec3(float(std::cos(e)), float(std::sin(e)), 0.0f), diameter, Vec3(4.0f));
    const SkySummary summary = SummarizeSky(sky);
    EXPECT_NEAR(summary.sunSolidAngle, 2.0 * M_PI * (1.0 - std::cos(alpha)), 1e-9);
    EXPECT_NEAR(summary.sunSinHalfAngle, std::sin(alpha), 1e-7);
    const float estimate = SunEstimate(Receiver(), sky, summary);
    if (elevation >= 2.5) {
      // Ω cos θ × L × albedo/π (for a disc above the horizon, within 2/(1 + cos α) of the exact π sin²α cos θ).
      EXPECT_NEAR(estimate, 4.0 * 0.5 / M_PI * summary.sunSolidAngle * std::sin(e), 1e-6);
    } else if (elevation > -2.5) {
      EXPECT_GT(estimate, 0.0f) << "the disc straddles the horizon at " << elevation;
    } else {
      EXPECT_EQ(estimate, -1.0f) << "the whole disc has set at " << elevation;
    }
  }
  // Behind the geometric normal's horizon the sun cannot contribute either (ConnectToLight tests both normals).
  ShadingPoint sp = Receiver();
  sp.geometricNormal = Vec3(1.0f, 0.0f, 0.0f);
  sky.sun = MakeSunDisc(Vec3(-0.5f, 0.8f, 0.0f), diameter, Vec3(4.0f));
  EXPECT_EQ(SunEstimate(sp, sky, SummarizeSky(sky)), -1.0f);
  EXPECT_EQ(SunEstimate(Receiver(), Sky{}, none), -1.0f);
}

TEST(ReferenceSky, EnvironmentEstimateIsTheFurnaceOfTheMeanLuminance) {
  // Two texels, each half the sphere: the mean luminance is their average.
  EnvironmentMap map;
  map.width = 1;
  map.height = 2;
  map.texels = {Vec3(1.0f), Vec3(3.0f)};
  const EnvironmentSampler sampler(map);
  Sky sky;
  sky.environment = &sampler;
  sky.environmentScale = Vec3(0.5f);
  const SkySummary summary = SummarizeSky(sky);
  EXPECT_NEAR(summary.environmentMeanLuminance, 0.5 * 2.0, 1e-6);
  EXPECT_NEAR(EnvironmentEstimate(Receiver(), sky, summary), 0.5 * 1.0, 1e-6);  // albedo 0.5 × 1
  EXPECT_EQ(EnvironmentEstimate(Receiver(), Sky{}, summary), -1.0f);
  // The layered proxy adds the specular lobe's weight × F0.
  EXPECT_NEAR(ReflectanceProxy(Bsdf{BsdfType::kLayered, Vec3(0.3f), 0.2f, Vec3(0.5f), 0.4f}), 0.3 + 0.4 * 0.5, 1e-6);
}

TEST(ReferenceSky, SkyDensityIsTheMixtureOfTheStrategiesDensities) {
  EnvironmentMap map;
  map.width = 4;
  map.height = 2;
  for (int k = 0; k < 8; ++k) map.texels.push_back(Vec3(float(k + 1)));
  const EnvironmentSampler sampler(map);
  Sky sky;
  sky.environment = &sampler;
  sky.cosRotation = std::cos(0.3f);
  sky.sinRotation = std::sin(0.3f);
  sky.hasSun = true;
  sky.sun = MakeSunDisc(glm::normalize(Vec3(0.2f, 1.0f, -0.3f)), 3.0f, Vec3(100.0f));
  const LightMixture m{0.25f, 0.35f, 0.4f};
  // Every direction either strategy draws has a positive mixture density, equal to the weighted sum.
  for (int k = 0; k < 256; ++k) {
    const float u[4] = {(k + 0.5f) / 256.0f, std::fmod(k * 0.618034f, 1.0f), std::fmod(k * 0.414214f, 1.0f),
                        std::fmod(k * 0.732051f, 1.0f)};
    for (const LightStrategy s : {LightStrategy::kSun, LightStrategy::kEnvironment}) {
      const Vec3 w = SampleSkyStrategy(sky, s, u[0], u[1], u[2], u[3]);
      EXPECT_NEAR(glm::length(w), 1.0f, 1e-6f);
      const float p = SkyLightPdf(m, sky, w);
      EXPECT_GT(p, 0.0f);
      EXPECT_FLOAT_EQ(p, m.sun * sky.SunPdf(w) + m.environment * sky.EnvironmentPdf(w));
      if (s == LightStrategy::kSun) { EXPECT_GT(sky.SunPdf(w), 0.0f); }
    }
  }
  // A strategy of probability 0 contributes nothing to the density, whatever its own.
  EXPECT_EQ(SkyLightPdf(LightMixture{1.0f, 0.0f, 0.0f}, sky, sky.sun.direction), 0.0f);
}

}  // namespace
}  // namespace restir
