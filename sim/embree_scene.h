// The Embree 3 scene: one instance per animated object over prototypes built once, static geometry merged,
// emitters as one static mesh. Two top-level scenes are kept so that the previous frame stays queryable
// (ray-traced bias correction traces visibility in the previous frame's scene).
#pragma once

#include <cstdint>
#include <optional>
#include <memory>
#include <vector>

#include "core/light.h"
#include "core/math.h"
#include "core/shadow_ray.h"  // OffsetRayOrigin, for the callers that trace from a surface
#include "sim/sequence.h"

namespace restir {

enum class SceneFrame { kCurrent, kPrevious };

// Embree's kernel family. Scenes are built for the one chosen when they are created. The default is SSE4.2,
// which every x86-64 CPU this runs on has; AVX2 and AVX-512 are faster on CPUs that have them.
enum class EmbreeIsa : uint8_t { kSse42, kAvx2, kAvx512 };
// Chooses the ISA of scenes created from now on; false (nothing changes) when this CPU or this Embree lacks it.
bool SetEmbreeIsa(EmbreeIsa isa);
EmbreeIsa ActiveEmbreeIsa();
const char* EmbreeIsaName(EmbreeIsa isa);  // "sse4.2", "avx2", "avx512": Embree's own names
std::optional<EmbreeIsa> ParseEmbreeIsa(const std::string& name);  // the inverse of EmbreeIsaName
// The widest ISA both this CPU and this Embree build support.
EmbreeIsa BestEmbreeIsa();

// Closest hit of a ray. Normals face the ray origin (every surface is two-sided except emitters, which emit
// from their front only). Embree decides which triangle the ray hits; where on it, and its normal, are then
// computed here in double precision from that triangle's world-space vertices, and rounded once. So a hit's
// attributes do not depend on Embree's arithmetic, which differs between ISAs (FMA) and CPUs (its rcp-based
// division), and the position is as close to the surface as a float can be.
struct SurfaceHit {
  bool hit = false;
  float t = 0.0f;
  Vec3 position;
  float errorScale = 0.0f;  // for spawning rays off `position` (core/shadow_ray.h): see sim/embree_scene.cpp
  Vec3 geometricNormal;    // unit, facing the ray origin
  Vec3 shadingNormal;      // unit, interpolated vertex normal when the mesh has normals, facing the ray origin
  int32_t objectId = -1;   // index into Sequence::objects; LightObjectId() for an emitter; -1 on a miss
  int32_t materialId = -1; // index into Sequence::materials; -1 for an emitter or a miss
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

class EmbreeScene {
 public:
  explicit EmbreeScene(const Sequence& sequence);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Makes `state` the current frame; what was current becomes the previous frame. Only instance transforms
  // change; nothing is rebuilt except the top-level BVH over instances.
  void Update(const FrameState& state);

  SurfaceHit Intersect(const Vec3& org, const Vec3& dir, float tmax,
                       SceneFrame frame = SceneFrame::kCurrent) const;
  // Intersect for a query that only asks which emitter the ray reaches (the reference's BSDF rays): an
  // emitter hit or a miss as Intersect gives it; any other hit only hit = true with its objectId and
  // materialId, without the surface (position, normals, t), which costs most of Intersect's time.
  // The emitter an unbounded ray from org along dir meets first, if it meets one before anything else: Embree's
  // hit as it stands (no refinement of the hit point, which IntersectEmitter's callers need and this one's not).
  EmitterHit FirstEmitter(const Vec3& org, const Vec3& dir, SceneFrame frame = SceneFrame::kCurrent) const;
  SurfaceHit IntersectEmitter(const Vec3& org, const Vec3& dir, float tmax,
                              SceneFrame frame = SceneFrame::kCurrent) const;
  bool Occluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame = SceneFrame::kCurrent) const;
  // Traces a batch of shadow rays (Embree packets of 4, the fastest entry point on captured frames:
  // docs/performance.md "Shadow-ray entry points"); occluded[i] = 1 when ray i is blocked.
  void OccludedBatch(const ShadowRay* rays, uint8_t* occluded, size_t count,
                     SceneFrame frame = SceneFrame::kCurrent) const;
  // The same for rays given as arrays: the packets are filled by contiguous copies, not gathered field by field.
  void OccludedBatch(const ShadowRaysSoa& rays, uint8_t* occluded, SceneFrame frame = SceneFrame::kCurrent) const;

  // Light triangles of the current frame in a fixed order (radiance zero while their light is off), and the
  // index of the Sequence::lights entry each came from.
  const std::vector<LightTriangle>& LightTriangles() const { return lights_; }
  const std::vector<uint32_t>& LightGroupOf() const { return lightGroup_; }
  int32_t LightObjectId() const { return lightObjectId_; }

 private:
  // Intersect's body; `surface` false stops at a hit that is not an emitter (IntersectEmitter).
  SurfaceHit Query(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame, bool surface) const;
  struct Impl;
  friend struct EmbreeProbe;  // sim/embree_probe.h: the benchmarks' and tests' access, in restir_sim_probe only
  std::unique_ptr<Impl> impl_;
  std::vector<LightTriangle> lights_;
  std::vector<uint32_t> lightGroup_;
  int32_t lightObjectId_ = 0;
};

// Builds the light-triangle list of a frame: every triangle of every light, radiance zero when switched off.
std::vector<LightTriangle> BuildLightTriangles(const Sequence& sequence, const FrameState& state,
                                               std::vector<uint32_t>* groupOf = nullptr);

}  // namespace restir
