// The reference at glossy receivers without a sky (light sampling with its MIS weight in the light-draw kernel, BSDF
// sampling in the BSDF-draw kernel) against an answer it did not compute: the outgoing radiance of a GGX floor
// under a quad light, integrated over the light by a deterministic midpoint rule on subtriangles, with the
// microfacet BRDF written out here in double from its papers (Walter et al. 2007 Eq. 20: D G2 F / (4 cos θo cos θi);
// GGX D; Heitz 2014 Eq. 99 height-correlated Smith; Schlick's Fresnel with F0 = albedo), not taken from core/bsdf.
// Nothing occludes the light, so the integral is the whole answer. Rough to fairly sharp lobes (roughness 0.3 to
// 0.8), the light overhead and off to the side, the highlight in view.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tests/sim/scene_fixtures.h"
#include "sim/run/frame_loop.h"
#include "sim/reference/reference.h"

namespace restir {
namespace {

using DVec3 = glm::dvec3;

// f_r(wo, wi) of a GGX surface of normal n, alpha = roughness², F0 = f0: zero outside the upper hemisphere.
double Ggx(double alpha, double f0, const DVec3& n, const DVec3& wo, const DVec3& wi) {
  const double cosO = glm::dot(n, wo), cosI = glm::dot(n, wi);
  if (cosO <= 0.0 || cosI <= 0.0) return 0.0;
  const DVec3 h = glm::normalize(wo + wi);
  const double a2 = alpha * alpha, cosH = glm::dot(n, h);
  const double k = cosH * cosH * (a2 - 1.0) + 1.0;
  const double d = cosH > 0.0 ? a2 / (M_PI * k * k) : 0.0;
  auto lambda = [&](double c) { return 0.5 * (std::sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0); };
  const double g2 = 1.0 / (1.0 + lambda(cosO) + lambda(cosI));
  const double m = 1.0 - std::clamp(glm::dot(wi, h), 0.0, 1.0);
  const double fresnel = f0 + (1.0 - f0) * m * m * m * m * m;
  return fresnel * d * g2 / (4.0 * cosO * cosI);
}

// L_o at x seen from `eye`, r g b: Σ over the light's triangles, each cut into n² subtriangles, of f L cos θi
// cos θy / d² times the subtriangle's area at its centroid.
DVec3 Quadrature(const Sequence& seq, const Vec3& x, const Vec3& eye, double alpha, const Vec3& f0, int n) {
  const DVec3 xd(x), nd(0, 1, 0), wo = glm::normalize(DVec3(eye) - xd);
  DVec3 sum(0.0);
  for (const Light& l : seq.lights)
    for (size_t t = 0; t + 2 < l.vertices.size(); t += 3) {
      const DVec3 p0(l.vertices[t]), e1 = DVec3(l.vertices[t + 1]) - p0, e2 = DVec3(l.vertices[t + 2]) - p0;
      const DVec3 c = glm::cross(e1, e2);
      const DVec3 ny = glm::normalize(c);
      const double subArea = 0.5 * glm::length(c) / (double(n) * n);
      for (int a = 0; a < n; ++a)
        for (int b = 0; a + b < n; ++b)
          for (int flip = 0; flip < (a + b + 1 < n ? 2 : 1); ++flip) {
            const double ca = (a + (flip ? 2.0 : 1.0) / 3.0) / n, cb = (b + (flip ? 2.0 : 1.0) / 3.0) / n;
            const DVec3 y = p0 + ca * e1 + cb * e2;
            const DVec3 d = y - xd;
            const double dist2 = glm::dot(d, d);
            const DVec3 wi = d / std::sqrt(dist2);
            const double cosI = glm::dot(nd, wi), cosY = -glm::dot(ny, wi);
            if (cosI <= 0.0 || cosY <= 0.0) continue;
            for (int ch = 0; ch < 3; ++ch)
              sum[ch] += Ggx(alpha, f0[ch], nd, wo, wi) * l.radiance[ch] * cosI * cosY / dist2 * subArea;
          }
    }
  return sum;
}

struct GlossyCase {
  const char* name;
  float roughness;
  Vec3 lightCentre;
};

TEST(ReferenceGlossy, GgxFloorMatchesAnIndependentQuadratureOfTheLight) {
  const GlossyCase cases[] = {
      {"roughness 0.3, light overhead", 0.3f, Vec3(0.3f, 1.0f, -0.2f)},
      {"roughness 0.55, light overhead", 0.55f, Vec3(0.3f, 1.0f, -0.2f)},
      {"roughness 0.8, light overhead", 0.8f, Vec3(0.3f, 1.0f, -0.2f)},
      {"roughness 0.4, light low at the side", 0.4f, Vec3(-1.6f, 0.4f, -1.0f)},
  };
  const Vec3 albedo(0.9f, 0.6f, 0.3f);
  for (const GlossyCase& c : cases) {
    Sequence seq = test::FloorUnderQuadLight(24, 16, c.lightCentre.y, 0.5f);
    seq.materials[0].type = MaterialType::kGgx;
    seq.materials[0].roughness = c.roughness;
    seq.materials[0].albedo = albedo;
    seq.lights.clear();
    test::AddQuadLight(seq, "light", c.lightCentre, Vec3(0.25f, 0, 0), Vec3(0, 0, 0.25f), Vec3(5.0f, 4.0f, 3.0f));
    FrameLoop loop(seq, seq.width, seq.height);
    loop.BeginFrame(0);
    ReferenceParams params;
    params.samplesPerPixel = 512;
    const ReferenceImage ref = RenderReference(seq, loop.State(), loop.Scene(), loop.Gbuffer(), params);
    const GBuffer& g = loop.Gbuffer();
    const double alpha = double(c.roughness) * c.roughness;
    double z2 = 0.0, worst = 0.0, refSum = 0.0, quadSum = 0.0, varSum = 0.0;
    int count = 0;
    for (size_t i = 0; i < g.Size(); ++i) {
      if (!g.IsSurface(i) || g.lightId[i] >= 0) continue;
      const DVec3 quadrature = Quadrature(seq, g.Position(i), loop.State().camera.position, alpha, albedo, 96);
      for (int ch = 0; ch < 3; ++ch) {
        const double exact = quadrature[ch];
        const double value = ref.mean.pixels[i][ch], se = ref.standardError.pixels[i][ch];
        refSum += value;
        quadSum += exact;
        varSum += double(se) * se;
        if (!(se > 0.0f)) {
          EXPECT_NEAR(value, exact, 1e-6 * (1.0 + exact)) << c.name << " pixel " << i;  // no spread: no light
          continue;
        }
        const double z = (value - exact) / se;
        z2 += z * z;
        worst = std::max(worst, std::fabs(z));
        ++count;
      }
    }
    ASSERT_GT(count, 600) << c.name;
    // z has 15 degrees of freedom (16 replicates): E[z²] = 15/13. Bounds: the mean of z² within 0.7-1.6 over the
    // case's 1,080-1,125 pixel-channels, and no |z| above 8 (P(|t15| > 8) = 9e-7 per value: about 4e-3 over the
    // 4,365 of the four cases). Measured: mean z² 1.00-1.26, max |z| 3.9-5.1.
    EXPECT_GT(z2 / count, 0.7) << c.name;
    EXPECT_LT(z2 / count, 1.6) << c.name;
    EXPECT_LT(worst, 8.0) << c.name;
    // The frame's total within 4 standard errors of the quadrature's (about 6e-5 two-sided).
    EXPECT_LT(std::fabs(refSum - quadSum), 4.0 * std::sqrt(varSum)) << c.name << ": " << refSum << " vs " << quadSum;
  }
}

}  // namespace
}  // namespace restir
