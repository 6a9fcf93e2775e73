// Drawing a direction towards a polygonal light in proportion to (nearly) the cosine at a diffuse receiver, so that
// the light-sampling estimate f / p of an unoccluded diffuse receiver is nearly the same number at every draw, and
// what noise is left is the shadows'. The polygon is the part of the light the receiver's integrand covers
// (core/polygon_irradiance.h ClipPolygonToReceiver), cut into a fan of triangles; a triangle is chosen by its exact
// projected solid angle (Lambert's formula), and a direction in it by Arvo's area-preserving map of the unit square
// onto the spherical triangle (Arvo 1995, "Stratified Sampling of Spherical Triangles", SIGGRAPH, Fig. 2), the square
// first warped by a bilinear density that follows the cosine at the triangle's three corners (the approximation of
// projected-solid-angle sampling pbrt-v4 uses for triangle lights, Pharr et al. 2023, §6.5.4). All in double: the
// reference's answer rests on it, and a few thousand draws a pixel cost little next to their shadow rays. Its sines,
// cosines and arctangents are core/portable_math.h's, the same bits on every CPU.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "core/math.h"
#include "core/polygon_irradiance.h"
#include "core/portable_math.h"

namespace restir {

// x in [0, 1] with density proportional to (1 − x) a + x b (a, b ≥ 0, not both 0), for u in [0, 1): the root of the
// cdf's quadratic in the form that loses no digits when a and b are far apart, u (a + b) / (a + √((1 − u) a² + u b²)).
inline double SampleLinear(double u, double a, double b) {
  if (u == 0.0 && a == 0.0) return 0.0;
  const double x = u * (a + b) / (a + std::sqrt((1.0 - u) * a * a + u * b * b));
  return std::min(x, 1.0);
}

inline double LinearPdf(double x, double a, double b) { return 2.0 * ((1.0 - x) * a + x * b) / (a + b); }

// The bilinear density on the unit square through the corner weights w[0] at (0, 0), w[1] at (1, 0), w[2] at (0, 1)
// and w[3] at (1, 1) (all ≥ 0, sum > 0), normalised to integrate to 1.
inline double BilinearPdf(double x, double y, const double (&w)[4]) {
  const double sum = w[0] + w[1] + w[2] + w[3];
  return 4.0 * ((1.0 - x) * (1.0 - y) * w[0] + x * (1.0 - y) * w[1] + (1.0 - x) * y * w[2] + x * y * w[3]) / sum;
}

// A point of the unit square with density BilinearPdf, from (u0, u1): y from its marginal (linear between the
// bottom and the top edges' sums), then x from its conditional at that y (linear between the two sides there).
inline void SampleBilinear(double u0, double u1, const double (&w)[4], double& x, double& y) {
  y = SampleLinear(u1, w[0] + w[1], w[2] + w[3]);
  x = SampleLinear(u0, (1.0 - y) * w[0] + y * w[2], (1.0 - y) * w[1] + y * w[3]);
}

// The solid angle of the spherical triangle of unit directions a, b, c (Van Oosterom and Strackee 1983:
// tan(Ω / 2) = |a · (b × c)| / (1 + a · b + b · c + c · a)), accurate for tiny triangles where the angle excess is not.
inline double SphericalTriangleArea(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  return 2.0 * PortableAtan2(std::fabs(glm::dot(a, glm::cross(b, c))),
                             1.0 + glm::dot(a, b) + glm::dot(b, c) + glm::dot(c, a));
}

// The unit vector of v's component orthogonal to unit a, or 0 where it has none.
inline glm::dvec3 OrthogonalDirection(const glm::dvec3& v, const glm::dvec3& a) {
  const glm::dvec3 o = v - glm::dot(v, a) * a;
  const double len = glm::length(o);
  return len > 0.0 ? o / len : glm::dvec3(0.0);
}

// Arvo's map (1995, Fig. 2) of (u0, u1) ∈ [0, 1]² onto the spherical triangle a, b, c of area `area`
// (SphericalTriangleArea), uniform in solid angle: u0 picks the sub-triangle a, b, ĉ of area u0 × area (ĉ on the arc
// from a to c), u1 the point on the arc from b to ĉ whose cosine from b is 1 − u1 (1 − ĉ · b), which splits that
// sub-triangle evenly in area. So (·, 0) is b, (0, 1) is a and (1, 1) is c. The angle α at a enters only through
// its cosine and sine, the angle between the great circles' planes through a, b and a, c.
inline glm::dvec3 SampleSphericalTriangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, double area,
                                          double u0, double u1) {
  const glm::dvec3 tb = OrthogonalDirection(b, a), tc = OrthogonalDirection(c, a);
  const double cosAlpha = glm::dot(tb, tc), sinAlpha = glm::length(glm::cross(tb, tc));
  const double cosC = glm::dot(a, b);  // the side opposite c
  double sinArea, cosArea;
  PortableSinCos(u0 * area, sinArea, cosArea);
  const double s = sinArea * cosAlpha - cosArea * sinAlpha;  // sin(Â − α)
  const double t = cosArea * cosAlpha + sinArea * sinAlpha;  // cos(Â − α)
  const double uu = t - cosAlpha, vv = s + sinAlpha * cosC;
  const double den = (vv * s + uu * t) * sinAlpha;
  // q = cos of the arc from a to ĉ; where the denominator vanishes (u0 = 0, or a sliver) ĉ is a.
  double q = den != 0.0 ? ((vv * t - uu * s) * cosAlpha - vv) / den : 1.0;
  q = std::clamp(q, -1.0, 1.0);
  const glm::dvec3 cHat = q * a + std::sqrt(std::max(0.0, 1.0 - q * q)) * tc;
  const double z = 1.0 - u1 * (1.0 - glm::dot(cHat, b));
  const glm::dvec3 w = z * b + std::sqrt(std::max(0.0, 1.0 - z * z)) * OrthogonalDirection(cHat, b);
  return glm::normalize(w);
}

// Below this solid angle a fan triangle is drawn uniformly by area instead: the angle excess the map inverts has
// lost most of its digits (about 1e-16 / Ω relative), and so small a light is nearly uniform in projected solid
// angle already.
inline constexpr double kMinSphericalSampleArea = 1e-6;

// A direction towards the polygon, with its density in solid angle.
struct PolygonDirection {
  glm::dvec3 w{0.0};  // unit direction from the receiver
  double pdf = 0.0;   // density in solid angle; 0: no direction (an empty polygon)
  double distance = 0.0;  // from the receiver along w to the polygon's plane
};

// The polygon of one light as a diffuse receiver sees it, ready to be sampled (MakeProjectedSolidAngleSampler).
struct ProjectedSolidAngleSampler {
  static constexpr size_t kMaxFan = kMaxClippedVertices - 2;
  glm::dvec3 vertex[kMaxClippedVertices];  // the clipped polygon relative to the receiver
  glm::dvec3 unit[kMaxClippedVertices];    // the same, normalised
  size_t fan = 0;                          // triangles 0, i + 1, i + 2 for i < fan; 0: nothing to sample
  double projectedSolidAngle = 0.0;        // the whole polygon's, as ClippedPolygonProjectedSolidAngle gives it
  double cdf[kMaxFan] = {};                // running sum of the fan triangles' projected solid angles
  double area[kMaxFan] = {};               // each fan triangle's solid angle
  double corner[kMaxFan][4] = {};          // each fan triangle's bilinear weights (SampleSphericalTriangle's corners)
  glm::dvec3 planeNormal{0.0};             // the light's normal, for the distance to its plane
};

// The sampler of the polygon p0, p0 + edges[i] (i < k) of a light of normal lightNormal, at a receiver x with
// shading normal n and geometric normal ng: the polygon ClipPolygonToReceiver leaves, fanned from its first vertex,
// each triangle weighed by its projected solid angle (Lambert's sum over its edges: the polygon's own, whose sum is
// the whole's projectedSolidAngle to the bit, and the fan's diagonals, each computed once) and its corner weights the
// cosine at its corners, floored at 1% of the largest so that every direction keeps a density.
inline ProjectedSolidAngleSampler MakeProjectedSolidAngleSampler(const Vec3& x, const Vec3& n, const Vec3& ng,
                                                                 const Vec3& p0, const Vec3* edges, size_t k,
                                                                 const Vec3& lightNormal) {
  ProjectedSolidAngleSampler s;
  const size_t m = ClipPolygonToReceiver(x, n, ng, p0, edges, k, lightNormal, s.vertex);
  if (m < 3) return s;
  const glm::dvec3 nd(n);
  double boundary[kMaxClippedVertices], diagonal[kMaxClippedVertices] = {};  // edge i → i + 1; 0 → j
  double sum = 0.0;
  for (size_t i = 0; i < m; ++i) sum += boundary[i] = LambertEdgeTermD(s.vertex[i], s.vertex[(i + 1) % m], nd);
  s.projectedSolidAngle = 0.5 * std::fabs(sum);
  for (size_t j = 2; j + 1 < m; ++j) diagonal[j] = LambertEdgeTermD(s.vertex[0], s.vertex[j], nd);
  double cosine[kMaxClippedVertices], largest = 0.0;
  for (size_t i = 0; i < m; ++i) {
    const double len = glm::length(s.vertex[i]);
    if (!(len > 0.0)) return s;  // a vertex at the receiver: the integrand is not finite there
    s.unit[i] = s.vertex[i] / len;
    cosine[i] = std::max(0.0, glm::dot(nd, s.unit[i]));
    largest = std::max(largest, cosine[i]);
  }
  const double floor = 0.01 * largest;
  double running = 0.0;
  for (size_t i = 0; i + 2 < m; ++i) {
    // Triangle 0, i + 1, i + 2: its edges 0 → i + 1, i + 1 → i + 2 and i + 2 → 0.
    const double in = i == 0 ? boundary[0] : diagonal[i + 1];
    const double out = i + 3 == m ? boundary[m - 1] : -diagonal[i + 2];
    running += 0.5 * std::fabs(in + boundary[i + 1] + out);
    s.cdf[i] = running;
    s.area[i] = SphericalTriangleArea(s.unit[0], s.unit[i + 1], s.unit[i + 2]);
    // Arvo's corners with a = vertex 0, b = vertex i + 1, c = vertex i + 2: (0, 0) and (1, 0) are b, (0, 1) a, (1, 1) c.
    const double wa = std::max(cosine[0], floor), wb = std::max(cosine[i + 1], floor),
                 wc = std::max(cosine[i + 2], floor);
    s.corner[i][0] = wb;
    s.corner[i][1] = wb;
    s.corner[i][2] = wa;
    s.corner[i][3] = wc;
  }
  if (!(running > 0.0) || !std::isfinite(running)) return s;
  s.fan = m - 2;
  s.planeNormal = glm::dvec3(lightNormal);
  return s;
}

// A direction from the sampler for (uFan, u0, u1) ∈ [0, 1)³: uFan picks the fan triangle by its share of the
// projected solid angle, (u0, u1) the direction in it. Density: share × bilinear density / solid angle, or, for a
// triangle below kMinSphericalSampleArea, share × d² / (area × |cos θ at the light|) of a uniform point on it.
inline PolygonDirection SampleProjectedSolidAngle(const ProjectedSolidAngleSampler& s, double uFan, double u0,
                                                  double u1) {
  PolygonDirection out;
  if (s.fan == 0) return out;
  const double total = s.cdf[s.fan - 1];
  const double target = uFan * total;
  size_t i = 0;
  while (i + 1 < s.fan && target >= s.cdf[i]) ++i;
  const double share = (s.cdf[i] - (i ? s.cdf[i - 1] : 0.0)) / total;
  if (!(share > 0.0)) return out;  // only where rounding put the target at the total onto an empty triangle
  const glm::dvec3 &a = s.unit[0], &b = s.unit[i + 1], &c = s.unit[i + 2];
  if (s.area[i] >= kMinSphericalSampleArea) {
    double x, y;
    SampleBilinear(u0, u1, s.corner[i], x, y);
    out.w = SampleSphericalTriangle(a, b, c, s.area[i], x, y);
    out.pdf = share * BilinearPdf(x, y, s.corner[i]) / s.area[i];
  } else {
    // Uniform by area on the planar triangle (pbrt-v4 SampleUniformTriangle's square-root map).
    const glm::dvec3 &p0 = s.vertex[0], &p1 = s.vertex[i + 1], &p2 = s.vertex[i + 2];
    const double su = std::sqrt(u0);
    const glm::dvec3 p = p0 + (1.0 - su) * (p1 - p0) + (u1 * su) * (p2 - p0);
    const double d2 = glm::dot(p, p);
    const glm::dvec3 cr = glm::cross(p1 - p0, p2 - p0);
    const double triArea = 0.5 * glm::length(cr);
    if (!(d2 > 0.0) || !(triArea > 0.0)) return out;
    out.w = p / std::sqrt(d2);
    const double cosLight = std::fabs(glm::dot(cr, out.w)) / (2.0 * triArea);
    if (!(cosLight > 0.0)) return out;
    out.pdf = share * d2 / (triArea * cosLight);
  }
  // The light's plane through the polygon's first vertex.
  const double along = glm::dot(s.planeNormal, out.w);
  out.distance = along != 0.0 ? glm::dot(s.planeNormal, s.vertex[0]) / along : 0.0;
  if (!(out.distance > 0.0) || !std::isfinite(out.pdf)) out = PolygonDirection{};
  return out;
}

}  // namespace restir
