// The reference's light sampling under a sky (issue 18; DESIGN §4 "Candidate sources", §7): one light-sampling
// draw first chooses a strategy — the frame's emitters (local lights), the sun, or the environment — with
// per-receiver probabilities from cheap estimates of what each contributes there, then draws a point (local) or
// a direction (sky) from it. The estimator (sim/reference/reference.cpp DirectSamples) weighs each draw by the
// density of the whole mixture at what it drew, so it is one technique for MIS with BSDF sampling:
//   local point y on light l:  p = P_local · P(l) / area(l)                   (area measure)
//   sky direction ω:           p = P_sun · SunPdf(ω) + P_env · EnvironmentPdf(ω)   (solid angle)
// with the integrand L_e f_r G for the point and Sky::Radiance(ω) f_r cos θ for the direction (the sun and the
// environment as one emitter: a direction drawn from either pays both densities and collects both radiances).
// Pure functions of their arguments and random numbers.
#pragma once

#include "core/bsdf.h"
#include "core/shading.h"
#include "core/sky.h"

namespace restir {

// The probabilities with which one light-sampling draw chooses each strategy at one receiver. They sum to 1 when
// any strategy can contribute, else they are all 0 (the receiver has only BSDF sampling).
struct LightMixture {
  float local = 1.0f;        // the frame's emitters: the per-pixel light distribution, then a point on the light
  float sun = 0.0f;          // Sky::SampleSun
  float environment = 0.0f;  // Sky::SampleEnvironment
};

enum class LightStrategy : uint8_t { kLocal, kSun, kEnvironment };

// What the per-receiver estimates need of a frame's sky, computed once per frame.
struct SkySummary {
  // (1/4π) ∫ max(0, Y(L_env(ω))) dω: the environment's mean luminance over the sphere (with its intensity), as
  // the texels' luminance × solid angle that its sampler draws from. 0 without an environment.
  float environmentMeanLuminance = 0.0f;
  float sunSolidAngle = 0.0f;     // 2π (1 − cos α), α the sun's half-angle; 0 without a sun
  float sunSinHalfAngle = 0.0f;   // sin α
};
SkySummary SummarizeSky(const Sky& sky);

// A cheap stand-in for a BSDF's directional albedo (luminance): the diffuse albedo, plus the GGX lobe's F0 weight.
// Only shapes the mixture.
float ReflectanceProxy(const Bsdf& bsdf);

// Estimates, as the luminance of reflected radiance, of what each sky strategy contributes unshadowed at a
// receiver; -1 where it cannot contribute at all.
// Sun: E f_r ≈ Y(L_sun f_r(ω_o, ω_sun)) Ω cos θ (Ω cos θ is the irradiance of a small disc per unit radiance,
// exactly π sin²α cos θ for a disc above the horizon). Near the horizon (|cos θ| < sin α, the disc crossing it)
// cos θ is replaced by the ramp (cos θ + sin α)² / (4 sin α), which meets it with its slope at sin α and reaches 0
// where the whole disc has set; below that (every direction of the disc behind the shading or geometric normal's
// horizon, with a margin for rounding) the sun cannot contribute.
float SunEstimate(const ShadingPoint& sp, const Sky& sky, const SkySummary& summary);
// Environment: a uniform sky of the map's mean luminance reflects ρ × that (the furnace), ρ = ReflectanceProxy.
float EnvironmentEstimate(const ShadingPoint& sp, const Sky& sky, const SkySummary& summary);

// The defensive mixture (Hesterberg 1995; as the per-pixel light distribution's power share): over the k
// strategies that can contribute (estimate >= 0), P_s = (1 − δ) e_s / Σ e + δ / k, or 1/k each when every estimate
// is 0, so every strategy that can contribute keeps P >= δ/k whatever the estimates get wrong; the others get 0.
// The last strategy that can contribute takes the remainder, so the three sum to 1 in float.
inline constexpr float kDefensiveStrategyShare = 0.1f;
LightMixture MixLightStrategies(float localEstimate, float sunEstimate, float environmentEstimate);

// The strategy u in [0, 1) chooses: local below P_local, the sun below P_local + P_sun, else the environment (the
// last strategy with P > 0 where rounding leaves u above the sum).
LightStrategy ChooseLightStrategy(const LightMixture& m, float u);

// Solid-angle density with which the mixture's light sampling produces the sky direction ω.
inline float SkyLightPdf(const LightMixture& m, const Sky& sky, const Vec3& w) {
  const float sun = m.sun > 0.0f ? m.sun * sky.SunPdf(w) : 0.0f;
  const float environment = m.environment > 0.0f ? m.environment * sky.EnvironmentPdf(w) : 0.0f;
  return sun + environment;
}

// The sun's exact unshadowed contribution at a diffuse receiver, for the difference estimator under a sky
// (sim/reference/reference_samples.h SkySamples): L_sun (albedo / π) ∫ over the disc of n · ω dω =
// L_sun albedo sin²α (n · d), exact where the whole disc is in front of both the shading and the geometric normal
// (the cap's cosine-weighted solid angle is π sin²α cos θ there; Snyder 1996, "Area light sources for real-time
// graphics"), and 0 where the viewer is below the shading normal (EvalBsdf's diffuse value is). False, leaving out
// alone, where the disc is not wholly in front of both normals by a margin, or there is no sun.
bool SunDifferenceConstant(const ShadingPoint& sp, const Sky& sky, glm::dvec3& out);

// A direction from the sun (u0, u1: its cone) or the environment (uSelect, uCoin: the texel; u0, u1: the
// direction within it) strategy.
Vec3 SampleSkyStrategy(const Sky& sky, LightStrategy s, float uSelect, float uCoin, float u0, float u1);

}  // namespace restir
