// The receiver at a G-buffer pixel and the few things about it that both the estimator passes and the reference
// need (DESIGN §4 notation): its ShadingPoint, what the primary ray sees directly, and the visibility of a light
// point from it. The reference depends on this and core/ only, never on the pipeline.
#pragma once

#include <vector>

#include "core/bsdf.h"
#include "core/light.h"
#include "core/shading.h"
#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/sequence.h"

namespace restir {

// Materials of a sequence as BSDFs (GGX alpha = roughness²).
std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence);

// Unit direction from a receiver towards the camera (the ω_o of every target and BSDF evaluation).
inline Vec3 ViewDirection(const Vec3& eye, const Vec3& position) { return glm::normalize(eye - position); }

// The receiver at a G-buffer pixel, seen from `eye`; valid only where gbuffer.IsSurface(i).
ShadingPoint ShadingPointAt(const GBuffer& gbuffer, size_t i, const Vec3& eye, const std::vector<Bsdf>& bsdfs);

// Radiance a primary ray sees directly at pixel i: an emitter's front face, else zero.
Vec3 DirectEmission(const GBuffer& gbuffer, size_t i, const std::vector<LightTriangle>& lights);

// True when the segment from the receiver to a light point (on an emitter of normal lightNormal and error scale
// lightErrorScale) is blocked: core/shadow_ray.h ShadowRaySetup, both ends spawned off their surfaces.
bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame = SceneFrame::kCurrent);

}  // namespace restir
