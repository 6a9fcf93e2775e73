// Closed-form irradiance from a uniformly emitting polygon (Lambert 1760; the form used in Arvo 1995,
// "Applications of Irradiance Tensors", Eq. 2): E(x) = L/2 · Σ_i Θ_i (n · Γ_i), Θ_i the angle subtended by
// edge i, Γ_i the unit normal of the plane through x and that edge. Validates the reference renderer and RIS.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/math.h"

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

}  // namespace restir
