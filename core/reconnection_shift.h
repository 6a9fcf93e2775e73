// The reconnection shift of path reuse (ReSTIR GI: Ouyang et al. 2021 §4; shifts in general: Lin et al. 2022,
// GRIS, §7; DESIGN §4 "Path reuse"): a sample vertex x₂, found by a path from primary vertex x₁, is reused at
// another primary vertex y₁ by reconnecting y₁ to x₂, everything after x₂ kept. Pure functions, in the
// solid-angle measure at the primary vertex (ReSTIR GI's form; in area measure at x₂ the shift is the
// identity, Jacobian 1).
#pragma once

#include <cmath>

#include "core/bsdf.h"
#include "core/math.h"

namespace restir {

// The direction the shifted path leaves y₁ in: towards x₂ (the shift T maps x₁'s direction to x₂ onto this
// one; its inverse is the same function from x₁).
inline Vec3 ReconnectionDirection(const Vec3& y1, const Vec3& x2) {
  return glm::normalize(x2 - y1);
}

// |∂ω_y / ∂ω_x| of the shift from x₁ to y₁ through x₂ (normal n₂), DESIGN §4 "Path reuse":
// (|cos φ_y| / |cos φ_x|) · (‖x₁ − x₂‖² / ‖y₁ − x₂‖²), φ the angle at x₂ between n₂ and the direction to the
// primary vertex. The solid angle a patch dA of x₂ subtends is |cos φ| dA / d², so the ratio of the two is
// the Jacobian. 0 where either primary vertex lies in x₂'s tangent plane (the patch subtends no solid angle
// from it) or coincides with x₂.
inline float ReconnectionJacobian(const Vec3& x1, const Vec3& y1, const Vec3& x2, const Vec3& n2) {
  const Vec3 dx = x1 - x2, dy = y1 - x2;
  const float lx2 = glm::dot(dx, dx), ly2 = glm::dot(dy, dy);
  const float cosX = std::fabs(glm::dot(n2, dx)), cosY = std::fabs(glm::dot(n2, dy));  // times ‖dx‖, ‖dy‖
  if (!(cosX > 0.0f) || !(ly2 > 0.0f)) return 0.0f;
  // (cosY / ‖dy‖) / (cosX / ‖dx‖) · lx2 / ly2 = cosY · ‖dx‖³ / (cosX · ‖dy‖³)
  const float lx = std::sqrt(lx2), ly = std::sqrt(ly2);
  return (cosY * lx2 * lx) / (cosX * ly2 * ly);
}

// Whether a path may be reconnected at x₂ with BSDF `bsdf`: where x₂ reflects by a Lambertian lobe alone, the
// radiance it sends towards a primary vertex is the same, L_o(x₂), for every primary vertex in front of its shading
// hemisphere and 0 behind it (the BSDF is 0 there), and the rest of the path (its directions drawn at x₂ by the
// cosine, independent of where the path came from) keeps its density. So a shifted sample's value is f_r(y₁)
// G(y₁, x₂) V L_o(x₂) [n_s · (y₁ − x₂) > 0]: a secondary vertex is reused as a point on a light with radiance L_o is
// (DESIGN §4 "Path reuse", area measure), with its shading hemisphere as the side it sends light to
// (sim/estimator/passes/frame_view.h LightPointAt). A glossy x₂ (any GGX lobe) sends a radiance that depends on the
// direction and draws its next direction from it, so it is not reconnected: its path is used at its own pixel only
// (the hybrid shift is not built; docs/architecture.md). The rule depends on x₂ alone, so it splits the path space
// without bias.
inline bool Reconnectable(const Bsdf& bsdf) {
  return bsdf.type == BsdfType::kDiffuse || (bsdf.type == BsdfType::kLayered && !(bsdf.specularWeight > 0.0f));
}

// The side a reconnectable vertex (shading normal n_s) sends its light to: a receiver at y₁ gets it only where
// n_s · (y₁ − x₂) > 0. Without it, a vertex on a mesh with interpolated normals lent light to pixels its own
// BSDF sends none to (measured +28% / -8.5% on a floor beside a wall with normals tilted 60°).
inline bool InFrontOfVertex(const Vec3& shadingNormal, const Vec3& vertex, const Vec3& receiver) {
  return glm::dot(shadingNormal, receiver - vertex) > 0.0f;
}

// A path's first vertex after the primary hit, as a sample ReSTIR GI resamples (Ouyang et al. 2021 §3): x₂, the
// radiance it sends back towards x₁ and the density with which x₁'s BSDF found it, in area measure at x₂.
struct SecondaryVertex {
  Vec3 position{0.0f};   // x₂
  Vec3 normal{0.0f};     // x₂'s geometric normal on the side x₁ sees (the side the ray arrived on)
  Vec3 shadingNormal{0.0f};  // x₂'s shading normal on that side: the receivers it sends L_o to (InFrontOfVertex)
  Vec3 radiance{0.0f};   // L_o(x₂): the path's estimate of what leaves x₂ by reflection towards its front
  float pdfArea = 0.0f;  // p_A(x₂) = p_ω(ω) |n₂ · ω| / ‖x₂ − x₁‖², ω x₁'s sampled direction; 0: no vertex
  float errorScale = 0;  // x₂'s error scale, for the far end of a ray to it (core/shadow_ray.h)
};

}  // namespace restir
