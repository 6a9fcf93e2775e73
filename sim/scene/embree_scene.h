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
#include "sim/scene/rays.h"
#include "sim/scene/sequence.h"

namespace restir {

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
  friend struct EmbreeProbe;  // sim/scene/embree_probe.h: the benchmarks' and tests' access, in restir_sim_probe only
  std::unique_ptr<Impl> impl_;
  std::vector<LightTriangle> lights_;
  std::vector<uint32_t> lightGroup_;
  int32_t lightObjectId_ = 0;
};

// Builds the light-triangle list of a frame: every triangle of every light, radiance zero when switched off.
std::vector<LightTriangle> BuildLightTriangles(const Sequence& sequence, const FrameState& state,
                                               std::vector<uint32_t>* groupOf = nullptr);

}  // namespace restir
