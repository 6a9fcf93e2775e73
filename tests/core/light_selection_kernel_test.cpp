// The light-selection kernel (core/light_selection_kernel.h) and the equations it evaluates:
// - every SIMD target this machine supports reproduces the scalar twin bit for bit (DESIGN §3), on blocks of 1 to
//   16 receivers (diffuse, GGX from mirror to rough, layered, black; tilted, grazing, 1000 m from the origin)
//   under light sets of 1 to 300 triangles (tiny, huge, behind the receiver, straddling its horizon, switched off);
// - the twin's cdf is the defensive mixture of its weights and the power shares, recomputed here in double, and
//   every light whose share float can represent keeps a positive step (the estimator's unbiasedness rests on it;
//   a share under a millionth of the total, as a float cdf has always lost, biases by less than that share);
// - the irradiance estimate is Lambert's formula (core/polygon_irradiance.h PolygonIrradiance in double on the
//   triangle clipped by ClipPolygonToHemisphere, an independent form: acos, polygon clipping) to 2e-4 where it
//   takes the exact path (and to 1.5e-3 of the radiance where an edge passes close to the receiver), and within
//   1.5 size / d where it takes the point path (against a midpoint quadrature where Lambert's sum loses its
//   digits), for triangles and quads, over a
//   grid of receivers and triangles: overhead, tilted, straddling the horizon, grazing, below it, tiny, huge,
//   near and far from the origin.
#include "core/light_selection_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/kernel_test_support.h"
#include "core/polygon_irradiance.h"
#include "core/simd.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace light_selection_kernel_test {

class LightSelectionKernel : public test::SimdTargetTest {};

using test::Bits;
using test::RandomUnit;

// A random emitter near x: a triangle, or a quad (a parallelogram cut into A B C and A C D, as quad lights are) in
// two of every five. Sizes from a millimetre to a hundred metres, distances from a centimetre to a kilometre; mostly
// above the receiver, some across or below its horizon.
void AddRandomLight(std::mt19937& rng, const Vec3& x, const Vec3& n, std::vector<LightTriangle>& out) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (;;) {
    const float size = std::pow(10.0f, -3.0f + 5.0f * u(rng));
    const float distance = std::pow(10.0f, -2.0f + 5.0f * u(rng));
    const float lift = u(rng) < 0.7f ? 1.0f : (u(rng) < 0.5f ? 0.0f : -1.0f);
    const Vec3 c = x + distance * glm::normalize(lift * n + 1.2f * RandomUnit(rng));
    const Vec3 a = size * RandomUnit(rng), b = size * RandomUnit(rng);
    const Vec3 radiance = u(rng) < 0.1f ? Vec3(0.0f) : Vec3(u(rng) * 30, u(rng) * 30, u(rng) * 30);
    LightTriangle t0, t1;
    if (u(rng) < 0.4f) {
      const Vec3 q[4] = {c - a - b, c + a - b, c + a + b, c - a + b};
      if (MakeLightTriangle(q[0], q[1], q[2], radiance, t0) && MakeLightTriangle(q[0], q[2], q[3], radiance, t1)) {
        out.push_back(t0);
        out.push_back(t1);
        return;
      }
    } else if (MakeLightTriangle(c, c + a, c + b, radiance, t0)) {
      out.push_back(t0);
      return;
    }
  }
}

struct LightSet {
  std::vector<LightTriangle> triangles;
  LightGroups groups;
  std::vector<float> powerPmf;  // per triangle
  std::vector<SelectionLight> lights;
  SelectionLights View() const { return SelectionLights{lights.data(), lights.size()}; }
};

// `count` emitters, at least one with power (the reference builds no distribution over dark lights).
LightSet RandomLights(std::mt19937& rng, const Vec3& x, const Vec3& n, size_t count) {
  LightSet s;
  for (size_t l = 0; l < count; ++l) AddRandomLight(rng, x, n, s.triangles);
  if (s.triangles[0].radiance == Vec3(0.0f)) s.triangles[0].radiance = Vec3(1.0f);
  double power = 0.0;
  for (const LightTriangle& t : s.triangles) power += LightPower(t);
  for (const LightTriangle& t : s.triangles) s.powerPmf.push_back(static_cast<float>(LightPower(t) / power));
  s.groups = MakeLightGroups(s.triangles);
  s.lights = MakeSelectionLights(s.triangles, s.groups, s.powerPmf);
  return s;
}

// A block of receivers around `centre` (a block is a run of a row's pixels: near each other, similar normals, but
// not always).
SelectionReceivers RandomBlock(std::mt19937& rng, const Vec3& centre, const Vec3& normal, size_t count,
                               size_t materials) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  SelectionReceivers r{};
  r.count = count;
  for (size_t k = 0; k < kSelectionBlock; ++k) {
    const Vec3 x = centre + 0.05f * Vec3(u(rng), u(rng), u(rng));
    const Vec3 ng = k % 5 == 4 ? RandomUnit(rng) : normal;
    const Vec3 ns = k % 3 == 0 ? ng : glm::normalize(ng + 0.3f * RandomUnit(rng));
    const Vec3 wo = glm::normalize(ng * (k % 7 == 0 ? 0.001f : 1.0f) + 0.8f * RandomUnit(rng));
    for (int c = 0; c < 3; ++c) {
      r.x[c][k] = x[c];
      r.ng[c][k] = ng[c];
      r.n[c][k] = ns[c];
      r.wo[c][k] = wo[c];
    }
    r.materialId[k] = static_cast<int32_t>(rng() % materials);
  }
  return r;
}

ShadingPoint PointOf(const SelectionReceivers& r, size_t k, const std::vector<Bsdf>& bsdfs) {
  ShadingPoint sp;
  for (int c = 0; c < 3; ++c) {
    sp.position[c] = r.x[c][k];
    sp.geometricNormal[c] = r.ng[c][k];
    sp.shadingNormal[c] = r.n[c][k];
    sp.wo[c] = r.wo[c][k];
  }
  sp.bsdf = bsdfs[static_cast<size_t>(r.materialId[k])];
  return sp;
}

TEST_F(LightSelectionKernel, EveryTargetMatchesTheScalarTwinAndTheTwinIsTheMixture) {
  std::mt19937 rng(20261128);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::vector<Bsdf> bsdfs = test::KernelMaterials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const std::vector<size_t> lightCounts{1, 2, 3, 4, 5, 7, 8, 17, 72, 144, 300};  // emitters: triangles or quads
  size_t compared = 0, exactChecks = 0;
  for (int trial = 0; trial < 240; ++trial) {
    const float far = trial % 4 == 0 ? 1000.0f : 1.0f;  // far from the origin
    const Vec3 centre = far * Vec3(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    const Vec3 normal = trial % 6 == 0 ? Vec3(0, 1, 0) : RandomUnit(rng);
    // Blocks of one material kind, as the reference forms them, and mixed ones.
    const size_t kinds = trial % 3 == 0 ? 2 : bsdfs.size();
    const size_t count = 1 + static_cast<size_t>(trial) % kSelectionBlock;
    const SelectionReceivers block = RandomBlock(rng, centre, normal, count, kinds);
    const LightSet lights = RandomLights(rng, centre, normal, lightCounts[trial % lightCounts.size()]);
    const size_t n = lights.lights.size();
    ASSERT_EQ(n, lights.groups.first.size());
    std::vector<float> work(n * kSelectionBlock), columns(n * kSelectionBlock, -1.0f), twinEstimate(kSelectionBlock);
    BuildLightSelectionScalar(block, materials, lights.View(), work.data(), columns.data(), twinEstimate.data());
    std::vector<float> twin(n * kSelectionBlock, -1.0f);
    SelectionRows(columns.data(), n, count, twin.data());
    // The twin is the mixture (1 - δ) w / Σw + δ Φ / ΣΦ of its own weights, accumulated in order.
    for (size_t r = 0; r < count; ++r) {
      const ShadingPoint sp = PointOf(block, r, bsdfs);
      double total = 0.0;
      std::vector<double> w(n);
      for (size_t l = 0; l < n; ++l) total += w[l] = LightSelectionWeight(sp, lights.lights[l]);
      const bool mixed = total > 0.0 && std::isfinite(total);
      double running = 0.0;
      const float* cdf = twin.data() + r * n;
      for (size_t l = 0; l < n; ++l) {
        // A group's power share is its triangles'.
        const uint32_t t = lights.groups.first[l];
        const double power = lights.groups.split[l] <= 1.0f ? double(lights.powerPmf[t]) + lights.powerPmf[t + 1]
                                                           : double(lights.powerPmf[t]);
        const double step = mixed ? (1.0 - kDefensivePowerShare) * w[l] / total + kDefensivePowerShare * power : power;
        running += step;
        ASSERT_NEAR(cdf[l], running, 1e-5 * running + 1e-30) << "trial " << trial << " receiver " << r << " light " << l;
        if (l > 0) { ASSERT_GE(cdf[l], cdf[l - 1]); }
        // A light whose share float can hold (a step above a millionth of the running total, 16 ulps) keeps it.
        if (step > 1e-6 * running) {
          ASSERT_GT(cdf[l], l > 0 ? cdf[l - 1] : 0.0f) << "a light lost its share: trial " << trial << " light " << l;
        }
      }
      ASSERT_GT(cdf[n - 1], 0.0f);
      if (mixed) {
        EXPECT_NEAR(twinEstimate[r], total, 1e-5 * total);
        ++exactChecks;
      }
    }
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      EXPECT_STREQ(LightSelectionKernelDispatchedTargetName(), test::ExpectedDispatchName(t));
      std::vector<float> gotColumns(n * kSelectionBlock, -2.0f), got(n * kSelectionBlock, -2.0f), gotEstimate(kSelectionBlock);
      BuildLightSelection(block, materials, lights.View(), work.data(), gotColumns.data(), gotEstimate.data());
      for (size_t l = 0; l < n; ++l)
        for (size_t r = 0; r < count; ++r)
          ASSERT_EQ(Bits(gotColumns[l * kSelectionBlock + r]), Bits(columns[l * kSelectionBlock + r]))
              << SimdTargetName(t) << " trial " << trial;
      SelectionRows(gotColumns.data(), n, count, got.data());
      for (size_t r = 0; r < count; ++r) {
        ASSERT_EQ(Bits(gotEstimate[r]), Bits(twinEstimate[r])) << SimdTargetName(t) << " trial " << trial;
        for (size_t l = 0; l < n; ++l)
          ASSERT_EQ(Bits(got[r * n + l]), Bits(twin[r * n + l]))
              << SimdTargetName(t) << " trial " << trial << " receiver " << r << " light " << l;
        compared += n;
      }
      // Nothing is written past the block's receivers.
      for (size_t e = count * n; e < got.size(); ++e) ASSERT_EQ(got[e], -2.0f) << SimdTargetName(t);
    }
  }
  EXPECT_GT(compared, 100000u);
  EXPECT_GT(exactChecks, 1000u);
}

// The emitter's polygon: a triangle's three vertices, or a quad's four.
std::vector<Vec3> Polygon(const std::vector<LightTriangle>& tris) {
  const LightTriangle& t = tris[0];
  std::vector<Vec3> p{t.p0, t.p0 + t.e1, t.p0 + t.e2};
  if (tris.size() == 2) p.push_back(tris[1].p0 + tris[1].e2);
  return p;
}

// Lambert's formula (the answer) for the emitter clipped to x's hemisphere, in double.
double Lambert(const Vec3& x, const Vec3& n, const std::vector<LightTriangle>& tris) {
  const std::vector<Vec3> clipped = ClipPolygonToHemisphere(x, n, Polygon(tris));
  return clipped.size() >= 3 ? PolygonIrradiance(x, n, clipped, Luminance(tris[0].radiance)) : 0.0;
}

// The same integral, ∫ L cos θx cos θy / d² dA, by the midpoint rule on each triangle cut into k² similar ones, in
// double: for an emitter small against its distance, where Lambert's sum cancels to (size / d)² and loses its
// digits in double, this brute force keeps them.
double Quadrature(const Vec3& x, const Vec3& n, const std::vector<LightTriangle>& tris, int k) {
  double total = 0.0;
  for (const LightTriangle& t : tris) {
    const glm::dvec3 p0(t.p0), e1(t.e1), e2(t.e2), xd(x), nd(n), ln(t.normal);
    double sum = 0.0;
    for (int i = 0; i < k; ++i)
      for (int j = 0; i + j < k; ++j)
        for (int up = 0; up < 2 && !(up && i + j == k - 1); ++up) {
          const double b1 = (i + (up ? 2.0 : 1.0) / 3.0) / k, b2 = (j + (up ? 2.0 : 1.0) / 3.0) / k;
          const glm::dvec3 d = p0 + b1 * e1 + b2 * e2 - xd;
          const double d2 = glm::dot(d, d);
          sum += std::max(0.0, glm::dot(nd, d)) * std::max(0.0, -glm::dot(ln, d)) / (d2 * d2);
        }
    total += sum * 0.5 * glm::length(glm::cross(e1, e2)) / (k * k) * Luminance(t.radiance);
  }
  return total;
}

TEST(LightIrradianceEstimate, IsLambertsFormulaOrItsPointEstimate) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  size_t exact = 0, point = 0, below = 0, quads = 0, degenerate = 0;
  double worstExact = 0.0, worstPoint = 0.0;
  for (int i = 0; i < 200000; ++i) {
    // Near the origin, any size from a millimetre and distance from a centimetre; 1e4 m from it, where a float
    // keeps millimetres, sizes from 10 cm and distances from a metre. Triangles, and quads cut in two.
    const bool far = i % 2 == 1;
    const Vec3 x = far ? 1e4f * Vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f) : Vec3(u(rng), u(rng), u(rng));
    const Vec3 n = i % 4 == 0 ? Vec3(0, 0, 1) : RandomUnit(rng);
    const float size = far ? std::pow(10.0f, -1.0f + 3.0f * u(rng)) : std::pow(10.0f, -3.0f + 5.0f * u(rng));
    const float distance = far ? std::pow(10.0f, 3.0f * u(rng)) : std::pow(10.0f, -2.0f + 5.0f * u(rng));
    const float lift = u(rng) < 0.6f ? 1.0f : (u(rng) < 0.5f ? 0.0f : -1.0f);
    const Vec3 c = x + distance * glm::normalize(lift * n + 1.2f * RandomUnit(rng));
    const Vec3 a = size * RandomUnit(rng), b = size * RandomUnit(rng);
    std::vector<LightTriangle> tris(i % 3 == 0 ? 2 : 1);
    if (tris.size() == 2) {
      const Vec3 q[4] = {c - a - b, c + a - b, c + a + b, c - a + b};
      if (!MakeLightTriangle(q[0], q[1], q[2], Vec3(3.0f, 1.0f, 0.5f), tris[0]) ||
          !MakeLightTriangle(q[0], q[2], q[3], Vec3(3.0f, 1.0f, 0.5f), tris[1]))
        continue;
    } else if (!MakeLightTriangle(c, c + a, c + b, Vec3(3.0f, 1.0f, 0.5f), tris[0])) {
      continue;
    }
    const LightGroups groups = MakeLightGroups(tris);
    ASSERT_EQ(groups.first.size(), 1u) << "a quad is one group";
    const SelectionLight light = MakeSelectionLights(tris, groups, std::vector<float>(tris.size(), 0.5f))[0];
    quads += light.vertices == 4;
    const float got = LightIrradianceEstimate(x, n, light);
    ASSERT_TRUE(std::isfinite(got)) << i;
    ASSERT_GE(got, 0.0f);
    // A light that faces away, or that the receiver sees edge-on (within kEdgeOn2 of its plane), gives nothing,
    // whatever its geometry.
    const float facing = glm::dot(tris[0].normal, x) - light.offset;
    if (!(facing > 0.0f && facing * facing > kEdgeOn2 * light.size2)) {
      ASSERT_EQ(got, 0.0f);
      continue;
    }
    const Vec3 d = light.centroid - x;
    const double d2 = glm::dot(d, d);
    bool above = true, under = true;
    for (const Vec3& v : Polygon(tris)) {
      above = above && glm::dot(n, v - x) >= 0.0f;
      under = under && glm::dot(n, v - x) < 0.0f;
    }
    const double lum = Luminance(tris[0].radiance);
    if (under) {
      ASSERT_EQ(got, 0.0f);
      ++below;
    } else if (above && d2 > kPointLightDistance2 * light.size2) {
      // The point estimate: L A cos θx cos θy / d² at the centroid against the integral. The centroid rule is
      // exact for a linear integrand, but a light barely above the horizon has cos θx vary by its whole value
      // across it: the error is first order in size / d, 1.22 size / d the worst measured over 2e5 random
      // triangles (float rounding 1e4 m from the origin included).
      const double r = std::sqrt(light.size2 / d2);
      const double expected = r > 0.01 ? Lambert(x, n, tris) : Quadrature(x, n, tris, 8);
      // Relative to the integral, and to L A / d² (what the emitter gives facing the receiver head on), for an
      // emitter seen edge-on, whose integral is a rounding of zero.
      const double bound = (1.5 * r + 1e-3) * expected + 1e-5 * light.lumArea / d2;
      const double err = std::fabs(got - expected);
      ASSERT_LE(err, bound) << i << " got " << got << " expected " << expected << " size/d " << r;
      worstPoint = std::max(worstPoint, err / bound);
      ++point;
    } else {
      // Clipped Lambert in float against double: the Θ / sin Θ fit (1.7e-5), and float rounding of the directions,
      // which the terms of an edge passing close to the receiver (up to π each) carry into the sum: an absolute
      // error up to about 1e-3 of the radiance (9.1e-4 the worst of 2e6 random triangles around a receiver).
      // 1e4 m from the origin, also the rounding of x and the vertices (half an ulp of 1e4, about 5e-4 m) against
      // their distance: each edge's angle (up to π) moves by a few ulp(|x|) / d.
      const double expected = Lambert(x, n, tris);
      if (!std::isfinite(expected)) {
        // The double formula's own degenerate case: clipping put a vertex twice on the horizon, and the zero edge
        // between them has no normal. It has no answer to compare with.
        ++degenerate;
        continue;
      }
      const double err = std::fabs(got - expected);
      float nearest = std::numeric_limits<float>::infinity();
      for (const Vec3& v : Polygon(tris)) nearest = std::min(nearest, glm::length(v - x));
      const double rounding = 8.0 * 0x1p-23 * std::max({std::fabs(x.x), std::fabs(x.y), std::fabs(x.z)}) / nearest;
      const double bound = 2e-4 * expected + (1.5e-3 + 4.0 * kPi * rounding) * lum;
      ASSERT_LE(err, bound) << i << " got " << got << " expected " << expected;
      worstExact = std::max(worstExact, err / bound);
      ++exact;
    }
  }
  EXPECT_GT(exact, 5000u);
  EXPECT_GT(point, 5000u);
  EXPECT_GT(below, 1000u);
  EXPECT_GT(quads, 30000u);
  EXPECT_LT(degenerate, 20u);
  RecordProperty("worst_exact_error_over_bound", std::to_string(worstExact));
  RecordProperty("worst_point_error_over_bound", std::to_string(worstPoint));
}

// The per-tile weight above the per-pixel light limit: the light's luminance times the solid angle it subtends.
// Against the exact solid angle of the triangle (Van Oosterom and Strackee 1983, in double) from 20 to 1000 sizes
// away, near the origin (1 cm to 10 m lights) and 1e4 m from it (1 to 100 m lights, well above the float spacing),
// where the centroid estimate is within 3% (its error is O((size/d)²));
// exactly 0 behind the light; finite and at most L A / size² right beside it (the clamp).
TEST(TileLightWeight, IsTheRadianceTimesTheSolidAngleInFrontAndZeroBehind) {
  using D3 = glm::dvec3;
  std::mt19937 rng(40);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int front = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 origin = i % 2 ? 1e4f * RandomUnit(rng) : Vec3(0.0f);
    const float size = i % 2 ? std::pow(10.0f, 2.0f * u(rng)) : std::pow(10.0f, -2.0f + 3.0f * u(rng));
    const Vec3 c = origin + size * RandomUnit(rng);
    std::vector<LightTriangle> tris(1);
    if (!MakeLightTriangle(c, c + size * RandomUnit(rng), c + size * RandomUnit(rng), Vec3(2.0f, 1.0f, 0.5f), tris[0]))
      continue;
    const LightGroups groups = MakeLightGroups(tris);
    const SelectionLight light = MakeSelectionLights(tris, groups, {1.0f})[0];
    const float distance = size * std::pow(10.0f, 1.3f + 1.7f * u(rng));
    const Vec3 x = light.centroid + distance * RandomUnit(rng);
    const D3 v[3] = {D3(tris[0].p0) - D3(x), D3(tris[0].p0 + tris[0].e1) - D3(x), D3(tris[0].p0 + tris[0].e2) - D3(x)};
    const double facing = glm::dot(D3(light.normal), D3(x) - D3(light.centroid));
    const float got = TileLightWeight(x, light);
    if (facing <= 0.0) {
      EXPECT_EQ(got, 0.0f) << i;
      continue;
    }
    const double l[3] = {glm::length(v[0]), glm::length(v[1]), glm::length(v[2])};
    const double denominator = l[0] * l[1] * l[2] + glm::dot(v[0], v[1]) * l[2] + glm::dot(v[0], v[2]) * l[1] +
                               glm::dot(v[1], v[2]) * l[0];
    const double solidAngle = 2.0 * std::fabs(std::atan2(glm::dot(v[0], glm::cross(v[1], v[2])), denominator));
    if (solidAngle < 1e-9) continue;  // seen edge-on: nothing to compare
    EXPECT_NEAR(got / (light.lumRadiance * solidAngle), 1.0, 0.03) << i;
    ++front;
  }
  EXPECT_GT(front, 5000);
  // Right beside the light (d far below its size): finite, bounded by the clamp.
  std::vector<LightTriangle> tris(1);
  ASSERT_TRUE(MakeLightTriangle(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1.0f), tris[0]));
  const SelectionLight light = MakeSelectionLights(tris, MakeLightGroups(tris), {1.0f})[0];
  const float beside = TileLightWeight(light.centroid + 1e-6f * light.normal, light);
  EXPECT_GT(beside, 0.0f);
  EXPECT_LE(beside, light.lumArea / light.size2);
}

// The clipped formula on hand-made cases whose answer is known without it: a triangle wholly above equals the
// unclipped polygon formula; one cut by the horizon plane equals the formula on its part above; one wholly below
// gives 0; a square crossing the horizon equals the formula on the rectangle above.
TEST(HorizonClippedPolygonIrradiance, AgreesWithTheClosedFormAcrossTheHorizon) {
  const Vec3 n(0, 0, 1);
  for (const float scale : {1e-3f, 1.0f, 1e3f}) {
    const Vec3 a[3] = {scale * Vec3(1, 0, 1), scale * Vec3(0, 1, 1), scale * Vec3(-1, -1, 1)};
    const double whole = PolygonIrradiance(Vec3(0), n, {a[0], a[1], a[2]}, 1.0);
    EXPECT_NEAR(HorizonClippedPolygonIrradiance<3>(a, n), whole, 2e-5 * whole) << scale;
    // A vertical triangle standing across the horizon: (1, 0, -1), (1, 1, 0), (1, 0, 1); its part above is
    // (1, 0, 0), (1, 1, 0), (1, 0, 1).
    const Vec3 diamond[3] = {scale * Vec3(1, 0, -1), scale * Vec3(1, 1, 0), scale * Vec3(1, 0, 1)};
    const double upper = PolygonIrradiance(Vec3(0), n, {scale * Vec3(1, 0, 0), scale * Vec3(1, 1, 0), scale * Vec3(1, 0, 1)}, 1.0);
    EXPECT_NEAR(HorizonClippedPolygonIrradiance<3>(diamond, n), upper, 2e-4 * upper) << scale;
    const Vec3 below[3] = {scale * Vec3(1, 0, -1), scale * Vec3(0, 1, -1), scale * Vec3(-1, -1, -2)};
    EXPECT_EQ(HorizonClippedPolygonIrradiance<3>(below, n), 0.0f) << scale;
    // A vertical square x = 1, y in [-1, 1], z in [-0.5, 1.5]: above the horizon the rectangle z in [0, 1.5].
    const Vec3 square[4] = {scale * Vec3(1, -1, -0.5f), scale * Vec3(1, 1, -0.5f), scale * Vec3(1, 1, 1.5f),
                            scale * Vec3(1, -1, 1.5f)};
    const double rectangle = PolygonIrradiance(
        Vec3(0), n, {scale * Vec3(1, -1, 0), scale * Vec3(1, 1, 0), scale * Vec3(1, 1, 1.5f), scale * Vec3(1, -1, 1.5f)},
        1.0);
    EXPECT_NEAR(HorizonClippedPolygonIrradiance<4>(square, n), rectangle, 2e-4 * rectangle) << scale;
  }
}

// Θ / sin Θ between unit vectors at every angle, against std::acos in double on the same float vectors: relative
// error under 2e-5, down to Θ within 1e-5 of π (an edge passing 1e-5 of its length from the receiver).
TEST(ThetaOverSinTheta, MatchesAcosOverSine) {
  for (int i = 0; i <= 400000; ++i) {
    const double theta = 3.14159265358979 * i / 400000.0 * (1.0 - 1e-5 / 3.2);
    const Vec3 a(1.0f, 0.0f, 0.0f), b(static_cast<float>(std::cos(theta)), static_cast<float>(std::sin(theta)), 0.0f);
    const glm::dvec3 ad(a), bd(b);
    const double bLength = glm::length(bd);
    const double cosine = glm::dot(ad, bd) / bLength, sine = glm::length(glm::cross(ad, bd)) / bLength;
    const double expected = sine == 0.0 ? 1.0 : std::atan2(sine, cosine) / sine;
    const Vec3 s = a + b;
    ASSERT_NEAR(ThetaOverSinTheta(glm::dot(a, b), glm::dot(s, s)), expected, 2e-5 * expected) << theta;
  }
  // An edge through the receiver (Θ = π): finite.
  EXPECT_TRUE(std::isfinite(ThetaOverSinTheta(-1.0f, 0.0f)));
}

}  // namespace light_selection_kernel_test
}  // namespace restir
