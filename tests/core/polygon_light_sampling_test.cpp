#include "core/polygon_light_sampling.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/clip_cases.h"

namespace restir {
namespace {

// 53-bit uniforms in [0, 1) from a fixed-seed Mersenne twister (its output is fixed by the standard; the
// library's distributions are not).
struct Uniforms {
  std::mt19937_64 engine;
  explicit Uniforms(uint64_t seed) : engine(seed) {}
  double operator()() { return static_cast<double>(engine() >> 11) * 0x1.0p-53; }
};

// SampleLinear inverts its cdf F(x) = (a x + (b − a) x² / 2) / ((a + b) / 2), weights from zero at one end to a
// millionfold ratio, to 1e-12.
TEST(SampleLinear, InvertsItsCdf) {
  for (const auto& [a, b] : std::vector<std::pair<double, double>>{
           {1, 1}, {0, 1}, {1, 0}, {3, 0.2}, {1e-6, 1}, {1, 1e6}, {0.01, 0.010001}})
    for (int i = 0; i < 1000; ++i) {
      const double u = i / 1000.0;
      const double x = SampleLinear(u, a, b);
      ASSERT_GE(x, 0.0);
      ASSERT_LE(x, 1.0);
      EXPECT_NEAR((a * x + (b - a) * x * x / 2) / ((a + b) / 2), u, 1e-12) << a << " " << b << " " << u;
    }
}

// SampleBilinear's y inverts the marginal cdf and its x the conditional one at that y, and BilinearPdf is their
// product (a midpoint sum of it over the square is 1, and it equals the two linear densities multiplied).
TEST(SampleBilinear, InvertsItsMarginalAndConditionalAndMatchesItsDensity) {
  const double ws[][4] = {{1, 1, 1, 1}, {0.01, 0.01, 1, 0.5}, {1, 0.2, 0.01, 0.7}, {0, 1, 1, 0}};
  for (const auto& w : ws) {
    double total = 0.0;
    for (int i = 0; i < 400; ++i)
      for (int j = 0; j < 400; ++j) total += BilinearPdf((i + 0.5) / 400, (j + 0.5) / 400, w) / (400.0 * 400.0);
    EXPECT_NEAR(total, 1.0, 1e-9);
    for (int i = 0; i < 50; ++i)
      for (int j = 0; j < 50; ++j) {
        const double u0 = i / 50.0, u1 = j / 50.0;
        double x, y;
        SampleBilinear(u0, u1, w, x, y);
        const double bottom = w[0] + w[1], top = w[2] + w[3];
        EXPECT_NEAR((bottom * y + (top - bottom) * y * y / 2) / ((bottom + top) / 2), u1, 1e-12);
        const double left = (1 - y) * w[0] + y * w[2], right = (1 - y) * w[1] + y * w[3];
        EXPECT_NEAR((left * x + (right - left) * x * x / 2) / ((left + right) / 2), u0, 1e-12);
        EXPECT_NEAR(BilinearPdf(x, y, w), LinearPdf(y, bottom, top) * LinearPdf(x, left, right),
                    1e-12 * BilinearPdf(x, y, w));
      }
  }
}

// Spherical triangles from the receiver at the origin to planar triangles: overhead, tilted, a sliver, one of
// nearly a hemisphere, and small ones down to the threshold below which the sampler takes area sampling.
std::vector<std::array<glm::dvec3, 3>> SphericalTriangles() {
  return {
      {glm::dvec3(-1, -1, 2), glm::dvec3(-1, 1, 2), glm::dvec3(1, 0, 2)},
      {glm::dvec3(-1, -1, 1.5), glm::dvec3(-0.5, 1, 2.5), glm::dvec3(1, 0, 1.2)},
      {glm::dvec3(0, 0, 1), glm::dvec3(3, 0.02, 1), glm::dvec3(3, -0.01, 1.2)},
      {glm::dvec3(-100, -100, 0.5), glm::dvec3(100, -100, 0.5), glm::dvec3(0, 150, 0.5)},
      {glm::dvec3(0.3, 0, 1), glm::dvec3(0.3011, 0, 1), glm::dvec3(0.3, 0.0022, 1)},  // 1.06e-6 sr
      {glm::dvec3(5, -1, 0.05), glm::dvec3(5, 0, 0.6), glm::dvec3(5, 1, 0.05)},
  };
}

// Arvo's map preserves area: the sub-triangle a, b, ĉ that u0 cuts off has u0 of the area, to 1e-9 relative; its
// corners are where its comment says (a to 1e-5 only: at u0 = 0, cos of the arc from a to ĉ rounds to 1 − O(ε / sin² α),
// whose square root leaves ĉ up to 1e-8 / sin α from a, 3e-6 at the sliver's corner; a set of measure zero).
TEST(SampleSphericalTriangle, FirstCoordinateCutsOffItsShareOfTheArea) {
  for (const auto& t : SphericalTriangles()) {
    const glm::dvec3 a = glm::normalize(t[0]), b = glm::normalize(t[1]), c = glm::normalize(t[2]);
    const double area = SphericalTriangleArea(a, b, c);
    ASSERT_GE(area, 0.99e-6);
    for (int i = 1; i <= 20; ++i) {
      const double u0 = i / 20.0;
      const glm::dvec3 cHat = SampleSphericalTriangle(a, b, c, area, u0, 1.0);
      EXPECT_NEAR(SphericalTriangleArea(a, b, cHat) / area, u0, 1e-9) << area << " " << u0;
    }
    EXPECT_LT(glm::length(SampleSphericalTriangle(a, b, c, area, 0.3, 0.0) - b), 1e-9);
    EXPECT_LT(glm::length(SampleSphericalTriangle(a, b, c, area, 0.0, 1.0) - a), 1e-5);
    EXPECT_LT(glm::length(SampleSphericalTriangle(a, b, c, area, 1.0, 1.0) - c), 1e-9);
  }
}

// Uniform in solid angle: directions from SampleSphericalTriangle counted in the 16 cells of the planar triangle's
// 4 × 4 subdivision against each cell's own solid angle (Van Oosterom and Strackee's formula on its corners, not
// the map's angle excess). Pearson's χ², 15 degrees of freedom, 16,000 draws per triangle: the critical value 44.3
// is exceeded with probability 1e-4 per triangle, 6e-4 over the six.
TEST(SampleSphericalTriangle, IsUniformInSolidAngle) {
  const int n = 4, draws = 16000;
  Uniforms u(7);
  for (const auto& t : SphericalTriangles()) {
    const glm::dvec3 a = glm::normalize(t[0]), b = glm::normalize(t[1]), c = glm::normalize(t[2]);
    const double area = SphericalTriangleArea(a, b, c);
    // The cells: for each lattice square (i, j) with i + j < n, its lower triangle, and its upper where it has one.
    std::vector<double> expected;
    std::vector<std::array<double, 4>> cells;  // i, j, upper, area
    std::vector<int> index(static_cast<size_t>(n * n * 2), -1);
    const auto at = [&](double s, double r) { return glm::normalize(t[0] + s * (t[1] - t[0]) + r * (t[2] - t[0])); };
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j)
        for (int up = 0; up < (i + j + 1 < n ? 2 : 1); ++up) {
          const double s0 = double(i) / n, r0 = double(j) / n, h = 1.0 / n;
          const double cellArea = up ? SphericalTriangleArea(at(s0 + h, r0), at(s0 + h, r0 + h), at(s0, r0 + h))
                                     : SphericalTriangleArea(at(s0, r0), at(s0 + h, r0), at(s0, r0 + h));
          index[static_cast<size_t>((i * n + j) * 2 + up)] = static_cast<int>(cells.size());
          cells.push_back({double(i), double(j), double(up), cellArea});
        }
    ASSERT_EQ(cells.size(), size_t(n * n));
    std::vector<double> count(cells.size(), 0.0);
    for (int k = 0; k < draws; ++k) {
      const glm::dvec3 w = SampleSphericalTriangle(a, b, c, area, u(), u());
      // Locate by barycentric coordinates of the ray's point on the plane.
      const glm::dvec3 e1 = t[1] - t[0], e2 = t[2] - t[0], nrm = glm::cross(e1, e2);
      const glm::dvec3 q = (glm::dot(nrm, t[0]) / glm::dot(nrm, w)) * w - t[0];
      const double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
      const double q1 = glm::dot(q, e1), q2 = glm::dot(q, e2), det = d11 * d22 - d12 * d12;
      const double s = (d22 * q1 - d12 * q2) / det, r = (d11 * q2 - d12 * q1) / det;
      ASSERT_TRUE(s > -1e-6 && r > -1e-6 && s + r < 1 + 1e-6) << "outside: " << s << " " << r;
      const int i = std::clamp(static_cast<int>(s * n), 0, n - 1);
      const int j = std::clamp(static_cast<int>(r * n), 0, n - 1 - i);
      const int up = (i + j + 1 < n && s * n - i + r * n - j > 1.0) ? 1 : 0;
      count[static_cast<size_t>(index[static_cast<size_t>((i * n + j) * 2 + up)])] += 1.0;
    }
    double chi2 = 0.0, sum = 0.0;
    for (const auto& cell : cells) sum += cell[3];
    EXPECT_NEAR(sum / area, 1.0, 1e-9);  // the cells' formula agrees with the whole's
    for (size_t k = 0; k < cells.size(); ++k) {
      const double e = draws * cells[k][3] / sum;
      chi2 += (count[k] - e) * (count[k] - e) / e;
    }
    EXPECT_LT(chi2, 44.3) << "triangle of solid angle " << area;
  }
}

// The planar polygon the sampler draws from (ClipPolygonToReceiver), further clipped to m · ω ≥ 0 (m through the
// receiver): what the test integrates exactly, written here by Sutherland–Hodgman again.
std::vector<glm::dvec3> ClipBy(const std::vector<glm::dvec3>& poly, const glm::dvec3& m) {
  std::vector<glm::dvec3> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3 &a = poly[i], &b = poly[(i + 1) % poly.size()];
    const double da = glm::dot(m, a), db = glm::dot(m, b);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}
double SolidAngleOf(const std::vector<glm::dvec3>& poly) {  // fanned from the last vertex, not the sampler's first
  double sum = 0.0;
  for (size_t i = 0; i + 2 < poly.size(); ++i)
    sum += SphericalTriangleArea(glm::normalize(poly.back()), glm::normalize(poly[i]), glm::normalize(poly[i + 1]));
  return sum;
}

// The sampler's density is what it says, over the clip grid (tilts, horizons cut by either normal, grazing
// emission and reception; 1 mm to 100 m; up to 10 km from the origin): for g = the cosine, g = 1, and g = the
// cosine on either side of three planes through the receiver, the mean of g / pdf over the draws is the exact
// integral of g (Lambert's formula, or Van Oosterom and Strackee's fanned from another vertex), by a z-test at
// |z| < 5 (false-failure rate 5.7e-7 per check, 3e-4 over the grid's 512 checks). Every direction is in front of both
// normals and meets the light's plane at the distance it reports; the polygon's projected solid angle is
// ClippedPolygonProjectedSolidAngle's to the bit.
TEST(ProjectedSolidAngleSampler, DensityIsExactOverTheClipGrid) {
  const int draws = 4000;
  Uniforms u(11);
  int checks = 0;
  for (const ClipCase& cc : ClipCases())
    for (float scale : {1e-3f, 1.0f, 100.0f})
      for (const Vec3& offset : {Vec3(0), Vec3(1000.0f, -1000.0f, 1000.0f), Vec3(-1e4f, 0, 1e4f)}) {
        if (scale < 1.0f && offset.x < -1000.0f) continue;
        const PlacedCase pc = Place(cc, scale, offset);
        const Vec3 edges[2] = {pc.e1, pc.e2};
        const ProjectedSolidAngleSampler s = MakeProjectedSolidAngleSampler(pc.x, pc.n, pc.ng, pc.p0, edges, 2, pc.ln);
        const std::string what = std::string(cc.name) + " at scale " + std::to_string(scale) + ", offset " +
                                 std::to_string(offset.x);
        if (std::string(cc.name) == "behind the emitter") {
          EXPECT_EQ(s.fan, 0u) << what;
          EXPECT_EQ(SampleProjectedSolidAngle(s, 0.5, 0.5, 0.5).pdf, 0.0);
          continue;
        }
        // The whole polygon's projected solid angle is the difference estimator's U to the bit, and its fan's sum.
        EXPECT_EQ(s.projectedSolidAngle, ClippedPolygonProjectedSolidAngle(pc.x, pc.n, pc.ng, pc.p0, edges, 2, pc.ln));
        EXPECT_NEAR(s.cdf[s.fan - 1] / s.projectedSolidAngle, 1.0, 1e-12) << what;
        glm::dvec3 clipped[kMaxClippedVertices];
        const size_t m = ClipPolygonToReceiver(pc.x, pc.n, pc.ng, pc.p0, edges, 2, pc.ln, clipped);
        const std::vector<glm::dvec3> poly(clipped, clipped + m);
        const glm::dvec3 n(pc.n), ng(pc.ng), ln(pc.ln);
        glm::dvec3 centre(0.0);
        for (const glm::dvec3& v : poly) centre += glm::normalize(v);
        const glm::dvec3 planes[3] = {glm::cross(centre, glm::dvec3(1, 0, 0)), glm::cross(centre, glm::dvec3(0, 1, 0)),
                                      glm::cross(centre, glm::dvec3(0, 0, 1))};
        // Integrands and their exact integrals.
        std::vector<double> exact = {LambertPolygonSum(poly.data(), poly.size(), n), SolidAngleOf(poly)};
        for (const glm::dvec3& p : planes)
          for (double side : {1.0, -1.0}) {
            const std::vector<glm::dvec3> half = ClipBy(poly, side * p);
            exact.push_back(half.size() >= 3 ? LambertPolygonSum(half.data(), half.size(), n) : 0.0);
          }
        std::vector<double> sum(exact.size(), 0.0), sumSq(exact.size(), 0.0);
        for (int k = 0; k < draws; ++k) {
          const PolygonDirection d = SampleProjectedSolidAngle(s, u(), u(), u());
          ASSERT_GT(d.pdf, 0.0) << what;
          ASSERT_GT(glm::dot(n, d.w), -1e-9) << what;
          ASSERT_GT(glm::dot(ng, d.w), -1e-9) << what;
          const glm::dvec3 hit = d.distance * d.w;
          ASSERT_NEAR(glm::dot(ln, hit - poly[0]), 0.0, 1e-9 * d.distance) << what;
          const double cosX = std::max(0.0, glm::dot(n, d.w));
          std::vector<double> g = {cosX, 1.0};
          for (const glm::dvec3& p : planes)
            for (double side : {1.0, -1.0}) g.push_back(side * glm::dot(p, d.w) >= 0.0 ? cosX : 0.0);
          for (size_t j = 0; j < g.size(); ++j) {
            const double x = g[j] / d.pdf;
            sum[j] += x;
            sumSq[j] += x * x;
          }
        }
        for (size_t j = 0; j < exact.size(); ++j) {
          const double mean = sum[j] / draws;
          const double var = std::max(0.0, sumSq[j] / draws - mean * mean) / (draws - 1);
          const double tol = 5.0 * std::sqrt(var) + 1e-9 * exact[j];
          EXPECT_NEAR(mean, exact[j], tol) << what << ", integrand " << j;
          ++checks;
        }
      }
  EXPECT_EQ(checks, 8 * 8 * 8);  // 8 cases with light × 8 placements × 8 integrands
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// What the sampler is for: at an unoccluded diffuse receiver, f / p = cos θ / pdf is nearly one number, where area
// sampling's spreads with the distance and both cosines. Over the clip grid's cases at 1 m, the relative standard
// deviation of cos θ / pdf per draw (printed) is at most 0.2 and at most a quarter of uniform area sampling's.
TEST(ProjectedSolidAngleSampler, UnoccludedCosineOverDensityIsNearlyConstant) {
  const int draws = 20000;
  Uniforms u(13);
  for (const ClipCase& cc : ClipCases()) {
    if (std::string(cc.name) == "behind the emitter") continue;
    const PlacedCase pc = Place(cc, 1.0f, Vec3(0));
    const Vec3 edges[2] = {pc.e1, pc.e2};
    const ProjectedSolidAngleSampler s = MakeProjectedSolidAngleSampler(pc.x, pc.n, pc.ng, pc.p0, edges, 2, pc.ln);
    const glm::dvec3 n(pc.n), ng(pc.ng), ln(pc.ln), x(pc.x), p0(pc.p0), e1(pc.e1), e2(pc.e2);
    const double area = 0.5 * glm::length(glm::cross(e1, e2));
    double sum = 0, sumSq = 0, aSum = 0, aSumSq = 0;
    for (int k = 0; k < draws; ++k) {
      const PolygonDirection d = SampleProjectedSolidAngle(s, u(), u(), u());
      const double v = std::max(0.0, glm::dot(n, d.w)) / d.pdf;
      sum += v, sumSq += v * v;
      // A uniform point on the whole triangle, its integrand in area measure.
      const double su = std::sqrt(u()), r = u();
      const glm::dvec3 w = p0 + (1 - su) * e1 + (r * su) * e2 - x;
      const double d2 = glm::dot(w, w), dist = std::sqrt(d2);
      const double cosX = glm::dot(n, w) / dist, cosY = -glm::dot(ln, w) / dist;
      const double a = cosX > 0 && glm::dot(ng, w) > 0 && cosY > 0 ? cosX * cosY / d2 * area : 0.0;
      aSum += a, aSumSq += a * a;
    }
    const double mean = sum / draws, sd = std::sqrt(std::max(0.0, sumSq / draws - mean * mean));
    const double aMean = aSum / draws, aSd = std::sqrt(std::max(0.0, aSumSq / draws - aMean * aMean));
    std::printf("%-24s projected solid angle %.4f, area %.4f\n", cc.name, sd / mean, aSd / aMean);
    EXPECT_LT(sd / mean, 0.2) << cc.name;
    EXPECT_LT(sd / mean, 0.25 * aSd / aMean) << cc.name;
  }
}

}  // namespace
}  // namespace restir
