#include "sim/scene/shading_point.h"

#include "core/shadow_ray.h"

#include <stdexcept>

namespace restir {

Bsdf MaterialBsdf(const Material& m, const Vec3& baseColor) {
  Bsdf b;
  b.alpha = m.roughness * m.roughness;
  switch (m.type) {
    case MaterialType::kDiffuse:
      b.type = BsdfType::kDiffuse;
      b.albedo = baseColor;
      break;
    case MaterialType::kGgx:
      b.type = BsdfType::kGgx;
      b.albedo = baseColor;
      break;
    case MaterialType::kLayered: {
      const float s = m.metallic + m.specular * (1.0f - m.metallic);
      if (!(s > 0.0f)) {  // no specular lobe at all: plain Lambert
        b.type = BsdfType::kDiffuse;
        b.albedo = baseColor;
        break;
      }
      b.type = BsdfType::kLayered;
      b.albedo = (1.0f - s) * baseColor;
      b.specular = glm::min(Vec3(1.0f), (m.metallic * baseColor + Vec3(m.specular * (1.0f - m.metallic))) / s);
      b.specularWeight = s;
      break;
    }
  }
  return b;
}

std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence) {
  std::vector<Bsdf> out;
  out.reserve(sequence.materials.size());
  for (const Material& m : sequence.materials) out.push_back(MaterialBsdf(m, m.albedo));
  return out;
}

BsdfSoa FrameBsdfTable(const std::vector<Bsdf>& materialBsdfs, const std::vector<Material>& materials,
                       const GBuffer& current, const GBuffer* previous) {
  std::vector<Bsdf> table = materialBsdfs;
  const size_t m = materialBsdfs.size();
  std::vector<uint8_t> taken;
  for (const GBuffer* g : {&current, previous}) {
    if (!g) continue;
    for (size_t i = 0; i < g->bsdfId.size(); ++i) {
      const int32_t id = g->bsdfId[i];
      if (id < 0 || size_t(id) < m) continue;
      if (size_t(id) >= table.size()) {
        table.resize(size_t(id) + 1);
        taken.resize(size_t(id) + 1, 0);
      }
      if (taken[size_t(id)]) throw std::logic_error("FrameBsdfTable: two receivers share a table entry");
      taken[size_t(id)] = 1;
      const Material& mat = materials[size_t(g->materialId[i])];
      table[size_t(id)] = MaterialBsdf(mat, mat.albedo * g->Texel(i));
    }
  }
  return MakeBsdfSoa(table);
}

ShadingPoint ShadingPointAt(const GBuffer& g, size_t i, const Vec3& eye, const BsdfSoa& table) {
  ShadingPoint sp;
  sp.position = g.Position(i);
  sp.geometricNormal = g.GeometricNormal(i);
  sp.shadingNormal = g.ShadingNormal(i);
  sp.wo = ViewDirection(eye, sp.position);
  sp.bsdf = table.At(static_cast<size_t>(g.bsdfId[i]));
  sp.errorScale = g.errorScale[i];
  return sp;
}

ShadingPoint ShadingPointAt(const GBuffer& g, size_t i, const Vec3& eye, const std::vector<Bsdf>& bsdfs) {
  ShadingPoint sp;
  sp.position = g.Position(i);
  sp.geometricNormal = g.GeometricNormal(i);
  sp.shadingNormal = g.ShadingNormal(i);
  sp.wo = ViewDirection(eye, sp.position);
  sp.bsdf = bsdfs[static_cast<size_t>(g.bsdfId[i])];
  sp.errorScale = g.errorScale[i];
  return sp;
}

Vec3 DirectEmission(const GBuffer& g, size_t i, const std::vector<LightTriangle>& lights) {
  const int32_t id = g.lightId[i];
  if (id < 0) return Vec3(0.0f);
  const LightTriangle& t = lights[static_cast<size_t>(id)];
  // The G-buffer normal faces the camera; the emitter is seen from its front when its own normal does too.
  return glm::dot(t.normal, g.GeometricNormal(i)) > 0.0f ? t.radiance : Vec3(0.0f);
}

Vec3 DirectEmission(const GBuffer& g, size_t i, const std::vector<LightTriangle>& lights, const Sky& sky,
                    const Camera& camera) {
  if (g.objectId[i] >= 0 || g.lightId[i] >= 0) return DirectEmission(g, i, lights);
  if (sky.Empty()) return Vec3(0.0f);
  const int x = static_cast<int>(i % static_cast<size_t>(g.width)), y = static_cast<int>(i / static_cast<size_t>(g.width));
  return sky.Radiance(camera.RayDirection(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f));
}

bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame) {
  const ShadowRaySegment ray =
      ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, lightPosition, lightNormal, lightErrorScale);
  return scene.Occluded(ray.org, ray.dir, ray.tmax, frame);
}

}  // namespace restir
