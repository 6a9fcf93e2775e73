#include "sim/reference/reference_sky.h"

#include <algorithm>
#include <cmath>

namespace restir {

namespace {

// Rounding of a unit direction is ~1e-7 per component: a disc this far behind a horizon (in cos θ) is behind it
// for every direction the sampler can return.
constexpr float kHorizonMargin = 1e-5f;

}  // namespace

SkySummary SummarizeSky(const Sky& sky) {
  SkySummary s;
  if (sky.HasEnvironment()) {
    const EnvironmentMap& map = sky.environment->Map();
    double sum = 0.0;
    for (int r = 0; r < map.height; ++r) {
      const double omega = EnvironmentTexelSolidAngle(map, r);
      for (int c = 0; c < map.width; ++c) {
        const float y = Luminance(sky.environmentScale * map.texels[static_cast<size_t>(r) * map.width + c]);
        if (y > 0.0f && std::isfinite(y)) sum += double(y) * omega;
      }
    }
    s.environmentMeanLuminance = static_cast<float>(sum / (4.0 * M_PI));
  }
  if (sky.hasSun) {
    const double oneMinusCos = sky.sun.oneMinusCos;
    s.sunSolidAngle = static_cast<float>(2.0 * M_PI * oneMinusCos);
    s.sunSinHalfAngle = static_cast<float>(std::sqrt(oneMinusCos * (2.0 - oneMinusCos)));
  }
  return s;
}

float ReflectanceProxy(const Bsdf& bsdf) {
  const float diffuse = Luminance(bsdf.albedo);
  if (bsdf.type != BsdfType::kLayered) return std::max(0.0f, diffuse);
  return std::max(0.0f, diffuse + bsdf.specularWeight * Luminance(bsdf.specular));
}

float SunEstimate(const ShadingPoint& sp, const Sky& sky, const SkySummary& summary) {
  if (!sky.hasSun) return -1.0f;
  const Vec3& d = sky.sun.direction;
  const float sinAlpha = summary.sunSinHalfAngle;
  const float cosS = glm::dot(sp.shadingNormal, d), cosG = glm::dot(sp.geometricNormal, d);
  if (cosS < -(sinAlpha + kHorizonMargin) || cosG < -(sinAlpha + kHorizonMargin)) return -1.0f;
  const float cosTheta = cosS >= sinAlpha ? cosS : (cosS + sinAlpha) * (cosS + sinAlpha) / (4.0f * sinAlpha);
  // f_r towards the disc's centre; where the centre has set, the diffuse stand-in (f_r is 0 below the horizon).
  const Vec3 fr =
      cosS > 0.0f ? EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, d) : Vec3(ReflectanceProxy(sp.bsdf) * kInvPi);
  const float e = Luminance(sky.sun.radiance * fr) * summary.sunSolidAngle * std::max(0.0f, cosTheta);
  return std::isfinite(e) ? std::max(0.0f, e) : 0.0f;
}

bool SunDifferenceConstant(const ShadingPoint& sp, const Sky& sky, glm::dvec3& out) {
  if (!sky.hasSun || sp.bsdf.type != BsdfType::kDiffuse) return false;
  const double oneMinusCos = sky.sun.oneMinusCos;
  const double sin2 = oneMinusCos * (2.0 - oneMinusCos);  // sin²α = (1 − cos α)(1 + cos α)
  const double sinAlpha = std::sqrt(sin2);
  const glm::dvec3 d(sky.sun.direction);
  const double cosS = glm::dot(glm::dvec3(sp.shadingNormal), d), cosG = glm::dot(glm::dvec3(sp.geometricNormal), d);
  // The disc's edge is at cos θ − sin α ... cos θ + sin α from the horizon; the margin covers float rounding of a
  // direction in it (1e-7) with room to spare.
  const double limit = sinAlpha + 1e-4;
  if (!(cosS > limit) || !(cosG > limit)) return false;
  out = glm::dot(sp.shadingNormal, sp.wo) > 0.0f
            ? glm::dvec3(sky.sun.radiance) * glm::dvec3(sp.bsdf.albedo) * (sin2 * cosS)
            : glm::dvec3(0.0);
  return true;
}

float EnvironmentEstimate(const ShadingPoint& sp, const Sky& sky, const SkySummary& summary) {
  if (!sky.HasEnvironment()) return -1.0f;
  const float e = ReflectanceProxy(sp.bsdf) * summary.environmentMeanLuminance;
  return std::isfinite(e) ? std::max(0.0f, e) : 0.0f;
}

LightMixture MixLightStrategies(float localEstimate, float sunEstimate, float environmentEstimate) {
  const float e[3] = {localEstimate, sunEstimate, environmentEstimate};
  bool can[3];
  int k = 0, last = -1;
  double total = 0.0;
  for (int s = 0; s < 3; ++s) {
    // NaN compares false: a strategy whose estimate is NaN counts as one that can contribute, with estimate 0.
    can[s] = !(e[s] < 0.0f);
    if (!can[s]) continue;
    ++k;
    last = s;
    if (std::isfinite(e[s])) total += e[s];
  }
  LightMixture m{0.0f, 0.0f, 0.0f};
  if (k == 0) return m;
  float p[3] = {0.0f, 0.0f, 0.0f}, before = 0.0f;
  for (int s = 0; s < 3; ++s) {
    if (!can[s]) continue;
    if (s == last) {
      p[s] = std::max(0.0f, 1.0f - before);
      break;
    }
    const double share = total > 0.0 && std::isfinite(total)
                             ? (1.0 - kDefensiveStrategyShare) * (std::isfinite(e[s]) ? e[s] : 0.0) / total +
                                   kDefensiveStrategyShare / k
                             : 1.0 / k;
    p[s] = static_cast<float>(share);
    before += p[s];
  }
  m.local = p[0];
  m.sun = p[1];
  m.environment = p[2];
  return m;
}

LightStrategy ChooseLightStrategy(const LightMixture& m, float u) {
  if (u < m.local) return LightStrategy::kLocal;
  if (u < m.local + m.sun) return LightStrategy::kSun;
  if (m.environment > 0.0f) return LightStrategy::kEnvironment;
  return m.sun > 0.0f ? LightStrategy::kSun : LightStrategy::kLocal;
}

Vec3 SampleSkyStrategy(const Sky& sky, LightStrategy s, float uSelect, float uCoin, float u0, float u1) {
  // The density the sampler reports is that of its own strategy; the estimator needs the mixture's
  // (SkyLightPdf), so it is dropped here.
  float pdf = 0.0f;
  return s == LightStrategy::kSun ? sky.SampleSun(u0, u1, pdf)
                                  : sky.SampleEnvironment(uSelect, uCoin, u0, u1, pdf);
}

}  // namespace restir
