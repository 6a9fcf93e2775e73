// The grid of receivers and emitter triangles the polygon tests share (tests/core/polygon_irradiance_test.cpp,
// tests/core/polygon_light_sampling_test.cpp): tilts, horizon clips by the shading and by the geometric normal,
// grazing emission and reception, and a receiver behind the emitter, each to be scaled and moved far from the origin.
#pragma once

#include <vector>

#include "core/math.h"

namespace restir {

struct ClipCase {
  const char* name;
  Vec3 x, n, ng;     // receiver, shading and geometric normals (unnormalised here)
  Vec3 a, b, c;      // the triangle; its emitting side is the one cross(b − a, c − a) points to
  bool clips;        // a horizon cuts it: the quadrature's kink
};

inline std::vector<ClipCase> ClipCases() {
  return {
      {"overhead", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(-1, -1, 2), Vec3(-1, 1, 2), Vec3(1, 0, 2), false},
      {"tilted emitter", Vec3(0.3f, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(-1, -1, 1.5f), Vec3(-0.5f, 1, 2.5f),
       Vec3(1, 0, 1.2f), false},
      {"tilted receiver", Vec3(0, 0, 0), Vec3(0.5f, 0.2f, 1), Vec3(0.5f, 0.2f, 1), Vec3(-1, -1, 2), Vec3(-1, 1, 2),
       Vec3(1, 0, 2), false},
      {"straddles the horizon", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(2, -1, -0.5f), Vec3(2, 0, 1.5f),
       Vec3(2, 1, -0.5f), true},
      {"shading normal clips", Vec3(0, 0, 0), Vec3(-0.6f, 0, 0.8f), Vec3(0, 0, 1), Vec3(1, -1, 0.3f),
       Vec3(0.2f, 0, 2), Vec3(1, 1, 0.3f), true},
      {"geometric normal clips", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0.7f, 0, 0.7f), Vec3(-1.5f, -1, 1),
       Vec3(-1.5f, 1, 1), Vec3(0.5f, 0, 1), true},
      {"grazing emission", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(-1, -1, 1), Vec3(-1, 1, 1),
       Vec3(-0.02f, 0, 3), false},
      {"grazing reception", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(5, -1, 0.05f), Vec3(5, 0, 0.6f),
       Vec3(5, 1, 0.05f), false},
      {"behind the emitter", Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(-1, -1, 2), Vec3(1, 0, 2),
       Vec3(-1, 1, 2), false},
  };
}

// The grid's triangle at a scale and an offset, as the renderer has it: float vertices, edges and unit normals.
struct PlacedCase {
  Vec3 x, n, ng, p0, e1, e2, ln;
};
inline PlacedCase Place(const ClipCase& cc, float scale, const Vec3& offset) {
  PlacedCase p;
  p.x = offset + cc.x * scale;
  p.p0 = offset + cc.a * scale;
  p.e1 = (offset + cc.b * scale) - p.p0;
  p.e2 = (offset + cc.c * scale) - p.p0;
  p.ln = glm::normalize(glm::cross(p.e1, p.e2));
  p.n = glm::normalize(cc.n);
  p.ng = glm::normalize(cc.ng);
  return p;
}

}  // namespace restir
