// The plain types of ray queries (sim/scene/embree_scene.h answers them; sim/scene/embree_probe.h observes them):
// which frame's scene, a closest hit, an emitter hit, shadow rays. No Embree, no scene.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/math.h"

namespace restir {

// Which of the two kept top-level scenes a query traces: this frame's or the previous frame's.
enum class SceneFrame { kCurrent, kPrevious };

// Closest hit of a ray. Normals face the ray origin (every surface is two-sided except emitters, which emit
// from their front only). Embree decides which triangle the ray hits; where on it, and its normal, are then
// computed here in double precision from that triangle's world-space vertices, and rounded once. So a hit's
// attributes do not depend on Embree's arithmetic, which differs between ISAs (FMA) and CPUs (its rcp-based
// division), and the position is as close to the surface as a float can be.
struct SurfaceHit {
  bool hit = false;
  float t = 0.0f;
  Vec3 position;
  float errorScale = 0.0f;  // for spawning rays off `position` (core/shadow_ray.h): see sim/scene/embree_scene.cpp
  Vec3 geometricNormal;    // unit, facing the ray origin
  Vec3 shadingNormal;      // unit, interpolated vertex normal when the mesh has normals, facing the ray origin
  int32_t objectId = -1;   // index into Sequence::objects; LightObjectId() for an emitter; -1 on a miss
  int32_t materialId = -1; // index into Sequence::materials; -1 for a miss or an emitter that does not reflect
  int32_t lightId = -1;    // index into the light-triangle list for an emitter hit, else -1
  bool frontFace = true;   // for emitters: the ray hit the emitting side
  Vec2 texcoord{0.0f};     // interpolated texture coordinates where the object's material is textured, else 0
};

// The first thing a ray meets, where only an emitter matters (the reference's BSDF samples).
struct EmitterHit {
  int32_t lightId = -1;    // index into the light-triangle list when the ray first meets an emitter, else -1
  float t = 0.0f;          // distance to it along the unit direction, from the triangle in double
  bool frontFace = false;  // the ray met its emitting side
};

// One shadow ray of a batch: from org along dir (unit) up to tmax.
struct ShadowRay {
  Vec3 org;
  Vec3 dir;
  float tmax = 0.0f;
};

// A batch of shadow rays as structure of arrays (the reference's light-draw kernel writes them so,
// core/light_draw_kernel.h): ray i from (org[0][i], org[1][i], org[2][i]) along dir (unit) up to tmax[i].
struct ShadowRaysSoa {
  const float* org[3] = {};
  const float* dir[3] = {};
  const float* tmax = nullptr;
  size_t count = 0;
};

}  // namespace restir
