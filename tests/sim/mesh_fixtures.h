// Object-space meshes and transforms for the Embree scene and G-buffer tests (no JSON parser involved).
#pragma once

#include <glm/gtc/matrix_transform.hpp>

#include <cstdint>
#include <string>
#include <vector>
#include <utility>

#include "sim/scene/sequence.h"

namespace restir::test {

// [-1,1]^2 in the xy plane, counter-clockwise seen from +z.
inline Mesh QuadMesh() {
  Mesh m;
  m.positions = {Vec3(-1, -1, 0), Vec3(1, -1, 0), Vec3(1, 1, 0), Vec3(-1, 1, 0)};
  m.triangles = {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)};
  return m;
}

// [-0.5,0.5]^3, outward counter-clockwise faces, four vertices per face.
inline Mesh BoxMesh() {
  Mesh m;
  for (int a = 0; a < 3; ++a) {
    for (float s : {1.0f, -1.0f}) {
      Vec3 n(0.0f), ea(0.0f), eb(0.0f);
      n[a] = s;
      ea[(a + 1) % 3] = 1.0f;
      eb[(a + 2) % 3] = 1.0f;
      const Vec3 u = s > 0 ? ea : eb;
      const Vec3 v = s > 0 ? eb : ea;
      const Vec3 c = 0.5f * n;
      const uint32_t base = static_cast<uint32_t>(m.positions.size());
      m.positions.push_back(c - 0.5f * u - 0.5f * v);
      m.positions.push_back(c + 0.5f * u - 0.5f * v);
      m.positions.push_back(c + 0.5f * u + 0.5f * v);
      m.positions.push_back(c - 0.5f * u + 0.5f * v);
      m.triangles.emplace_back(base, base + 1, base + 2);
      m.triangles.emplace_back(base, base + 2, base + 3);
    }
  }
  return m;
}

// Translate, rotate (degrees; x, then y, then z) and scale, by GLM: independent of sim/scene/animation.cpp.
inline Mat4 Trs(const Vec3& t, const Vec3& rotDeg, const Vec3& s) {
  Mat4 m = glm::translate(Mat4(1.0f), t);
  m = glm::rotate(m, glm::radians(rotDeg.z), Vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(rotDeg.y), Vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(rotDeg.x), Vec3(1, 0, 0));
  return glm::scale(m, s);
}

inline Object MakeObject(const std::string& name, Mesh mesh, bool animated, uint32_t material = 0) {
  Object o;
  o.name = name;
  o.mesh = std::move(mesh);
  o.animated = animated;
  o.material = material;
  o.keys.push_back(TransformKey{});
  return o;
}

// A 2 x 2 quad light at height y, emitting downwards.
inline Light QuadLight(const std::string& name, float y, Vec3 radiance) {
  // Emits downwards (-y): counter-clockwise seen from below.
  Light l;
  l.name = name;
  l.radiance = radiance;
  const Vec3 a(-1, y, -1), b(1, y, -1), c(1, y, 1), d(-1, y, 1);
  l.vertices = {a, b, c, a, c, d};
  return l;
}

inline Sequence BaseSequence() {
  Sequence s;
  s.materials.resize(2);
  s.materials[0].name = "grey";
  s.materials[1].name = "red";
  return s;
}

inline FrameState StateFor(const Sequence& s, std::vector<Mat4> xforms, int frame = 0) {
  FrameState st;
  st.frame = frame;
  st.objectToWorld = std::move(xforms);
  st.lightOn.assign(s.lights.size(), 1);
  return st;
}

// Deterministic test randomness (xorshift), independent of the standard library's distributions.
struct TestRng {
  uint64_t s;
  float Next() {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return static_cast<float>((s >> 40) & 0xffffff) * (1.0f / 16777216.0f);
  }
  float Range(float a, float b) { return a + (b - a) * Next(); }
};

}  // namespace restir::test
