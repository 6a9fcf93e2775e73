// The independent quadrature (visibility_quadrature.h) against closed forms: Lambert's polygon formula where
// nothing occludes, and the same formula on the light clipped by the plane through the receiver and a
// straight occluder edge where something does. Everything here is deterministic (no sampling), so the
// tolerances are accuracy claims, not statistical bands.
#include "visibility_quadrature.h"

#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "core/polygon_irradiance.h"
#include "tests/sim/scene_fixtures.h"

namespace restir {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::vector<glm::dvec3> QuadOf(const Light& l) {
  return {glm::dvec3(l.vertices[0]), glm::dvec3(l.vertices[1]), glm::dvec3(l.vertices[2]),
          glm::dvec3(l.vertices[5])};
}

// Lambert's formula in double throughout. core/polygon_irradiance.h is the same formula, but its clip returns
// float vertices: 10 m from the origin that moves a clipped vertex up to 5e-7 m off the light's plane, which
// for a receiver 1 mm in front of that plane (grazing emission) changes E by 4e-4, four times this test's
// tolerance. MatchesLambertAtGrazingEmissionAndFarFromOrigin checks that the two agree where no such rounding
// arises.
double Lambert(const glm::dvec3& x, const glm::dvec3& n, const std::vector<glm::dvec3>& polygon,
               double radiance) {
  double sum = 0.0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const glm::dvec3 a = glm::normalize(polygon[i] - x);
    const glm::dvec3 b = glm::normalize(polygon[(i + 1) % polygon.size()] - x);
    const glm::dvec3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (len == 0.0) continue;
    sum += std::atan2(len, glm::dot(a, b)) * glm::dot(n, c / len);
  }
  return 0.5 * radiance * std::abs(sum);
}

// Sutherland–Hodgman against one plane: the part of a convex polygon with m·(p - x) >= 0.
std::vector<glm::dvec3> ClipToHalfSpace(const std::vector<glm::dvec3>& polygon, const glm::dvec3& x,
                                        const glm::dvec3& m) {
  std::vector<glm::dvec3> out;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const glm::dvec3& a = polygon[i];
    const glm::dvec3& b = polygon[(i + 1) % polygon.size()];
    const double da = glm::dot(m, a - x), db = glm::dot(m, b - x);
    if (da >= 0.0) out.push_back(a);
    if ((da >= 0.0) != (db >= 0.0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// Irradiance from a one-sided quad light seen from x (normal n): zero behind the light's plane, Lambert on
// the part above x's horizon otherwise.
double LambertOneSided(const Vec3& x, const Vec3& n, const Light& l) {
  const std::vector<glm::dvec3> quad = QuadOf(l);
  const glm::dvec3 xd(x), nd(n);
  if (glm::dot(glm::cross(quad[1] - quad[0], quad[2] - quad[0]), xd - quad[0]) <= 0.0) return 0.0;
  const std::vector<glm::dvec3> above = ClipToHalfSpace(quad, xd, nd);
  return above.size() >= 3 ? Lambert(xd, nd, above, l.radiance.x) : 0.0;
}

// The same on the part of the light that a straight occluder edge AB leaves visible from x: the light clipped
// to the side of the plane through x and AB away from `inside` (a point of the occluder). Exact when the
// occluder covers everything on its side of that plane between x and the light.
double LambertBeyondEdge(const Vec3& x, const Vec3& n, const Light& l, const Vec3& a, const Vec3& b,
                         const Vec3& inside) {
  const glm::dvec3 xd(x), nd(n);
  glm::dvec3 m = glm::cross(glm::dvec3(b) - glm::dvec3(a), glm::dvec3(a) - xd);
  if (glm::dot(m, glm::dvec3(inside) - xd) > 0.0) m = -m;
  const std::vector<glm::dvec3> visible = ClipToHalfSpace(ClipToHalfSpace(QuadOf(l), xd, m), xd, nd);
  return visible.size() >= 3 ? Lambert(xd, nd, visible, l.radiance.x) : 0.0;
}

// Evaluates the quadrature at every receiver, in parallel (each result depends on its receiver alone).
std::vector<test::QuadratureResult> EvaluateAll(const test::VisibilityQuadrature& quad,
                                                const std::vector<Vec3>& xs, const Vec3& n,
                                                int receiverObject, int grid) {
  std::vector<test::QuadratureResult> out(xs.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, xs.size()), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) out[i] = quad.Irradiance(xs[i], n, receiverObject, grid);
  });
  return out;
}

// An unoccluded quad light over a floor, tilted by 0°, 45°, 80° and 89° (emitting towards
// (sin t, -cos t, 0)), once high (wholly above the floor) and once low (crossing the floor plane, so Lambert
// needs the horizon clip), with the whole configuration translated by 0, 10, 100 and 1000 m along (1, 1, 1).
// Receivers: a 7 x 7 grid of floor points (some on the floor quad's diagonal, where its two triangles meet,
// which must not shadow them), plus points 1 mm and 1 cm in front of the tilted light's plane (grazing
// emission) and 1 mm behind it (exactly 0). Receivers within 0.55 m of the light's centre are skipped: there
// the integrand peaks on a scale the grid does not resolve, which is a statement about the grid, not about
// visibility. Claim: relative error <= 1e-4 everywhere, and within the quadrature's own error estimate.
TEST(VisibilityQuadrature, MatchesLambertAtGrazingEmissionAndFarFromOrigin) {
  constexpr int kGrid = 16;
  double worstRel = 0.0, worstRatio = 0.0;
  int points = 0, zeros = 0;
  for (const double offset : {0.0, 10.0, 100.0, 1000.0}) {
    for (const double height : {0.6, 0.1}) {
      for (const double tiltDeg : {0.0, 45.0, 80.0, 89.0}) {
        const double t = tiltDeg * kDeg;
        const glm::dvec3 shift(offset);
        Sequence seq;
        test::AddMaterial(seq, "floor", Vec3(0.5f));
        test::AddQuadObject(seq, "floor", 0, Vec3(shift), Vec3(3, 0, 0), Vec3(0, 0, -3));
        const glm::dvec3 c = shift + glm::dvec3(0.0, height, 0.0);
        test::AddQuadLight(seq, "light", Vec3(c), Vec3(0.25 * glm::dvec3(std::cos(t), std::sin(t), 0.0)),
                           Vec3(0, 0, 0.25f), Vec3(3.0f));
        seq.cameraKeys.push_back(CameraKey{});
        const FrameState state = test::StaticState(seq);
        const test::VisibilityQuadrature quad(seq, state);
        const Vec3 n(0, 1, 0);

        std::vector<Vec3> xs;
        std::vector<bool> behind;
        for (int i = -3; i <= 3; ++i)
          for (int k = -3; k <= 3; ++k) {
            const glm::dvec3 p = shift + glm::dvec3(0.5 * i, 0.0, 0.5 * k);
            if (glm::length(p - c) < 0.55) continue;
            xs.push_back(Vec3(p));
            behind.push_back(false);
          }
        if (tiltDeg > 0.0) {
          // Floor points at signed distance delta from the light's plane: sin t (px - cx) + cos t h = delta.
          for (const double delta : {1e-3, 1e-2, -1e-3})
            for (const double z : {-1.5, -0.75, 0.75, 1.5}) {
              const double px = c.x + (delta - std::cos(t) * height) / std::sin(t);
              xs.push_back(Vec3(glm::dvec3(px, shift.y, shift.z + z)));
              behind.push_back(delta < 0.0);
            }
        }
        const auto results = EvaluateAll(quad, xs, n, 0, kGrid);
        for (size_t i = 0; i < xs.size(); ++i) {
          const double exact = LambertOneSided(xs[i], n, seq.lights[0]);
          const double q = results[i].irradiance.x, est = results[i].errorEstimate.x;
          ++points;
          if (behind[i]) {
            EXPECT_EQ(exact, 0.0) << "test setup: meant to be behind the light's plane";
          }
          if (exact == 0.0) {
            ++zeros;
            EXPECT_EQ(q, 0.0) << "behind the light's plane; offset " << offset << " tilt " << tiltDeg;
            continue;
          }
          const double rel = std::abs(q - exact) / exact;
          worstRel = std::max(worstRel, rel);
          if (est > 0.0) worstRatio = std::max(worstRatio, std::abs(q - exact) / est);
          EXPECT_LE(rel, 1e-4) << "offset " << offset << " height " << height << " tilt " << tiltDeg << " x ("
                               << xs[i].x << ", " << xs[i].y << ", " << xs[i].z << ") exact " << exact
                               << " quad " << q;
          EXPECT_LE(std::abs(q - exact), est + 1e-9 * exact)
              << "outside its error estimate; offset " << offset << " tilt " << tiltDeg;
          // The project's float-interface closed form agrees with the double one where its rounding is
          // harmless.
          if (offset == 0.0 && height > 0.5) {
            const std::vector<Vec3> quad{seq.lights[0].vertices[0], seq.lights[0].vertices[1],
                                         seq.lights[0].vertices[2], seq.lights[0].vertices[5]};
            EXPECT_NEAR(PolygonIrradiance(xs[i], n, quad, 3.0), exact, 1e-9 * exact);
          }
        }
      }
    }
  }
  std::printf(
      "unoccluded: %d receivers (%d behind the light), worst relative error %.2e, worst |error|/estimate "
      "%.3f\n",
      points, zeros, worstRel, worstRatio);
}

// A large opaque quad at half the light's height whose straight edge (at 30° to the axes) crosses the light's
// solid angle: the visible part of the light is the light clipped by the plane through the receiver and the
// edge, a closed form. On a 17 x 17 grid of floor receivers spanning full light, penumbra and umbra, the
// quadrature must agree with it within its own error estimate, and the estimate must be tight (below 1% of
// the unoccluded irradiance) so that the agreement means something. The edge is oblique to both rules' sample
// rows; ThinOccluderShadowsExactlyAndClipsBeyondItsEdge has one parallel to the light's sides.
TEST(VisibilityQuadrature, AgreesWithEdgeClippedLambertWithinItsErrorEstimate) {
  constexpr int kGrid = 32;
  Sequence seq;
  test::AddMaterial(seq, "grey", Vec3(0.5f));
  test::AddQuadObject(seq, "floor", 0, Vec3(0), Vec3(3, 0, 0), Vec3(0, 0, -3));
  const glm::dvec3 edgeDir(std::sin(30 * kDeg), 0.0, std::cos(30 * kDeg));
  const glm::dvec3 across(std::cos(30 * kDeg), 0.0, -std::sin(30 * kDeg));
  const glm::dvec3 edgePoint(0.0, 0.5, 0.0);
  // Corners c - u ± v lie on the edge line through edgePoint.
  test::AddQuadObject(seq, "occluder", 0, Vec3(edgePoint + 2.0 * across), Vec3(2.0 * across),
                      Vec3(3.0 * edgeDir));
  test::AddQuadLight(seq, "light", Vec3(0, 1, 0), Vec3(0.3f, 0, 0), Vec3(0, 0, 0.3f), Vec3(4.0f));
  seq.cameraKeys.push_back(CameraKey{});
  const FrameState state = test::StaticState(seq);
  const test::VisibilityQuadrature quad(seq, state);
  const Mesh& occ = seq.objects[1].mesh;
  const Vec3 a = occ.positions[0], b = occ.positions[3];
  const Vec3 inside = Vec3(edgePoint + 2.0 * across);
  const Vec3 n(0, 1, 0);

  std::vector<Vec3> xs;
  for (int i = -8; i <= 8; ++i)
    for (int k = -8; k <= 8; ++k) xs.push_back(Vec3(0.1f * i, 0.0f, 0.1f * k));
  const auto results = EvaluateAll(quad, xs, n, 0, kGrid);
  double worstRatio = 0.0, worstRelError = 0.0, worstRelEstimate = 0.0;
  int umbra = 0, penumbra = 0, lit = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    const double unoccluded = LambertOneSided(xs[i], n, seq.lights[0]);
    const double exact = LambertBeyondEdge(xs[i], n, seq.lights[0], a, b, inside);
    const double q = results[i].irradiance.x, est = results[i].errorEstimate.x;
    if (exact == 0.0) {
      ++umbra;
      EXPECT_EQ(q, 0.0) << "umbra receiver " << i;
      continue;
    }
    (exact < unoccluded * (1.0 - 1e-9) ? penumbra : lit)++;
    const double err = std::abs(q - exact);
    EXPECT_LE(err, est + 1e-12 * unoccluded) << "receiver (" << xs[i].x << ", " << xs[i].z << ") exact "
                                             << exact << " quad " << q << " estimate " << est;
    EXPECT_LT(est, 1e-2 * unoccluded) << "receiver (" << xs[i].x << ", " << xs[i].z << ")";
    if (est > 0.0) worstRatio = std::max(worstRatio, err / est);
    worstRelError = std::max(worstRelError, err / unoccluded);
    worstRelEstimate = std::max(worstRelEstimate, est / unoccluded);
  }
  std::printf(
      "straight edge: %d umbra, %d penumbra, %d lit receivers; worst |error| %.2e and estimate %.2e of the "
      "unoccluded irradiance; worst |error|/estimate %.3f\n",
      umbra, penumbra, lit, worstRelError, worstRelEstimate, worstRatio);
  EXPECT_GT(penumbra, 50);
  EXPECT_GT(umbra, 10);
  EXPECT_GT(lit, 10);
}

// A flat box 1 mm thick whose underside is 3 mm above the floor, lit by a tilted quad light beyond its edge.
// Floor points under the box are fully shadowed: exactly 0 (every segment enters the box's underside; nothing
// slips through the floor or the box's diagonals). Floor points outside it, from 0.2 mm to 10 cm from its
// edge, see the light above the plane through the point and the box's top near edge: Lambert on the light
// clipped by that plane, which takes them through umbra (< 3.9 mm), penumbra and full light (> 12.5 mm). The
// shadow edge on the light is parallel to the light's sides (the case that defeats level differences of a
// single rule). The quadrature must agree within its error estimate, and the estimate must stay below 1% of
// the unoccluded irradiance.
TEST(VisibilityQuadrature, ThinOccluderShadowsExactlyAndClipsBeyondItsEdge) {
  constexpr int kGrid = 64;
  Sequence seq;
  test::AddMaterial(seq, "grey", Vec3(0.5f));
  test::AddQuadObject(seq, "floor", 0, Vec3(0), Vec3(2, 0, 0), Vec3(0, 0, -2));
  test::AddBoxObject(seq, "slab", 0, Vec3(0.0f, 0.003f, -1.0f), Vec3(1.0f, 0.004f, 1.0f));
  const double t = -45.0 * kDeg;  // emits towards (-1, -1, 0) / sqrt 2, at the box's edge
  test::AddQuadLight(seq, "light", Vec3(0.5f, 0.3f, 0.0f),
                     Vec3(0.15 * glm::dvec3(std::cos(t), std::sin(t), 0.0)), Vec3(0, 0, 0.15f), Vec3(6.0f));
  seq.cameraKeys.push_back(CameraKey{});
  const FrameState state = test::StaticState(seq);
  const test::VisibilityQuadrature quad(seq, state);
  const Vec3 n(0, 1, 0);
  const Vec3 a(0.0f, 0.004f, -1.0f), b(0.0f, 0.004f, 1.0f), inside(0.5f, 0.0035f, 0.0f);

  std::vector<Vec3> under, outside;
  for (const float z : {-0.05f, 0.0f, 0.05f}) {
    for (const float s : {0.0005f, 0.001f, 0.002f, 0.005f, 0.01f, 0.05f, 0.2f, 0.5f})
      under.push_back(Vec3(s, 0, z));
    for (const float r : {0.0002f, 0.001f, 0.002f, 0.003f, 0.004f, 0.005f, 0.006f, 0.007f, 0.008f, 0.009f,
                          0.010f, 0.011f, 0.012f, 0.014f, 0.02f, 0.05f, 0.1f})
      outside.push_back(Vec3(-r, 0, z));
  }
  const auto underResults = EvaluateAll(quad, under, n, 0, kGrid);
  for (size_t i = 0; i < under.size(); ++i) {
    EXPECT_EQ(underResults[i].irradiance.x, 0.0)
        << "under the box at x = " << under[i].x << ", z = " << under[i].z;
    EXPECT_EQ(underResults[i].errorEstimate.x, 0.0);
  }
  const auto results = EvaluateAll(quad, outside, n, 0, kGrid);
  int umbra = 0, penumbra = 0, lit = 0;
  double worstRatio = 0.0, worstRelError = 0.0;
  for (size_t i = 0; i < outside.size(); ++i) {
    const double unoccluded = LambertOneSided(outside[i], n, seq.lights[0]);
    const double exact = LambertBeyondEdge(outside[i], n, seq.lights[0], a, b, inside);
    const double q = results[i].irradiance.x, est = results[i].errorEstimate.x;
    ASSERT_GT(unoccluded, 0.0);
    if (exact == 0.0) {
      ++umbra;
      EXPECT_EQ(q, 0.0) << "umbra at x = " << outside[i].x;
      continue;
    }
    (exact < unoccluded * (1.0 - 1e-9) ? penumbra : lit)++;
    const double err = std::abs(q - exact);
    EXPECT_LE(err, est + 1e-12 * unoccluded) << "x = " << outside[i].x << ", z = " << outside[i].z
                                             << " exact " << exact << " quad " << q << " estimate " << est;
    EXPECT_LT(est, 1e-2 * unoccluded) << "x = " << outside[i].x;
    if (est > 0.0) worstRatio = std::max(worstRatio, err / est);
    worstRelError = std::max(worstRelError, err / unoccluded);
  }
  std::printf(
      "thin occluder: %zu receivers under it all 0; outside %d umbra, %d penumbra, %d lit; worst |error| "
      "%.2e of the unoccluded irradiance; worst |error|/estimate %.3f\n",
      under.size(), umbra, penumbra, lit, worstRelError, worstRatio);
  EXPECT_GE(umbra, 6);
  EXPECT_GE(penumbra, 15);
  EXPECT_GE(lit, 6);
}

}  // namespace
}  // namespace restir
