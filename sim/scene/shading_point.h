// The receiver at a G-buffer pixel and the few things about it that both the estimator passes and the reference
// need (DESIGN §4 notation): its ShadingPoint, what the primary ray sees directly, and the visibility of a light
// point from it. The reference depends on this and core/ only, never on the pipeline.
#pragma once

#include <vector>

#include "core/bsdf.h"
#include "core/light.h"
#include "core/shading.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/sequence.h"

namespace restir {

// A material as a BSDF, with `baseColor` in place of its albedo (the texel times the albedo on a textured
// receiver). GGX alpha = roughness². kLayered, the metallic-roughness model (docs/sequence-format.md "Material
// mapping"), becomes core/'s convex layered BSDF: the specular lobe's share s = metallic + specular (1 - metallic),
// diffuse albedo (1 - s) baseColor, lobe F0 = (metallic baseColor + specular (1 - metallic)) / s, so the
// reflectance never exceeds 1 and metallic = 1 is a pure GGX conductor of F0 = baseColor.
Bsdf MaterialBsdf(const Material& material, const Vec3& baseColor);

// Materials of a sequence as BSDFs (each with its own albedo).
std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence);

// The BSDF table of a frame, which GBuffer::bsdfId indexes: the materials' entries (`materialBsdfs`), then one
// entry per textured receiver of `current` and of `previous` (null: none) at the index its bsdfId names. Throws
// std::logic_error if the two G-buffers' entries collide (they were traced with the same TextureTableOffset).
BsdfSoa FrameBsdfTable(const std::vector<Bsdf>& materialBsdfs, const std::vector<Material>& materials,
                       const GBuffer& current, const GBuffer* previous);

// Unit direction from a receiver towards the camera (the ω_o of every target and BSDF evaluation).
inline Vec3 ViewDirection(const Vec3& eye, const Vec3& position) { return glm::normalize(eye - position); }

// The receiver at a G-buffer pixel, seen from `eye`; valid only where gbuffer.IsSurface(i). Its BSDF is
// table.At(bsdfId); the overload on a plain list serves untextured scenes, where bsdfId = materialId.
ShadingPoint ShadingPointAt(const GBuffer& gbuffer, size_t i, const Vec3& eye, const BsdfSoa& table);
ShadingPoint ShadingPointAt(const GBuffer& gbuffer, size_t i, const Vec3& eye, const std::vector<Bsdf>& bsdfs);

// Radiance a primary ray sees directly at pixel i: an emitter's front face, else zero.
Vec3 DirectEmission(const GBuffer& gbuffer, size_t i, const std::vector<LightTriangle>& lights);
// The same, plus the sky where the primary ray escaped (no hit at pixel i): its radiance towards the ray through
// the pixel's centre, as sim/scene/gbuffer.cpp traced it.
Vec3 DirectEmission(const GBuffer& gbuffer, size_t i, const std::vector<LightTriangle>& lights, const Sky& sky,
                    const Camera& camera);

// True when the segment from the receiver to a light point (on an emitter of normal lightNormal and error scale
// lightErrorScale) is blocked: core/shadow_ray.h ShadowRaySetup, both ends spawned off their surfaces.
bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame = SceneFrame::kCurrent);

}  // namespace restir
