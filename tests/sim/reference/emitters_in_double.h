// A frame's emitters as the independent checks read them (tests/sim/reference/brute_force_reference_test.cpp,
// bench/reference_oracle_bench.cpp): straight from Sequence::lights, in double, none of core/'s light code, so that
// what they compute does not share the reference's light triangles or their rounding.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/scene/sequence.h"

namespace restir::test {

// One emitter triangle in double, lit side along `normal` (cross(e1, e2), the vertices counter-clockwise seen
// from the lit side).
struct EmitterInDouble {
  glm::dvec3 p0, e1, e2, normal;  // normal: unit
  double area = 0.0;
  glm::dvec3 radiance{0.0};
  double scale = 0.0;  // largest vertex coordinate magnitude, for the spawn offset at the light's end
};

// Every switched-on emitter triangle of the frame with an area and a radiance.
inline std::vector<EmitterInDouble> CollectEmitters(const Sequence& seq, const FrameState& state) {
  std::vector<EmitterInDouble> out;
  for (size_t l = 0; l < seq.lights.size(); ++l) {
    if (l < state.lightOn.size() && !state.lightOn[l]) continue;
    const Light& light = seq.lights[l];
    for (size_t v = 0; v + 2 < light.vertices.size(); v += 3) {
      EmitterInDouble e;
      const glm::dvec3 a(light.vertices[v]), b(light.vertices[v + 1]), c(light.vertices[v + 2]);
      e.p0 = a;
      e.e1 = b - a;
      e.e2 = c - a;
      const glm::dvec3 n = glm::cross(e.e1, e.e2);
      e.area = 0.5 * glm::length(n);
      if (!(e.area > 0.0)) continue;
      e.normal = n / (2.0 * e.area);
      e.radiance = glm::dvec3(light.triangleRadiance.empty() ? light.radiance : light.triangleRadiance[v / 3]);
      if (e.radiance == glm::dvec3(0.0)) continue;
      for (const glm::dvec3& p : {a, b, c})
        e.scale = std::max({e.scale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
      out.push_back(e);
    }
  }
  return out;
}

}  // namespace restir::test
