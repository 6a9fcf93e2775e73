// The G-buffer: what the primary ray at each pixel centre hit, as structure-of-arrays, and where that point
// was in the previous frame (DESIGN §2, §4 temporal reuse).
#pragma once

#include <cstdint>
#include <vector>

#include "core/math.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/sequence.h"

namespace restir {

struct GBuffer {
  int width = 0;
  int height = 0;
  std::vector<float> posX, posY, posZ;     // world position of the hit
  std::vector<float> ngX, ngY, ngZ;        // geometric normal, facing the camera
  std::vector<float> nsX, nsY, nsZ;        // shading normal, facing the camera
  std::vector<float> errorScale;           // the hit's error scale, for spawning rays off it (core/shadow_ray.h)
  std::vector<int32_t> objectId;           // -1: no hit
  std::vector<int32_t> materialId;         // -1: no hit, or an emitter that does not reflect
  // The receiver's entry in the frame's BSDF table (FrameBsdfTable, sim/scene/shading_point.h): materialId, or for a
  // pixel on a textured material its own entry, textureTableOffset + pixel index. -1 where materialId is.
  std::vector<int32_t> bsdfId;
  // Base-colour texture at the hit (linear; 1 where untextured). Empty unless the scene has textures.
  std::vector<float> texelR, texelG, texelB;
  std::vector<int32_t> lightId;            // emitter hit: light triangle; else -1
  std::vector<float> depth;                // view depth (distance along the camera's forward axis); 0 on a miss
  std::vector<float> prevX, prevY;         // continuous pixel coordinates of this point in the previous frame
  std::vector<uint8_t> prevValid;          // reprojection succeeded: on screen and the same surface there
  std::vector<uint8_t> disoccluded;        // surface hit whose reprojection failed (off screen or another surface)

  // Calls f on every per-pixel array, in one fixed order (checkpoints, memory accounting, comparisons).
  template <typename G, typename F>
  static void ForEachArray(G& g, F&& f) {
    for (auto* v : {&g.posX, &g.posY, &g.posZ, &g.ngX, &g.ngY, &g.ngZ, &g.nsX, &g.nsY, &g.nsZ, &g.errorScale,
                    &g.depth, &g.prevX, &g.prevY, &g.texelR, &g.texelG, &g.texelB})
      f(*v);
    for (auto* v : {&g.objectId, &g.materialId, &g.bsdfId, &g.lightId}) f(*v);
    for (auto* v : {&g.prevValid, &g.disoccluded}) f(*v);
  }

  void Resize(int w, int h);
  size_t Size() const { return static_cast<size_t>(width) * static_cast<size_t>(height); }
  Vec3 Position(size_t i) const { return Vec3(posX[i], posY[i], posZ[i]); }
  Vec3 GeometricNormal(size_t i) const { return Vec3(ngX[i], ngY[i], ngZ[i]); }
  Vec3 ShadingNormal(size_t i) const { return Vec3(nsX[i], nsY[i], nsZ[i]); }
  Vec3 Texel(size_t i) const { return Vec3(texelR[i], texelG[i], texelB[i]); }
  bool IsSurface(size_t i) const { return objectId[i] >= 0 && materialId[i] >= 0; }
};

// Reprojection similarity tests (DESIGN §4 temporal reuse; seed 003 validation list).
struct ReprojectionParams {
  float normalThreshold = 0.9f;   // minimum dot(n, n_prev) of geometric normals
  float depthThreshold = 0.05f;   // maximum |depth_prev_buffer - depth_expected| / depth_expected
};

// What TracePrimary needs to texture the receivers (base-colour textures of imported assets).
struct SurfaceTextures {
  const std::vector<Material>* materials = nullptr;  // the sequence's
  const std::vector<Texture>* textures = nullptr;    // the sequence's
  int32_t tableOffset = 0;  // FrameBsdfTable index of this G-buffer's pixel 0 (TextureTableOffset)
};

// Where a frame's textured receivers start in its BSDF table: after the materials, alternating between two
// blocks of one entry per pixel, so that this frame's and the previous frame's G-buffers never share entries.
int32_t TextureTableOffset(size_t materialCount, int width, int height, int frame);

// Traces one primary ray per pixel centre in the current frame of `scene` (parallel over rows). With `textures`,
// receivers on a textured material read their texel and get their own BSDF table entry; without, bsdfId =
// materialId everywhere.
void TracePrimary(const EmbreeScene& scene, const Camera& camera, GBuffer& gbuffer,
                  const SurfaceTextures* textures = nullptr);

// Fills prevX/prevY/prevValid/disoccluded of `current`: each hit point is carried back through its object's
// previous transform and projected into the previous camera, then checked against `previous` at the nearest
// pixel (same object, view depth within threshold, normals within threshold). With no previous frame
// (`previous` empty) every pixel is invalid and none is disoccluded.
void Reproject(const FrameState& currentState, const FrameState& previousState, const GBuffer& previous,
               int32_t lightObjectId, const ReprojectionParams& params, GBuffer& current);

// Disocclusion age (DESIGN §6 "*_disocc: pixels disoccluded in the last 4 frames"): per pixel, frames since its
// surface was revealed, carried through reprojection so the mask follows the revealed region as the camera moves;
// kNeverDisoccluded where it never was (or longer ago than 65534 frames). `previousAge` is last frame's (empty
// on a run's first frame).
inline constexpr uint16_t kNeverDisoccluded = 0xFFFF;
inline constexpr uint16_t kDisocclusionWindow = 4;  // frames a reveal counts as recent
std::vector<uint16_t> AgeDisocclusion(const GBuffer& current, const std::vector<uint16_t>& previousAge);

// Pixels revealed within the last kDisocclusionWindow frames (1) and the rest (0).
std::vector<uint8_t> RecentDisocclusionMask(const std::vector<uint16_t>& age);

}  // namespace restir
