// The project's reference renderer against an answer it did not compute: the brute-force quadrature with
// exact visibility (visibility_quadrature.h), in occluded configurations where no closed form exists. The
// reference and every estimator share one shadow-ray spawn rule, so every internal comparison shares its
// errors; these tests do not. Each is a statistical test with a stated false-failure rate; seeds are fixed,
// so the outcome is deterministic.
//
// The statistic. Per diffuse pixel, in the channel where the quadrature's radiance is largest (one channel
// per pixel: the three are rendered from the same samples and are not independent),
//   z = (ref.mean - ρ/π E_quad) / sqrt(se_ref² + (ρ/π err_quad)²),
// with se_ref from the reference's 16 replicates. Were the quadrature exact, z would be Student t with 15
// dof, so z² is F(1, 15): mean 15/13, variance 3.389. The quadrature's error estimate is conservative (an
// overestimate, visibility_quadrature.h), which can only shrink z, so only the upper side is tested:
//   (1) mean z² over the k pixels < 15/13 + 3.719 sqrt(3.389 / k) (normal approximation of the mean;
//       one-sided false-failure rate 1e-4), the test of a bias spread over many pixels, and
//   (2) every |z| below the two-sided Bonferroni bound of t15 at 1e-4 / k (false-failure rate 1e-4), the
//       test of a bias confined to a few pixels (a contact shadow, a leak beside an occluder). The replicate
//       means of a pixel lit by rare samples are far from normal, but they do not break this bound: lit in
//       one replicate only, a pixel has se_ref = its mean m, so z <= 1, and z << -1 only where the
//       quadrature expects many times the one hit seen (Poisson-unlikely: evidence, not noise).
// Per configuration the false-failure rate is at most 2e-4.
// Pixels where the reference is 0 +- 0 carry no t statistic: no replicate saw any light, so its spread says
// nothing about its error. Where the quadrature is exactly 0 too they agree (fully shadowed). Where it is
// not, the light there is either a rare event the reference did not sample (a sliver of a small light through
// a gap: with 768 samples over 72 lights, a light drawn roughly 0.7% of the time and 5% visible is missed by
// all of them three times in four) or light the reference wrongly blocks. The two cannot be told apart pixel
// by pixel, so (3) those pixels together must hold less than 1% of the quadrature's radiance over all
// compared pixels (a deterministic bound against a renderer that goes dark, not a statistical test).
#include <gtest/gtest.h>

#include "core/polygon_irradiance.h"
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "tests/sim/scene_fixtures.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"
#include "stats.h"
#include "visibility_quadrature.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace independent_visibility_test {

constexpr double kMeanTail = 1e-4;  // one-sided false-failure rate of the mean-z² test
constexpr double kMaxTail = 1e-4;   // false-failure rate of the largest-|z| test (Bonferroni over pixels)
constexpr int kDof = 15;            // 16 replicates
// Largest share of the quadrature's light that may fall on pixels the reference saw dark.
constexpr double kDarkShare = 1e-2;

// Two-sided Student-t tail P(|T_nu| > c), integrated directly over the tail (t = c / u, u in (0, 1]) by
// Simpson's rule, so that tails of 1e-8 keep their relative accuracy.
double StudentTwoSidedTail(int nu, double c) {
  const double norm = std::exp(std::lgamma(0.5 * (nu + 1)) - std::lgamma(0.5 * nu)) / std::sqrt(nu * M_PI);
  auto f = [&](double u) {
    if (u <= 0.0) return 0.0;
    const double t = c / u;
    return norm * std::pow(1.0 + t * t / nu, -0.5 * (nu + 1)) * c / (u * u);
  };
  const int n = 4000;
  double s = f(0.0) + f(1.0);
  for (int i = 1; i < n; ++i) s += f(static_cast<double>(i) / n) * (i % 2 ? 4.0 : 2.0);
  return 2.0 * s / (3.0 * n);
}

// The c with P(|T_nu| > c) = tail, by bisection.
double StudentCritical(int nu, double tail) {
  double lo = 0.0, hi = 1e4;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (StudentTwoSidedTail(nu, mid) > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

struct Outcome {
  int pixels = 0;      // pixels with a t statistic
  int zeroPixels = 0;  // reference and quadrature both exactly 0 with zero error
  int darkPixels = 0;  // the reference saw no light (0 +- 0), the quadrature some
  double darkShare =
      0.0;  // the quadrature's radiance there, as a share of its radiance over all compared pixels
  int unexplained = 0;  // a nonzero reference with zero standard error that the quadrature does not bear out
  // Pixels the reference has exactly (standard error 0 and light: every draw of every group it differenced there
  // arrived, sim/reference/reference_learning.h): each must lie within the quadrature's error bound of it, plus,
  // with an error target E, 3 E of it: a shadow taking less than about 1 / n of a light that n draws all missed
  // leaves such a pixel off by that much with no spread to show it (at a 2% target, 2 of 1394 lit pixels beside
  // the thin occluder, 0.8% and 0.2% off; none at 0.5%).
  int exactPixels = 0;
  double meanZ2 = 0.0;
  double meanZ2Bound = 0.0;
  double maxAbsZ = 0.0;
  double maxAbsZBound = 0.0;
  int beyondBound = 0;
  double meanRelDiff = 0.0;  // mean over lit pixels of (ref - quad) / quad
  double meanAbsRelDiff = 0.0;
  double sumRatio = 0.0;          // Σ ref / Σ quad - 1 over the compared pixels
  double meanQuadRelError = 0.0;  // mean over lit pixels of err_quad / quad
  double meanRefRelError = 0.0;   // mean over lit pixels of se_ref / quad
  std::string worst;              // the pixel with the largest |z|
};

// Renders the reference of the frame at `spp`, evaluates the quadrature at `grid` on (at most `maxPixels`, an
// even stride through) the diffuse pixels, and forms the statistics above. Pixels with a smooth shading
// normal (tessellated spheres) are left out: which normal a renderer shades them with is its convention, not
// visibility.
Outcome Compare(const char* name, const Sequence& seq, const FrameState& state, int spp, int grid,
                size_t maxPixels, double errorTarget = 0.0, ReferenceImage* out = nullptr, GBuffer* gOut = nullptr) {
  const auto start = std::chrono::steady_clock::now();
  EmbreeScene scene(seq);
  scene.Update(state);
  GBuffer g;
  TracePrimary(scene, state.camera, g);
  ReferenceParams params;
  params.samplesPerPixel = spp;
  params.targetRelativeError = errorTarget;
  const ReferenceImage ref = RenderReference(seq, state, scene, g, params);
  if (out) *out = ref;
  if (gOut) *gOut = g;
  const double refMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();

  std::vector<size_t> candidates;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i) || g.lightId[i] >= 0) continue;
    if (seq.materials[g.materialId[i]].type != MaterialType::kDiffuse) continue;
    if (glm::dot(g.ShadingNormal(i), g.GeometricNormal(i)) < 1.0f - 1e-6f) continue;
    candidates.push_back(i);
  }
  const size_t stride = std::max<size_t>(1, (candidates.size() + maxPixels - 1) / maxPixels);
  std::vector<size_t> pixels;
  for (size_t k = 0; k < candidates.size(); k += stride) pixels.push_back(candidates[k]);

  const test::VisibilityQuadrature quad(seq, state);
  std::vector<test::QuadratureResult> results(pixels.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, pixels.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) {
      const size_t i = pixels[k];
      results[k] = quad.Irradiance(g.Position(i), g.GeometricNormal(i), g.objectId[i], grid);
    }
  });
  const double quadMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() - refMs;

  Outcome o;
  double sumZ2 = 0.0, sumRef = 0.0, sumQuad = 0.0;
  int lit = 0;
  uint64_t rays = 0;
  std::vector<double> zs;
  for (size_t k = 0; k < pixels.size(); ++k) {
    const size_t i = pixels[k];
    const Vec3 albedo = seq.materials[g.materialId[i]].albedo;
    const glm::dvec3 e = results[k].irradiance, err = results[k].errorEstimate;
    rays += results[k].rays;
    int c = 0;
    for (int ch = 1; ch < 3; ++ch)
      if (albedo[ch] * e[ch] > albedo[c] * e[c]) c = ch;
    const double expected = albedo[c] / M_PI * e[c];
    const double quadErr = albedo[c] / M_PI * err[c];
    const double mean = ref.mean.pixels[i][c];
    const double se = ref.standardError.pixels[i][c];
    const double denom = std::sqrt(se * se + quadErr * quadErr);
    sumRef += mean;
    sumQuad += expected;
    if (expected > 0.0) {
      o.meanRelDiff += (mean - expected) / expected;
      o.meanAbsRelDiff += std::abs(mean - expected) / expected;
      o.meanQuadRelError += quadErr / expected;
      o.meanRefRelError += se / expected;
      ++lit;
    }
    if (se == 0.0) {
      if (mean == 0.0 && expected == 0.0 && quadErr == 0.0) {
        ++o.zeroPixels;
      } else if (mean == 0.0) {
        ++o.darkPixels;
        o.darkShare += expected;
      } else if (std::abs(mean - expected) <= quadErr + (1e-6 + 3.0 * errorTarget) * expected) {
        ++o.exactPixels;
      } else {
        ++o.unexplained;
        std::printf("  %s: pixel (%zu, %zu) ref %.6g with zero standard error, quad %.6g +- %.2g\n", name,
                    i % g.width, i / g.width, mean, expected, quadErr);
      }
      continue;
    }
    const double z = (mean - expected) / denom;
    zs.push_back(z);
    sumZ2 += z * z;
    if (std::abs(z) > o.maxAbsZ) {
      o.maxAbsZ = std::abs(z);
      char buf[256];
      const Vec3 x = g.Position(i);
      std::snprintf(buf, sizeof buf,
                    "pixel (%zu, %zu) object %d x (%.4f, %.4f, %.4f): ref %.5g +- %.2g, quad %.5g +- %.2g",
                    i % g.width, i / g.width, g.objectId[i], x.x, x.y, x.z, mean, se, expected, quadErr);
      o.worst = buf;
    }
  }
  o.pixels = static_cast<int>(zs.size());
  if (o.pixels > 0) {
    o.meanZ2 = sumZ2 / o.pixels;
    o.meanZ2Bound = 15.0 / 13.0 + test::NormalQuantileUpper(kMeanTail) * std::sqrt(3.389 / o.pixels);
    o.maxAbsZBound = StudentCritical(kDof, kMaxTail / o.pixels);
    for (double z : zs) o.beyondBound += std::abs(z) > o.maxAbsZBound ? 1 : 0;
  }
  if (lit > 0) {
    o.meanRelDiff /= lit;
    o.meanAbsRelDiff /= lit;
    o.meanQuadRelError /= lit;
    o.meanRefRelError /= lit;
  }
  o.sumRatio = sumQuad > 0.0 ? sumRef / sumQuad - 1.0 : 0.0;
  o.darkShare = sumQuad > 0.0 ? o.darkShare / sumQuad : 0.0;
  std::printf(
      "%s: %d pixels with a t statistic; mean z^2 %.3f (bound %.3f); max |z| %.2f (bound %.2f, %d "
      "beyond)\n",
      name, o.pixels, o.meanZ2, o.meanZ2Bound, o.maxAbsZ, o.maxAbsZBound, o.beyondBound);
  std::printf(
      "%s: %d pixels exactly 0 in both; %d where the reference saw no light (%.2e of the quadrature's "
      "radiance); %d exact within the quadrature's bound; %d unexplained\n",
      name, o.zeroPixels, o.darkPixels, o.darkShare, o.exactPixels, o.unexplained);
  std::printf(
      "%s: ref - quad over %d lit pixels: mean relative %+.4f, mean |relative| %.4f, sum ratio %+.4f; mean "
      "relative error of ref %.4f, of quad %.5f\n",
      name, lit, o.meanRelDiff, o.meanAbsRelDiff, o.sumRatio, o.meanRefRelError, o.meanQuadRelError);
  std::printf("%s: worst %s\n", name, o.worst.c_str());
  std::printf("%s: reference %.0f ms (%d spp), quadrature %.0f ms (grid %d, %.1f M rays)\n", name, refMs, spp,
              quadMs, grid, rays * 1e-6);
  return o;
}

void ExpectAgreement(const Outcome& o, int minPixels) {
  EXPECT_GE(o.pixels + o.exactPixels, minPixels);
  EXPECT_EQ(o.unexplained, 0);
  EXPECT_LT(o.darkShare, kDarkShare) << o.darkPixels << " pixels where the reference saw no light";
  EXPECT_LT(o.meanZ2, o.meanZ2Bound) << "bias spread over many pixels; worst " << o.worst;
  EXPECT_EQ(o.beyondBound, 0) << "max |z| " << o.maxAbsZ << " beyond " << o.maxAbsZBound << "; worst "
                              << o.worst;
}

// A diffuse floor under a flat box 1 mm thick whose underside is 3 mm above it, lit by a quad light low on
// one side (elevation 5°-20° from the box's far edge), so the box's 4 mm edge throws an umbra ~1 cm and a
// penumbra ~4 cm wide onto the floor beyond it. The camera looks down at that edge: box top, umbra, penumbra,
// full light.
Sequence ThinOccluderScene() {
  Sequence seq;
  seq.name = "thin_occluder";
  seq.contentHash = "fixture-thin-occluder";
  seq.width = 48;
  seq.height = 32;
  test::AddMaterial(seq, "floor", Vec3(0.6f));
  test::AddMaterial(seq, "slab", Vec3(0.7f));
  test::AddQuadObject(seq, "floor", 0, Vec3(0), Vec3(2, 0, 0), Vec3(0, 0, -2));
  test::AddBoxObject(seq, "slab", 1, Vec3(-0.2f, 0.003f, -0.2f), Vec3(0.2f, 0.004f, 0.2f));
  const double t = 70.0 * M_PI / 180.0;  // emits towards (sin t, -cos t, 0): towards +x and down
  test::AddQuadLight(seq, "light", Vec3(-0.5f, 0.15f, 0.0f),
                     Vec3(0.1 * glm::dvec3(std::cos(t), std::sin(t), 0.0)), Vec3(0, 0, 0.2f), Vec3(30.0f));
  CameraKey k;
  k.position = Vec3(0.32f, 0.18f, 0.12f);
  k.lookAt = Vec3(0.22f, 0.0f, 0.0f);
  k.vfovDegrees = 30.0f;
  seq.cameraKeys.push_back(k);
  return seq;
}

TEST(IndependentVisibility, ReferenceMatchesQuadratureBesideThinOccluder) {
  const Sequence seq = ThinOccluderScene();
  const Outcome o = Compare("thin occluder", seq, test::StaticState(seq), 1024, 32, 2000);
  ExpectAgreement(o, 800);
}

// The reference with --reference-error instead of a budget: its pixel counts come from the pilot, the estimate
// from fresh samples, so it must agree with the quadrature as well (no bias from the allocation), and reach
// about the relative standard error asked for: the pilot estimates the variance of independent samples, which
// the randomised QMC of the main pass only beats, so the mean achieved error lies at or below the target.
TEST(IndependentVisibility, ErrorTargetedReferenceMatchesQuadratureAndReachesItsTarget) {
  const Sequence seq = ThinOccluderScene();
  for (double target : {0.02, 0.005}) {
    ReferenceImage ref;
    const Outcome o = Compare("thin occluder, error target", seq, test::StaticState(seq), 0, 32, 2000, target, &ref);
    ExpectAgreement(o, 800);
    std::printf("target %.3f: mean relative standard error %.4f\n", target, o.meanRefRelError);
    EXPECT_LT(o.meanRefRelError, 1.2 * target);
    EXPECT_GT(o.meanRefRelError, 0.1 * target);
  }
}

// Budget mode spends the samples where the pilot saw variance: the penumbra beyond the slab's edge (visibility
// noise) gets more than the fully lit floor, and the mean stays the budget.
TEST(IndependentVisibility, BudgetGoesToThePenumbraAndAveragesTheBudget) {
  const Sequence seq = ThinOccluderScene();
  const FrameState state = test::StaticState(seq);
  EmbreeScene scene(seq);
  scene.Update(state);
  GBuffer g;
  TracePrimary(scene, state.camera, g);
  ReferenceParams params;
  params.samplesPerPixel = 256;
  const ReferenceImage ref = RenderReference(seq, state, scene, g, params);
  const test::VisibilityQuadrature quad(seq, state);
  double sumAll = 0.0, sumPenumbra = 0.0, sumLit = 0.0;
  int all = 0, penumbra = 0, lit = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i) || g.objectId[i] != 0) continue;  // the floor
    // Visible fraction of the light: the quadrature over Lambert's unoccluded irradiance.
    const test::QuadratureResult q = quad.Irradiance(g.Position(i), g.GeometricNormal(i), g.objectId[i], 16);
    const Light& l = seq.lights.front();
    const std::vector<Vec3> clipped = ClipPolygonToHemisphere(
        g.Position(i), g.GeometricNormal(i), {l.vertices[0], l.vertices[1], l.vertices[2], l.vertices[5]});
    const double open = clipped.size() >= 3 ? PolygonIrradiance(g.Position(i), g.GeometricNormal(i), clipped,
                                                                 l.radiance.x)
                                            : 0.0;
    const double visible = q.irradiance.x / std::max(1e-30, open);
    sumAll += ref.pixelSamples[i];
    ++all;
    if (visible > 0.1 && visible < 0.9) {
      sumPenumbra += ref.pixelSamples[i];
      ++penumbra;
    } else if (visible > 0.999) {
      sumLit += ref.pixelSamples[i];
      ++lit;
    }
  }
  std::printf("budget 256: mean samples %.1f over %d floor pixels, %.1f in %d penumbra pixels, %.1f in %d lit\n",
              sumAll / all, all, sumPenumbra / penumbra, penumbra, sumLit / lit, lit);
  ASSERT_GT(penumbra, 20);
  ASSERT_GT(lit, 20);
  EXPECT_GT(sumPenumbra / penumbra, 2.0 * sumLit / lit);
  uint64_t total = 0;
  uint32_t most = 0;
  int active = 0;
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i)) {
      total += ref.pixelSamples[i];
      most = std::max(most, ref.pixelSamples[i]);
      ++active;
    }
  EXPECT_NEAR(double(total) / active, 256.0, 0.1 * 256.0);
  // The memory estimate's bound on a pixel's samples (its block's samples are held at once), the pilot's 16 beside.
  EXPECT_LE(double(most), ReferenceMaxSamplesPerPixel(params) + 16.0);
}

TEST(IndependentVisibility, ReferenceMatchesQuadratureUnderLampAboveSlab) {
  Sequence seq;
  seq.name = "slab_lamp";
  seq.contentHash = "fixture-slab-lamp";
  test::AddMaterial(seq, "floor", Vec3(0.6f));
  test::AddMaterial(seq, "slab", Vec3(0.7f));
  test::AddQuadObject(seq, "floor", 0, Vec3(0), Vec3(2, 0, 0), Vec3(0, 0, -2));
  test::AddBoxObject(seq, "slab", 1, Vec3(-0.15f, 0.0f, -0.15f), Vec3(0.15f, 0.1f, 0.15f));
  // cross(u, v) with u = +x, v = +z points down.
  test::AddQuadLight(seq, "lamp", Vec3(0.0f, 0.12f, 0.0f), Vec3(0.04f, 0, 0), Vec3(0, 0, 0.04f),
                     Vec3(100.0f));
  CameraKey top;
  top.position = Vec3(0.05f, 0.5f, 0.3f);
  top.lookAt = Vec3(0.0f, 0.1f, 0.0f);
  top.vfovDegrees = 60.0f;
  seq.cameraKeys = {top};
  seq.width = 40;
  seq.height = 30;
  const Outcome slabTop = Compare("slab top", seq, test::StaticState(seq), 1024, 32, 2000);
  ExpectAgreement(slabTop, 250);

  CameraKey around;
  around.position = Vec3(0.0f, 1.3f, 1.1f);
  around.lookAt = Vec3(0.0f, 0.0f, 0.0f);
  around.vfovDegrees = 70.0f;
  seq.cameraKeys = {around};
  seq.width = 48;
  seq.height = 32;
  const Outcome floor = Compare("floor around slab", seq, test::StaticState(seq), 1024, 32, 2000);
  ExpectAgreement(floor, 300);
}

// The shipped window-bars sequence, frame 0, at 64 x 36: 72 lights, an interior seen through iron bars, and
// the interior's own occluders (sofa, table, cabinet, plinth), lights 2 cm from walls and ceiling. Every
// flat-shaded diffuse pixel (the reference's glossy lobe is not what the quadrature computes; the
// smooth-shaded ball is left out, see Compare), radiance albedo/π · E per channel. The grid is coarse (8)
// because most of the 72 emitters are small and far; the quadrature's error estimate stays ~6x below the
// reference's.
TEST(IndependentVisibility, ReferenceMatchesQuadratureInWindowBars) {
  const Sequence seq = LoadSequence(RESTIR_SOURCE_DIR "/sequences/window_bars_pan.json");
  const FrameState state = Evaluate(seq, 0, 64, 36);
  const Outcome o = Compare("window bars", seq, state, 768, 8, 4000);
  ExpectAgreement(o, 1000);
}

}  // namespace independent_visibility_test
}  // namespace restir
