// Closed-form irradiance from a uniformly emitting polygon (Lambert 1760; the form used in Arvo 1995,
// "Applications of Irradiance Tensors", Eq. 2): E(x) = L/2 · Σ_i Θ_i (n · Γ_i), Θ_i the angle subtended by
// edge i, Γ_i the unit normal of the plane through x and that edge. Validates the reference renderer and RIS.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/math.h"
#include "core/portable_math.h"

namespace restir {

// Irradiance at x (normal n) from a convex polygon of k vertices of constant radiance `radiance` emitting
// towards the side x is on. The polygon must lie entirely in the hemisphere above n (no horizon clipping is
// done). Real is the arithmetic: double where the formula is the answer (tests, closed forms), float where it only
// shapes a sampling distribution (the reference's per-pixel light selection), at half the cost of double acos.
template <class Real>
Real PolygonIrradianceOf(const Vec3& x, const Vec3& n, const Vec3* vertices, size_t k, Real radiance) {
  using V = glm::vec<3, Real>;
  Real sum = 0;
  for (size_t i = 0; i < k; ++i) {
    const V a = glm::normalize(V(vertices[i]) - V(x));
    const V b = glm::normalize(V(vertices[(i + 1) % k]) - V(x));
    const Real theta = std::acos(std::clamp(glm::dot(a, b), Real(-1), Real(1)));
    const V g = glm::normalize(glm::cross(a, b));
    sum += theta * glm::dot(V(n), g);
  }
  // The orientation of the vertex loop only flips the sign.
  return Real(0.5) * radiance * std::abs(sum);
}

inline double PolygonIrradiance(const Vec3& x, const Vec3& n, const std::vector<Vec3>& vertices, double radiance) {
  return PolygonIrradianceOf<double>(x, n, vertices.data(), vertices.size(), radiance);
}

// Clips a convex polygon of k vertices to the closed half-space n·(p - x) >= 0 (Sutherland–Hodgman against one
// plane), so that PolygonIrradiance can be applied to emitters that cross the receiver's horizon. Writes at most
// k + 1 vertices to `out` and returns their count.
inline size_t ClipPolygonToHemisphere(const Vec3& x, const Vec3& n, const Vec3* polygon, size_t k, Vec3* out) {
  size_t m = 0;
  for (size_t i = 0; i < k; ++i) {
    const Vec3& a = polygon[i];
    const Vec3& b = polygon[(i + 1) % k];
    const float da = glm::dot(n, a - x), db = glm::dot(n, b - x);
    if (da >= 0.0f) out[m++] = a;
    if ((da >= 0.0f) != (db >= 0.0f)) out[m++] = a + (b - a) * (da / (da - db));
  }
  return m;
}

inline std::vector<Vec3> ClipPolygonToHemisphere(const Vec3& x, const Vec3& n, const std::vector<Vec3>& polygon) {
  std::vector<Vec3> out(polygon.size() + 1);
  out.resize(ClipPolygonToHemisphere(x, n, polygon.data(), polygon.size(), out.data()));
  return out;
}

// Lambert's formula again, in the form the reference's per-pixel light selection evaluates for a packet of
// receivers at once (core/light_selection_kernel.h): in float, the triangle clipped to the receiver's hemisphere
// edge by edge instead of as a polygon (so that every lane runs the same operations), and each edge's Θ (n · Γ)
// as (n · (a × b)) Θ / sin Θ with Θ / sin Θ a polynomial in cos Θ = a · b: no acos, no normalised cross product
// (the form real-time area lighting uses, Heitz et al. 2016, "Real-Time Polygonal-Light Shading with Linearly
// Transformed Cosines", §5; the fit here is this project's own). Only +, -, *, /, sqrt and selects, so a SIMD lane
// reproduces it bit for bit. It only shapes a sampling distribution; PolygonIrradiance in double is the answer the
// tests hold it to (2e-4 relative, plus an absolute term where the horizon clips the triangle:
// tests/core/light_selection_kernel_test.cpp).

// Θ / sin Θ between unit vectors a and b, from x = a · b and sum2 = |a + b|²: g(x) = acos(x) / sqrt(1 - x²) on
// [0, 1] is a degree-5 polynomial fitted for relative error (at most 1.7e-5 in float), and for x < 0, Θ / sin Θ =
// π / sin Θ - g(-x), sin² Θ = (1 - x)(1 + x) with 1 + x = |a + b|² / 2: near Θ = π, where an edge passes close to
// the receiver, a · b has lost the digits of 1 + x that |a + b| keeps. sin Θ is floored at 1e-6 (an edge through
// the receiver).
inline float ThetaOverSinTheta(float x, float sum2) {
  const float y = std::fabs(x);
  const float g =
      ((((-0.06696824729442596f * y + 0.27594730257987976f) * y - 0.5419473648071289f) * y + 0.7602066397666931f) * y -
       0.9980255961418152f) * y + 1.570770502090454f;
  const float sin2 = (1.0f - x) * (0.5f * sum2);
  return x >= 0.0f ? g : 3.14159265358979f / std::sqrt(sin2 > 1e-12f ? sin2 : 1e-12f) - g;
}

// One edge's term of Lambert's sum, Θ (n · Γ), for unit directions a and b from the receiver to the edge's ends
// (Γ = (a × b) / |a × b|, |a × b| = sin Θ).
inline float LambertEdgeTerm(const Vec3& a, const Vec3& b, const Vec3& n) {
  const Vec3 c(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
  const Vec3 s = a + b;
  return glm::dot(n, c) * ThetaOverSinTheta(glm::dot(a, b), glm::dot(s, s));
}

// Irradiance at a receiver (normal n) from a convex polygon of K vertices and unit radiance, clipped to the
// receiver's hemisphere, given its vertices relative to the receiver (a[i] = v_i - x): 1/2 |Σ Θ (n · Γ)| over the
// clipped edges and, where the polygon crosses the horizon, the horizon edge from the point where the boundary
// leaves the hemisphere to the point where it comes back (a convex polygon crosses a plane at most twice). A
// vertex on the horizon (n · a = 0) counts as inside, as in ClipPolygonToHemisphere. Not finite when a vertex is
// at the receiver.
template <int K>
float HorizonClippedPolygonIrradiance(const Vec3 (&a)[K], const Vec3& n) {
  float s[K];
  bool in[K];
  Vec3 unit[K];
  for (int i = 0; i < K; ++i) {
    s[i] = glm::dot(n, a[i]);
    in[i] = s[i] >= 0.0f;
    unit[i] = a[i] * (1.0f / std::sqrt(glm::dot(a[i], a[i])));
  }
  // Each edge's term (0 for an edge wholly below the horizon), then the horizon edge's; summed in one fixed order.
  float term[K];
  Vec3 exit(0.0f), entry(0.0f);
  bool crosses = false;
  for (int i = 0; i < K; ++i) {
    const int j = i == K - 1 ? 0 : i + 1;
    term[i] = 0.0f;
    if (in[i] && in[j]) {
      term[i] = LambertEdgeTerm(unit[i], unit[j], n);
    } else if (in[i] || in[j]) {
      // The edge crosses the horizon at p: its part inside runs from a[i] to p, or from p to a[j].
      const Vec3 p = a[i] + (a[j] - a[i]) * (s[i] / (s[i] - s[j]));
      const Vec3 pu = p * (1.0f / std::sqrt(glm::dot(p, p)));
      term[i] = LambertEdgeTerm(in[i] ? unit[i] : pu, in[j] ? unit[j] : pu, n);
      (in[i] ? exit : entry) = pu;
      crosses = true;
    }
  }
  float sum = term[0];
  for (int i = 1; i < K; ++i) sum += term[i];
  sum += crosses ? LambertEdgeTerm(exit, entry, n) : 0.0f;
  return 0.5f * std::fabs(sum);
}

// The part of a convex emitter polygon that a receiver's light-sampling integrand covers, as
// ClippedPolygonProjectedSolidAngle (below) defines it: the polygon p0, p0 + edges[i] (i < k, k = 2 or 3) relative
// to the receiver x, in double, clipped to the half-spaces in front of n and of ng by Sutherland–Hodgman. Writes at
// most kMaxClippedVertices vertices to `out` and returns their count: 0 where the receiver is behind the emitter or
// on its plane, or where less than a polygon is left. The projected-solid-angle sampler
// (core/polygon_light_sampling.h) draws from the same polygon that the exact integral integrates.
inline constexpr size_t kMaxClippedVertices = 6;  // four vertices, plus one per clipping plane
inline size_t ClipPolygonToReceiver(const Vec3& x, const Vec3& n, const Vec3& ng, const Vec3& p0, const Vec3* edges,
                                    size_t k, const Vec3& lightNormal, glm::dvec3 (&out)[kMaxClippedVertices]) {
  using D3 = glm::dvec3;
  const D3 rel0 = D3(p0) - D3(x);
  if (k < 2 || k > 3 || !(glm::dot(D3(lightNormal), -rel0) > 0.0)) return 0;  // behind the emitter, or on its plane
  D3 poly[kMaxClippedVertices];
  size_t m = 0;
  poly[m++] = rel0;
  for (size_t i = 0; i < k; ++i) poly[m++] = rel0 + D3(edges[i]);
  for (const D3 plane : {D3(n), D3(ng)}) {
    size_t kept = 0;
    for (size_t i = 0; i < m; ++i) {
      const D3& a = poly[i];
      const D3& b = poly[(i + 1) % m];
      const double da = glm::dot(plane, a), db = glm::dot(plane, b);
      if (da >= 0.0 && kept < kMaxClippedVertices) out[kept++] = a;
      if ((da >= 0.0) != (db >= 0.0) && kept < kMaxClippedVertices) out[kept++] = a + (b - a) * (da / (da - db));
    }
    m = kept;
    if (m < 3) return 0;
    for (size_t i = 0; i < m; ++i) poly[i] = out[i];
  }
  return m;
}

// One edge's term of Lambert's sum, Θ (n · Γ), for the edge from a to b (relative to the receiver), in double
// (atan2 from core/portable_math.h, the same bits on every CPU; Θ accurate near 0 and π alike). An edge that
// degenerates to a point or passes through the receiver adds nothing (directions of measure zero).
inline double LambertEdgeTermD(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& n) {
  const glm::dvec3 c = glm::cross(a, b);
  const double lc = glm::length(c);
  return lc > 0.0 ? PortableAtan2(lc, glm::dot(a, b)) * glm::dot(n, c) / lc : 0.0;
}

// Lambert's sum 1/2 |Σ Θ (n · Γ)| over a convex polygon of m vertices relative to the receiver, all in front of n.
inline double LambertPolygonSum(const glm::dvec3* poly, size_t m, const glm::dvec3& n) {
  double sum = 0.0;
  for (size_t i = 0; i < m; ++i) sum += LambertEdgeTermD(poly[i], poly[(i + 1) % m], n);
  return 0.5 * std::fabs(sum);
}

// What a diffuse receiver's unshadowed light from one emitter polygon integrates to, as a number to subtract
// sampled shadows from (the reference's difference estimator, sim/reference/reference_learning.h): the
// cosine-weighted solid angle ∫ max(0, n · ω) dω over the directions ω towards the polygon in which the
// light-sampling integrand (core/shading.h ConnectToLightOnPlane, EvalBsdf) is nonzero, i.e. in front of both the
// shading normal n and the geometric normal ng, with the receiver on the emitting side of the polygon's plane (taken
// through p0 as the sampling takes it); 0 otherwise. The unshadowed contribution is then L_e · albedo / π times
// this. The polygon is convex, p0 then p0 + edges[i] for i < k (k = 2: a triangle; 3: a light group's quad, whose
// shared diagonal would cancel), and Lambert's formula is applied to it clipped to both half-spaces
// (ClipPolygonToReceiver), all in double: this is the answer the estimator's mean rests on, not a sampling weight.
inline double ClippedPolygonProjectedSolidAngle(const Vec3& x, const Vec3& n, const Vec3& ng, const Vec3& p0,
                                                const Vec3* edges, size_t k, const Vec3& lightNormal) {
  glm::dvec3 poly[kMaxClippedVertices];
  const size_t m = ClipPolygonToReceiver(x, n, ng, p0, edges, k, lightNormal, poly);
  return m < 3 ? 0.0 : LambertPolygonSum(poly, m, glm::dvec3(n));
}

// The same for a triangle p0, p0 + e1, p0 + e2.
inline double ClippedTriangleProjectedSolidAngle(const Vec3& x, const Vec3& n, const Vec3& ng, const Vec3& p0,
                                                 const Vec3& e1, const Vec3& e2, const Vec3& lightNormal) {
  const Vec3 edges[2] = {e1, e2};
  return ClippedPolygonProjectedSolidAngle(x, n, ng, p0, edges, 2, lightNormal);
}

}  // namespace restir
