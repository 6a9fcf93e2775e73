// Emitters as core/ sees them: one-sided emissive triangles in world space. A quad light is two of them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/math.h"

namespace restir {

struct LightTriangle {
  Vec3 p0;         // first vertex, world space
  Vec3 e1;         // p1 - p0
  Vec3 e2;         // p2 - p0
  Vec3 normal;     // unit normal of the emitting side, normalize(cross(e1, e2))
  float area = 0;  // 0.5 * |cross(e1, e2)|
  Vec3 radiance;   // emitted radiance L_e (linear RGB), zero while the light is switched off
  // Error scale of a point sampled on it (core/shadow_ray.h): the largest vertex coordinate magnitude, which
  // bounds the rounding of p0 + b0 e1 + b1 e2 and of Embree's tests against this triangle.
  float errorScale = 0;
};

// A point on a light with what the estimators need about it (DESIGN §4 notation: y, p_y, n_y, L_e).
struct LightSample {
  uint32_t lightId = 0;  // index of the triangle in the frame's light list
  Vec3 position;         // p_y
  Vec3 normal;           // n_y
  Vec3 radiance;         // L_e(y)
  float pdfArea = 0;     // p_src(y) in area measure: P(light) / area(light)
};

// Uniform point on a triangle from two uniforms (pbrt-v4 SampleUniformTriangle, the square-root map).
inline Vec3 SampleTrianglePoint(const LightTriangle& t, float u0, float u1) {
  const float su0 = std::sqrt(u0);
  const float b0 = 1.0f - su0;
  const float b1 = u1 * su0;
  return t.p0 + b0 * t.e1 + b1 * t.e2;
}

// Emitted power of a one-sided Lambertian emitter, as luminance: pi * area * Y(L_e). Drives light selection.
inline float LightPower(const LightTriangle& t) { return kPi * t.area * Luminance(t.radiance); }

// Builds the geometric fields of a triangle from its vertices. Returns false for a degenerate triangle.
inline bool MakeLightTriangle(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& radiance,
                              LightTriangle& out) {
  out.p0 = p0;
  out.e1 = p1 - p0;
  out.e2 = p2 - p0;
  const Vec3 c = glm::cross(out.e1, out.e2);
  const float len = glm::length(c);
  if (!(len > 0.0f) || !std::isfinite(len)) return false;
  out.normal = c / len;
  out.area = 0.5f * len;
  out.radiance = radiance;
  out.errorScale = 0.0f;
  for (const Vec3& p : {p0, p1, p2})
    out.errorScale = std::max(out.errorScale, std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z))));
  return true;
}

}  // namespace restir
