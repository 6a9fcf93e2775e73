// Emitters as core/ sees them: one-sided emissive triangles in world space. A quad light is two of them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
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

// Uniform point on a triangle from two uniforms (pbrt-v4 SampleUniformTriangle, the square-root map). The point is
// rounded to float, so far from the origin it lies up to half a float spacing off the triangle's plane (30 µm at
// 1 km): the reference takes the emitter's cosine from the plane instead (core/shading.h ConnectToLightOnPlane).
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

// Light groups: what the reference's light distributions select (core/light_selection_kernel.h). A group is a
// light triangle, or a quad: two triangles of one radiance that share a diagonal (A B C and A C D, as quad and grid
// lights are cut) and form a convex quadrilateral, weighed once and then split by area, so that a point on a quad
// is drawn uniformly over the whole quad. Groups follow the triangles' order.
struct LightGroups {
  std::vector<uint32_t> first;    // per group: its first triangle; a quad's second is first + 1
  std::vector<float> split;       // per group: the share of its area that is the first triangle's, 2 for a lone one
  std::vector<uint32_t> groupOf;  // per triangle: its group
  std::vector<float> invArea;     // per triangle: 1 / its group's area (a point's area density is P(group) × this)
};

// Whether t1 continues t0 into a convex quad t0.p0, t0.p1, t0.p2, t1.p2.
inline bool FormsQuad(const LightTriangle& t0, const LightTriangle& t1) {
  if (!(t0.area > 0.0f) || !(t1.area > 0.0f) || t0.radiance != t1.radiance) return false;
  if (t0.p0 != t1.p0 || t0.p0 + t0.e2 != t1.p0 + t1.e1) return false;
  if (!(glm::dot(t0.normal, t1.normal) > 1.0f - 1e-5f)) return false;
  // Convex: every corner turns the same way about the normal.
  const Vec3 q[4] = {t0.p0, t0.p0 + t0.e1, t0.p0 + t0.e2, t1.p0 + t1.e2};
  for (int i = 0; i < 4; ++i) {
    const Vec3 turn = glm::cross(q[(i + 1) % 4] - q[i], q[(i + 2) % 4] - q[(i + 1) % 4]);
    if (!(glm::dot(turn, t0.normal) > 0.0f)) return false;
  }
  return true;
}

// Per group, the sum of its triangles' entries of a per-triangle distribution (a quad's two, in order).
inline std::vector<float> GroupShares(const std::vector<float>& trianglePmf, const LightGroups& groups) {
  std::vector<float> shares;
  shares.reserve(groups.first.size());
  for (size_t g = 0; g < groups.first.size(); ++g) {
    const uint32_t t = groups.first[g];
    shares.push_back(groups.split[g] <= 1.0f ? trianglePmf[t] + trianglePmf[t + 1] : trianglePmf[t]);
  }
  return shares;
}

inline LightGroups MakeLightGroups(const std::vector<LightTriangle>& triangles) {
  LightGroups g;
  for (size_t t = 0; t < triangles.size();) {
    bool quad = t + 1 < triangles.size() && FormsQuad(triangles[t], triangles[t + 1]);
    const float pair = quad ? triangles[t].area + triangles[t + 1].area : 0.0f;
    // A pair whose area overflows, or whose second half is too thin for the split to reach it (the share rounds
    // to 1), stays two groups: each triangle must keep a positive probability where it emits.
    if (quad && !(pair <= std::numeric_limits<float>::max() && triangles[t].area / pair < 1.0f)) quad = false;
    const uint32_t group = static_cast<uint32_t>(g.first.size());
    g.first.push_back(static_cast<uint32_t>(t));
    const float area = quad ? pair : triangles[t].area;
    g.split.push_back(quad ? triangles[t].area / area : 2.0f);
    for (size_t k = 0; k < (quad ? 2u : 1u); ++k) {
      g.groupOf.push_back(group);
      g.invArea.push_back(1.0f / area);
    }
    t += quad ? 2 : 1;
  }
  return g;
}

}  // namespace restir
