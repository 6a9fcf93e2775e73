#include "sim/shading_point.h"

#include "core/shadow_ray.h"

namespace restir {

std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence) {
  std::vector<Bsdf> out;
  out.reserve(sequence.materials.size());
  for (const Material& m : sequence.materials) {
    Bsdf b;
    b.type = m.type == MaterialType::kGgx ? BsdfType::kGgx : BsdfType::kDiffuse;
    b.albedo = m.albedo;
    b.alpha = m.roughness * m.roughness;
    out.push_back(b);
  }
  return out;
}

ShadingPoint ShadingPointAt(const GBuffer& g, size_t i, const Vec3& eye, const std::vector<Bsdf>& bsdfs) {
  ShadingPoint sp;
  sp.position = g.Position(i);
  sp.geometricNormal = g.GeometricNormal(i);
  sp.shadingNormal = g.ShadingNormal(i);
  sp.wo = ViewDirection(eye, sp.position);
  sp.bsdf = bsdfs[static_cast<size_t>(g.materialId[i])];
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

bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame) {
  const ShadowRaySegment ray =
      ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, lightPosition, lightNormal, lightErrorScale);
  return scene.Occluded(ray.org, ray.dir, ray.tmax, frame);
}

}  // namespace restir
