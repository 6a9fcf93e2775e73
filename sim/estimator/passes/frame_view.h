// What every pass reads and reports (DESIGN §2): the read-only view of the current and previous frame, the
// reservoir storage the passes hand each other, and a pass's statistics. sim/estimator/pipeline.cpp builds the view
// once per frame; a test builds one by hand to call a pass alone.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/bsdf.h"
#include "core/gris.h"
#include "core/light.h"
#include "core/light_sampler.h"
#include "core/reconnection_shift.h"
#include "core/reservoir.h"
#include "core/sky.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"

namespace restir {

// How the reuse passes evaluate the targets p̂_i that enter MIS weights (DESIGN §4 "Bias correction").
enum class BiasCorrection : uint8_t {
  kNone,       // uniform MIS weights whatever the family, unshadowed targets: fast, darkens
  kBasic,      // the family's weights with unshadowed targets of each input's own surface
  kRayTraced,  // targets include visibility traced from each input's surface, in that input's frame
};

// What visibility the shading pass uses (DESIGN §4 "Visibility"); the reuse passes carry it accordingly.
enum class VisibilityReuse : uint8_t {
  kNone,      // trace a final shadow ray for the selected sample
  kSelected,  // shade with the carried V of the selected sample, no final ray (Wyman & Panteleev 2021)
  kWeighted,  // shade with V_X = Σ V_i w_i / Σ w_i, no final ray (seed 000 Eq. 4, Algorithm 1)
};

// The frame a pass works on. Everything is owned elsewhere and never written by a pass.
struct FrameView {
  const GBuffer* gbuffer = nullptr;          // this frame's primary hits
  const GBuffer* previousGbuffer = nullptr;  // last frame's, or null on a run's first frame
  const EmbreeScene* scene = nullptr;        // this frame's scene; last frame's through SceneFrame::kPrevious
  const LightSampler* lights = nullptr;      // this frame's light sampler (its Lights(): the light list)
  const std::vector<LightTriangle>* previousLights = nullptr;  // last frame's light list (null with no history)
  Vec3 eye{0.0f};                            // this frame's camera position
  Vec3 previousEye{0.0f};                    // last frame's camera position
  Sky sky;                                   // this frame's light at infinity (empty: none)
  Sky previousSky;                           // last frame's (meaningful with history)
  const Camera* camera = nullptr;            // this frame's camera: the sky seen through escaped primary rays
  const BsdfSoa* materials = nullptr;        // the sequence's materials as the kernels read them
  uint32_t seed = 0;                         // RngKey::seed
  uint32_t frame = 0;                        // RngKey::frame
  // The "lights" the reuse passes and shading evaluate samples on, in place of lights->Lights(): ReSTIR GI's
  // secondary vertices as points with the radiance they send (Pipeline::RenderIndirect). Null: the frame's lights.
  const std::vector<LightTriangle>* lightList = nullptr;
  // Shading adds what the primary ray sees (an emitter, the sky); false where the image is indirect light only.
  bool primaryEmission = true;

  bool HasHistory() const { return previousGbuffer != nullptr && previousLights != nullptr; }
  const std::vector<LightTriangle>& Lights() const { return lightList ? *lightList : lights->Lights(); }
  // Something to sample: local lights or a sky.
  bool HasLight() const { return (lightList ? !lightList->empty() : !lights->Empty()) || !sky.Empty(); }
};

// A ReSTIR GI vertex in a view's light list (sim/estimator/indirect_reuse.cpp): a point, so its triangle has no
// area; every light triangle of a scene has some (degenerate ones are dropped when the scene is built).
inline bool IsVertexPoint(const LightTriangle& t) { return t.area == 0.0f; }

// A stored sample as a light point seen from a receiver at x (DESIGN §4): a point on a local light is itself; a
// direction on the sky is its far point from x (core/sky.h SkyPointFor), so every receiver sees the same direction
// (the shift is the identity on ω). The radiance is the frame's: zero for a light switched off or a sky that is
// gone.
struct LightPoint {
  Vec3 position;         // p_y (the far point for a direction)
  Vec3 normal;           // n_y (-ω for a direction)
  Vec3 radiance;         // L_e(y) in this frame (L(ω) R² for a direction, see SkyPointFor)
  float errorScale = 0;  // y's error scale for spawning the shadow ray's far end
};
// False when the sample's light is not in this frame's list (removed); `sky` may be null (no sky that frame).
inline bool LightPointAt(const Vec3& x, uint32_t lightId, const Vec3& position, const Vec3& normal,
                         const std::vector<LightTriangle>& lights, const Sky* sky, LightPoint& out) {
  if (IsSkySample(lightId)) {
    const LightSample y = SkyPointFor(x, position, sky ? sky->Radiance(position) : Vec3(0.0f));
    out.position = y.position;
    out.normal = y.normal;
    out.radiance = y.radiance;
    out.errorScale = 0.0f;
    return true;
  }
  if (lightId >= lights.size()) return false;
  const LightTriangle& t = lights[lightId];
  out.position = position;
  out.normal = normal;
  out.radiance = t.radiance;
  out.errorScale = t.errorScale;
  // A ReSTIR GI vertex (Pipeline::RenderIndirect: a point, its triangle's normal its shading normal) sends its L_o
  // only to receivers in front of its shading hemisphere (core/reconnection_shift.h InFrontOfVertex).
  if (IsVertexPoint(t) && !InFrontOfVertex(t.normal, position, x)) out.radiance = Vec3(0.0f);
  return true;
}

// What a reservoir's sample went through since it was drawn, in RTXDI's packed sizes (its reservoir's age and
// spatialDistance, DI/Reservoir.hlsli), so the record stays 48 bytes.
struct SampleHistory {
  uint8_t age = 0;            // frames since initial sampling drew the sample (issue 20's diagnostics; saturates)
  uint8_t visibilityAge = 0;  // frames since shading traced its visibility here (RTXDI's age; 0: not stored)
  int8_t distanceX = 0;       // pixels the sample moved through reuse since then (RTXDI's spatialDistance),
  int8_t distanceY = 0;       // clamped to ±127
  // The history as reuse hands it on: from a pixel (dx, dy) away, one frame later when `nextFrame` (temporal).
  SampleHistory Moved(int dx, int dy, bool nextFrame) const {
    SampleHistory h = *this;
    if (nextFrame) {
      h.age = age == 255 ? age : static_cast<uint8_t>(age + 1);
      h.visibilityAge = visibilityAge == 255 ? visibilityAge : static_cast<uint8_t>(visibilityAge + 1);
    }
    h.distanceX = static_cast<int8_t>(std::clamp(distanceX + dx, -127, 127));
    h.distanceY = static_cast<int8_t>(std::clamp(distanceY + dy, -127, 127));
    return h;
  }
};

// A reservoir as the passes store it between passes and frames (issue 6 memory budget): the sample's light id,
// point and normal, and the reservoir's scalars. The emitted radiance is looked up from the light list of
// whichever frame evaluates the sample, so it is not stored; p_src and the running weight sum matter only while
// RIS streams candidates.
struct StoredReservoir {
  uint32_t lightId = 0;     // LightSample::lightId
  Vec3 position{0.0f};      // LightSample::position
  Vec3 normal{0.0f};        // LightSample::normal
  float targetPdf = 0.0f;   // Reservoir::targetPdf
  float W = 0.0f;           // Reservoir::W
  float confidence = 0.0f;  // Reservoir::confidence
  float visibility = 1.0f;  // Reservoir::visibility
  SampleHistory history;    // ages and distance travelled (temporal reuse ages it, every reuse moves it)
  bool HasSample() const { return W > 0.0f; }
};
static_assert(sizeof(StoredReservoir) == 48);
using ReservoirBuffer = std::vector<StoredReservoir>;  // one per pixel, row-major

StoredReservoir Store(const Reservoir& r);

// Reservoir or StoredReservoir: usable as a reuse input.
template <typename R>
bool FiniteReservoir(const R& r) {
  return std::isfinite(r.W) && std::isfinite(r.confidence) && std::isfinite(r.visibility) && r.W >= 0.0f;
}

// The passes of a frame in order (the last, indirect light, added by the frame loop: sim/run/frame_loop.h
// RenderPreset); metrics.csv has a column per pass for every preset.
inline constexpr const char* kPassNames[] = {"initial", "temporal", "spatial", "shade", "indirect"};

// What one pass did, for metrics.csv.
struct PassStats {
  std::string name;     // initial, temporal, spatial, shade, indirect (sim/run/frame_loop.h RenderPreset)
  double ms = 0.0;      // wall time of the pass
  uint64_t rays = 0;    // rays traced by the pass
  // Work the pass handed to its SIMD kernels (bench/frame_bench.cpp prices it at the kernels_bench rates):
  uint64_t risPixels = 0;     // pixels through the RIS kernel (core/ris_kernel.h)
  uint64_t targets = 0;       // (receiver, light point) pairs through the target kernel (core/target_kernel.h)
  uint64_t combinations = 0;  // combinations through the GRIS kernel (core/gris_kernel.h)
  uint64_t guarded = 0;       // non-finite values caught and reset (DESIGN §10)
  uint64_t crossObjectReuse = 0;  // temporal inputs whose previous surface had another object id (must be 0)
  // Spatial only, summed over its iterations (issue 39's equal-work and failed-search counts):
  uint64_t reservoirReads = 0;  // reservoirs read: each pixel's own, its neighbours' or its cell's, and the cells'
  uint64_t failed = 0;          // surface pixels that found nothing to reuse (no cell, or no qualifying neighbour)
  uint64_t visited = 0;         // surface pixels the pass visited (its iterations times the frame's surface pixels)
  // Shading only: surface pixels whose reservoir reaches the image, f(Y) V(Y) W > 0 in some channel (seed 004's
  // "contributing path"; visibility included, unlike the reservoirs' p̂ W > 0).
  uint64_t contributing = 0;
};

}  // namespace restir
