// What the whole-frame benchmark and the tests need of an EmbreeScene beyond what the simulator uses: an observer
// of every query (to record a frame's exact rays for the ray floor, or to answer them from memory for the kernel
// floor), Embree's raw answers, and every Embree shadow-ray entry point. Only the restir_sim_probe library has
// it (sim/scene/embree_scene.cpp compiled with RESTIR_RAY_HOOKS); restir_sim, which restir-sim links, is built
// without, so the production queries carry no hook at all.
#pragma once

#include <cstdint>

#include "core/math.h"
#include "sim/scene/rays.h"

namespace restir {

class EmbreeScene;  // sim/scene/embree_scene.h

// Embree's raw answer to a closest-hit query, before EmbreeScene::Intersect turns it into a SurfaceHit.
struct RawHit {
  float t = 0.0f;                            // tfar at the hit
  float ngX = 0.0f, ngY = 0.0f, ngZ = 0.0f;  // Embree's unnormalised Ng (object space of the instanced geometry)
  float u = 0.0f, v = 0.0f;                  // barycentrics
  uint32_t geomId = 0xffffffffu;             // RTC_INVALID_GEOMETRY_ID on a miss
  uint32_t primId = 0xffffffffu;
  uint32_t instId = 0xffffffffu;             // instID[0]
};

// Which Embree entry point traces a batch of shadow rays.
enum class OcclusionApi : uint8_t {
  k1,         // rtcOccluded1, one ray at a time
  k4,         // rtcOccluded4 packets (what EmbreeScene::OccludedBatch uses)
  k8,         // rtcOccluded8 packets
  k16,        // rtcOccluded16 packets
  kStream1M,  // rtcOccluded1M stream of RTCRay
};

// Observer of Intersect, Occluded and OccludedBatch queries (a batch then goes ray by ray). Callbacks run
// concurrently from the passes' threads.
class RayHook {
 public:
  virtual ~RayHook() = default;
  // Before tracing: return true and fill the answer to skip Embree.
  virtual bool AnswerOccluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                              bool& occluded) const { return false; }
  virtual bool AnswerIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                               RawHit& hit) const { return false; }
  // After Embree traced the query (not called for answered ones).
  virtual void TracedOccluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame, bool occluded) const {}
  virtual void TracedIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                               const RawHit& hit) const {}
};

// Sets the scene's observer (nullptr removes it). Not thread-safe against queries: set it between passes.
void SetRayHook(EmbreeScene& scene, const RayHook* hook);

// Embree alone, never the hook: what Intersect and Occluded trace.
RawHit IntersectRaw(const EmbreeScene& scene, const Vec3& org, const Vec3& dir, float tmax,
                    SceneFrame frame = SceneFrame::kCurrent);
bool OccludedRaw(const EmbreeScene& scene, const Vec3& org, const Vec3& dir, float tmax,
                 SceneFrame frame = SceneFrame::kCurrent);

// OccludedBatch through a chosen Embree entry point (the same answers; for measuring which is fastest).
void OccludedBatch(const EmbreeScene& scene, OcclusionApi api, const ShadowRay* rays, uint8_t* occluded,
                   size_t count, SceneFrame frame = SceneFrame::kCurrent);

}  // namespace restir
