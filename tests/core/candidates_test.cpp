// core/candidates.h: the multiple-importance densities of initial sampling's candidate sources.
// - The BSDF source's area density of a point on a light (BrdfAreaPdf: p_bsdf cos θ_y / d², zero past the cutoff
//   distance) integrates over the light to the probability that a BSDF ray hits it, measured here by casting
//   SampleBsdf's directions at the triangle with an intersection written in this file (Möller-Trumbore in double):
//   a binomial z-test per case, family false-failure rate 1e-4.
// - The balance weights m_s = M_s p_s / Σ_t M_t p_t built from those densities sum to one over the sources that can
//   produce a point or a direction, for every count mix (zeros included) and cutoff.
// - RTXDI's cutoff distance: sqrt((1/c − 1) pdf), infinite at c = 0.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "core/bsdf.h"
#include "core/candidates.h"
#include "core/light.h"
#include "core/rng.h"
#include "core/shading.h"
#include "stats.h"

namespace restir {
namespace {

// Ray-triangle intersection in double (Möller & Trumbore 1997): the distance, or -1 on a miss.
double HitDistance(const Vec3& o, const Vec3& d, const LightTriangle& t) {
  const glm::dvec3 O(o), D(d), P0(t.p0), E1(t.e1), E2(t.e2);
  const glm::dvec3 p = glm::cross(D, E2);
  const double det = glm::dot(E1, p);
  if (std::fabs(det) < 1e-300) return -1.0;
  const glm::dvec3 s = O - P0;
  const double u = glm::dot(s, p) / det;
  if (u < 0.0 || u > 1.0) return -1.0;
  const glm::dvec3 q = glm::cross(s, E1);
  const double v = glm::dot(D, q) / det;
  if (v < 0.0 || u + v > 1.0) return -1.0;
  const double dist = glm::dot(E2, q) / det;
  return dist > 0.0 ? dist : -1.0;
}

struct Case {
  const char* name;
  Bsdf bsdf;
  Vec3 wo;        // towards the viewer (the receiver's normal is +Y)
  Vec3 lightAt;   // the light triangle's centroid
  float size;     // its edge scale
  float cutoff;   // BRDF cutoff
};

std::vector<Case> Cases() {
  const Vec3 grazing = glm::normalize(Vec3(0.95f, 0.12f, 0.1f)), tilted = glm::normalize(Vec3(-0.5f, 0.8f, 0.2f));
  const Bsdf diffuse{BsdfType::kDiffuse, Vec3(0.7f)};
  const Bsdf rough{BsdfType::kGgx, Vec3(0.9f), 0.5f};
  const Bsdf glossy{BsdfType::kGgx, Vec3(0.9f), 0.05f};
  const Bsdf nearMirror{BsdfType::kGgx, Vec3(0.9f), 0.0064f};  // roughness 0.08
  Bsdf layered{BsdfType::kLayered, Vec3(0.4f), 0.1f};
  layered.specular = Vec3(0.04f);
  layered.specularWeight = 0.5f;
  // Mirror of wo about +Y: where the glossy lobes point.
  auto mirror = [](const Vec3& w, float dist) { return dist * Vec3(-w.x, w.y, -w.z); };
  return {
      {"diffuse, light overhead", diffuse, tilted, Vec3(0.2f, 1.0f, 0.1f), 0.5f, 0.0f},
      {"diffuse, light near the horizon", diffuse, tilted, Vec3(3.0f, 0.3f, 0.5f), 0.8f, 0.0f},
      {"rough GGX, light in the lobe", rough, tilted, mirror(tilted, 1.5f), 0.6f, 0.0f},
      {"glossy GGX, light in the lobe", glossy, tilted, mirror(tilted, 1.5f), 0.3f, 0.0f},
      {"glossy GGX, grazing view", glossy, grazing, mirror(grazing, 2.0f), 0.4f, 0.0f},
      {"near-mirror GGX, light in the lobe", nearMirror, tilted, mirror(tilted, 1.5f) + Vec3(0.0f, 0.0f, 0.3f), 0.3f, 0.0f},
      {"near-mirror GGX, grazing view", nearMirror, grazing, mirror(grazing, 2.0f) + Vec3(0.0f, 0.0f, 0.2f), 0.4f, 0.0f},
      {"layered, light in the lobe", layered, tilted, mirror(tilted, 1.2f), 0.4f, 0.0f},
      {"diffuse, cutoff 1e-4, far light", diffuse, tilted, Vec3(0.0f, 40.0f, 0.0f), 20.0f, 1e-4f},
      {"rough GGX, cutoff 0.02 across it", rough, tilted, mirror(tilted, 3.0f), 4.0f, 0.02f},
  };
}

LightTriangle TriangleFacing(const Vec3& centroid, float size, const Vec3& receiver) {
  // A triangle around `centroid`, tilted off facing the receiver so its cosine varies across it.
  const Vec3 towards = glm::normalize(receiver - centroid);
  Vec3 t, b;
  OrthonormalBasis(glm::normalize(towards + Vec3(0.3f, 0.0f, 0.2f)), t, b);
  const Vec3 p0 = centroid - size * (0.5f * t + 0.3f * b), p1 = centroid + size * (0.5f * t - 0.3f * b),
             p2 = centroid + size * 0.6f * b;
  LightTriangle lt;
  MakeLightTriangle(p0, p1, p2, Vec3(1.0f), lt);
  if (glm::dot(lt.normal, towards) < 0.0f) MakeLightTriangle(p0, p2, p1, Vec3(1.0f), lt);
  return lt;
}

TEST(Candidates, BrdfAreaDensityIntegratesToTheProbabilityThatABsdfRayHitsTheLight) {
  const std::vector<Case> cases = Cases();
  const double zBound = test::NormalQuantileUpper(0.5e-4 / double(cases.size()));
  for (size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    ShadingPoint sp;
    sp.position = Vec3(0.0f);
    sp.geometricNormal = sp.shadingNormal = Vec3(0.0f, 1.0f, 0.0f);
    sp.wo = c.wo;
    sp.bsdf = c.bsdf;
    const LightTriangle lt = TriangleFacing(c.lightAt, c.size, sp.position);
    // ∫_A BrdfAreaPdf dA by a midpoint rule on the triangle (barycentric grid of 400² cells, each halved).
    constexpr int kN = 400;
    double integral = 0.0;
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN - i; ++j)
        for (int half = 0; half < (j < kN - i - 1 ? 2 : 1); ++half) {
          const double a = (i + (half ? 2.0 / 3.0 : 1.0 / 3.0)) / kN, b = (j + (half ? 2.0 / 3.0 : 1.0 / 3.0)) / kN;
          const Vec3 y = lt.p0 + float(a) * lt.e1 + float(b) * lt.e2;
          const LightPath path = ConnectToLight(sp, y, lt.normal);
          if (!(path.geometry > 0.0f)) continue;
          const float pdf = PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi);
          integral += BrdfAreaPdf(pdf, -glm::dot(lt.normal, path.wi), path.distance, c.cutoff);
        }
    integral *= double(lt.area) / (double(kN) * kN);
    // The probability by casting rays: a hit counts when it is nearer than the ray's cutoff distance.
    constexpr int kRays = 1 << 20;
    int hits = 0;
    for (int r = 0; r < kRays; ++r) {
      // One key per ray: a key's dimensions repeat after 2^20 (core/rng.h).
      const RngKey key{7, static_cast<uint32_t>(k), static_cast<uint32_t>(r), static_cast<uint32_t>(RngPass::kTest)};
      const BsdfSample s = SampleBsdf(sp.bsdf, sp.shadingNormal, sp.wo, UniformFloat(key, 0), UniformFloat(key, 1));
      // A direction below the surface is no candidate (the pass's test), whatever it would hit.
      if (!(s.pdf > 0.0f) || !(glm::dot(sp.geometricNormal, s.wi) > 0.0f)) continue;
      const double t = HitDistance(sp.position, s.wi, lt);
      if (t > 0.0 && t <= BrdfRayMaxDistance(c.cutoff, s.pdf)) ++hits;
    }
    const double p = double(hits) / kRays;
    const double se = std::sqrt(std::max(integral * (1.0 - integral), 1e-12) / kRays);
    const double z = (p - integral) / se;
    std::printf("%-34s hit probability %.6f, integral of the area density %.6f, z %+.2f (bound %.2f)\n", c.name, p,
                integral, z, zBound);
    EXPECT_GT(integral, 1e-4) << c.name;  // the case has power: the light is within the lobe's reach
    EXPECT_LT(std::fabs(z), zBound) << c.name;
  }
}

TEST(Candidates, BalanceWeightsOfEverySourceSumToOne) {
  const RngKey key{11, 0, 0, static_cast<uint32_t>(RngPass::kTest)};
  uint32_t d = 0;
  auto u = [&] { return UniformFloat(key, d++); };
  int checked = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    CandidateCounts m;
    m.local = int(u() * 3.0f) * 4, m.sun = int(u() * 3.0f), m.environment = int(u() * 3.0f), m.brdf = int(u() * 3.0f);
    // Densities spanning many decades, zeros included.
    auto density = [&] { return u() < 0.2f ? 0.0f : std::pow(10.0f, -6.0f + 12.0f * u()); };
    const float area = density(), bsdfArea = density(), sun = density(), env = density(), bsdf = density();
    const float point = MixedPointPdf(m, area, bsdfArea);
    if (point > 0.0f) {
      const double sum = m.local * area / point + m.brdf * double(bsdfArea) / point;
      EXPECT_NEAR(sum, 1.0, 1e-5);
      ++checked;
    }
    const float direction = MixedDirectionPdf(m, sun, env, bsdf);
    if (direction > 0.0f) {
      const double sum = (m.sun * double(sun) + m.environment * double(env) + m.brdf * double(bsdf)) / direction;
      EXPECT_NEAR(sum, 1.0, 1e-5);
      ++checked;
    }
    EXPECT_EQ(MixedRisWeight(1.0f, 0.0f), 0.0f);
  }
  EXPECT_GT(checked, 10000);
}

TEST(Candidates, CutoffDistanceIsRtxdis) {
  EXPECT_TRUE(std::isinf(BrdfRayMaxDistance(0.0f, 3.0f)));
  for (float c : {1e-4f, 0.01f, 0.5f})
    for (float pdf : {1e-3f, 0.3f, 50.0f})
      EXPECT_FLOAT_EQ(BrdfRayMaxDistance(c, pdf), std::sqrt((1.0f / c - 1.0f) * pdf));
  // A point past the distance gets no BSDF density; one just inside keeps it.
  const float pdf = 2.0f, c = 0.01f, dmax = BrdfRayMaxDistance(c, pdf);
  EXPECT_EQ(BrdfAreaPdf(pdf, 0.5f, dmax * 1.001f, c), 0.0f);
  EXPECT_GT(BrdfAreaPdf(pdf, 0.5f, dmax * 0.999f, c), 0.0f);
}

}  // namespace
}  // namespace restir
