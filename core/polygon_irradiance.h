// Closed-form irradiance from a uniformly emitting polygon (Lambert 1760; the form used in Arvo 1995,
// "Applications of Irradiance Tensors", Eq. 2): E(x) = L/2 · Σ_i Θ_i (n · Γ_i), Θ_i the angle subtended by
// edge i, Γ_i the unit normal of the plane through x and that edge. Validates the reference renderer and RIS.
#pragma once

#include <algorithm>
#include <vector>

#include "core/math.h"

namespace restir {

// Irradiance at x (normal n) from a convex polygon of constant radiance `radiance` emitting towards the side
// x is on. The polygon must lie entirely in the hemisphere above n (no horizon clipping is done).
inline double PolygonIrradiance(const Vec3& x, const Vec3& n, const std::vector<Vec3>& vertices,
                                double radiance) {
  const size_t k = vertices.size();
  double sum = 0.0;
  for (size_t i = 0; i < k; ++i) {
    const glm::dvec3 a = glm::normalize(glm::dvec3(vertices[i]) - glm::dvec3(x));
    const glm::dvec3 b = glm::normalize(glm::dvec3(vertices[(i + 1) % k]) - glm::dvec3(x));
    const double theta = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    const glm::dvec3 g = glm::normalize(glm::cross(a, b));
    sum += theta * glm::dot(glm::dvec3(n), g);
  }
  // The orientation of the vertex loop only flips the sign.
  return 0.5 * radiance * std::abs(sum);
}

// Clips a convex polygon to the closed half-space n·(p - x) >= 0 (Sutherland–Hodgman against one plane), so
// that PolygonIrradiance can be applied to emitters that cross the receiver's horizon.
inline std::vector<Vec3> ClipPolygonToHemisphere(const Vec3& x, const Vec3& n, const std::vector<Vec3>& polygon) {
  std::vector<Vec3> out;
  const size_t k = polygon.size();
  for (size_t i = 0; i < k; ++i) {
    const Vec3& a = polygon[i];
    const Vec3& b = polygon[(i + 1) % k];
    const float da = glm::dot(n, a - x), db = glm::dot(n, b - x);
    if (da >= 0.0f) out.push_back(a);
    if ((da >= 0.0f) != (db >= 0.0f)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

}  // namespace restir
