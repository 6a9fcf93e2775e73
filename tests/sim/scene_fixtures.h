// Small scenes built in code for sim/ tests (no JSON parser involved).
#pragma once

#include <string>

#include "sim/scene/sequence.h"

namespace restir::test {

// The presets the closed-form tests hold to their answers (the unbiased ones).
inline const std::string kUnbiasedPresets[] = {"ris", "restir-unbiased", "restir-balance", "restir-spmis"};

// A preset name as a GoogleTest parameter name, which may not contain '-'.
struct PresetTestName {
  template <typename Info>
  std::string operator()(const Info& info) const {
    std::string name = info.param;
    for (char& ch : name)
      if (ch == '-') ch = '_';
    return name;
  }
};

// Adds a quad (two triangles, corners c ± u ± v) as an object with the given material.
inline void AddQuadObject(Sequence& seq, const std::string& name, uint32_t material, const Vec3& c, const Vec3& u,
                          const Vec3& v) {
  Object o;
  o.name = name;
  o.material = material;
  o.mesh.positions = {c - u - v, c + u - v, c + u + v, c - u + v};
  o.mesh.triangles = {glm::uvec3(0, 1, 2), glm::uvec3(0, 2, 3)};
  o.keys.push_back(TransformKey{});
  seq.objects.push_back(o);
}

// Adds a quad light with corners c ± u ± v, emitting towards cross(u, v).
inline void AddQuadLight(Sequence& seq, const std::string& name, const Vec3& c, const Vec3& u, const Vec3& v,
                         const Vec3& radiance) {
  Light l;
  l.name = name;
  const Vec3 p0 = c - u - v, p1 = c + u - v, p2 = c + u + v, p3 = c - u + v;
  l.vertices = {p0, p1, p2, p0, p2, p3};
  l.radiance = radiance;
  seq.lights.push_back(l);
}

// A diffuse floor (y = 0, 4 x 4 m) under one square light at height h, camera looking down at the floor.
inline Sequence FloorUnderQuadLight(int width, int height, float lightHeight, float albedo) {
  Sequence seq;
  seq.name = "floor_under_quad_light";
  seq.width = width;
  seq.height = height;
  seq.frameCount = 1;
  seq.contentHash = "fixture-floor-under-quad-light";
  Material m;
  m.name = "floor";
  m.albedo = Vec3(albedo);
  seq.materials.push_back(m);
  AddQuadObject(seq, "floor", 0, Vec3(0), Vec3(2, 0, 0), Vec3(0, 0, -2));
  // cross(u, v) with u = +x, v = +z points down (-y): the light faces the floor.
  AddQuadLight(seq, "light", Vec3(0.3f, lightHeight, -0.2f), Vec3(0.25f, 0, 0), Vec3(0, 0, 0.25f), Vec3(5.0f));
  CameraKey k;
  k.position = Vec3(0.0f, 3.0f, 1.2f);
  k.lookAt = Vec3(0.0f, 0.0f, -0.2f);
  k.vfovDegrees = 40.0f;
  seq.cameraKeys.push_back(k);
  return seq;
}

// Camera basis for a position/look-at pair (mirrors Evaluate's convention: up is +Y).
inline Camera MakeCamera(const Vec3& position, const Vec3& lookAt, float vfov, int width, int height) {
  Camera c;
  c.position = position;
  c.forward = glm::normalize(lookAt - position);
  c.right = glm::normalize(glm::cross(c.forward, Vec3(0, 1, 0)));
  c.up = glm::cross(c.right, c.forward);
  c.vfovDegrees = vfov;
  c.width = width;
  c.height = height;
  return c;
}

inline FrameState StaticState(const Sequence& seq, int frame = 0) {
  FrameState s;
  s.frame = frame;
  const CameraKey& k = seq.cameraKeys.front();
  s.camera = MakeCamera(k.position, k.lookAt, k.vfovDegrees, seq.width, seq.height);
  s.objectToWorld.assign(seq.objects.size(), Mat4(1.0f));
  s.lightOn.assign(seq.lights.size(), 1);
  return s;
}

// Adds an axis-aligned box [lo, hi] (12 triangles; surfaces are two-sided, so winding does not matter) as an
// object with the given material and one transform key (identity). Set `animated` and add keys to move it.
inline void AddBoxObject(Sequence& seq, const std::string& name, uint32_t material, const Vec3& lo, const Vec3& hi) {
  Object o;
  o.name = name;
  o.material = material;
  for (int k = 0; k < 8; ++k)
    o.mesh.positions.push_back(Vec3((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z));
  // Faces as quads of corner indices (bit 0: x, bit 1: y, bit 2: z).
  const unsigned faces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  for (const auto& f : faces) {
    o.mesh.triangles.push_back(glm::uvec3(f[0], f[1], f[2]));
    o.mesh.triangles.push_back(glm::uvec3(f[0], f[2], f[3]));
  }
  o.keys.push_back(TransformKey{});
  seq.objects.push_back(o);
}

// Adds a material and returns its index.
inline uint32_t AddMaterial(Sequence& seq, const std::string& name, const Vec3& albedo,
                            MaterialType type = MaterialType::kDiffuse, float roughness = 0.5f) {
  Material m;
  m.name = name;
  m.type = type;
  m.albedo = albedo;
  m.roughness = roughness;
  seq.materials.push_back(m);
  return static_cast<uint32_t>(seq.materials.size() - 1);
}

}  // namespace restir::test
