// A frame's estimator passes (DESIGN §2): initial sampling, then shading. One parameter struct per pass; a
// preset is a named bundle of them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/bsdf.h"
#include "core/light_sampler.h"
#include "core/reservoir.h"
#include "core/shading.h"
#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/image.h"
#include "sim/sequence.h"

namespace restir {

struct InitialSamplingParams {
  int candidates = 32;                               // M light candidates per pixel (streaming RIS)
  LightSelection lightSelection = LightSelection::kPower;  // source distribution over lights
  bool initialVisibility = false;                    // trace the selected sample; occluded -> W = 0 (Bitterli 2020)
};

struct ShadeParams {
  bool finalVisibility = true;  // trace a shadow ray for the final sample (off: shade unshadowed)
};

struct PipelineSettings {
  InitialSamplingParams initial;  // the initial-sampling pass
  ShadeParams shade;              // the shading pass
};

// Everything a pass reads about the current frame. Owned by the runner; passes never write it.
struct FrameInputs {
  const Sequence* sequence = nullptr;
  const FrameState* state = nullptr;
  const EmbreeScene* scene = nullptr;
  const GBuffer* gbuffer = nullptr;
  const LightSampler* lights = nullptr;
  const std::vector<Bsdf>* materials = nullptr;  // one per Sequence::materials
  uint32_t seed = 0;
  uint32_t frame = 0;
};

// What one pass did, for metrics.csv.
struct PassStats {
  std::string name;     // initial, shade, ...
  double ms = 0.0;      // wall time of the pass
  uint64_t rays = 0;    // rays traced by the pass
};

struct FrameResult {
  ImageRgb image;
  std::vector<PassStats> passes;
  uint64_t guardedEvents = 0;  // non-finite values caught and reset (DESIGN §10)
};

// Per-preset estimator state across frames (reservoir buffers are ping-ponged by later passes).
class Pipeline {
 public:
  explicit Pipeline(const PipelineSettings& settings) : settings_(settings) {}
  FrameResult RenderFrame(const FrameInputs& in);
  const PipelineSettings& Settings() const { return settings_; }

 private:
  PipelineSettings settings_;
  std::vector<Reservoir> reservoirs_;
};

// Materials of a sequence as BSDFs (GGX alpha = roughness^2).
std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence);

// The receiver at a G-buffer pixel; valid only where gbuffer.IsSurface(i).
ShadingPoint ShadingPointAt(const GBuffer& gbuffer, size_t i, const Camera& camera, const std::vector<Bsdf>& bsdfs);

// Radiance a primary ray sees directly at pixel i: an emitter's front face, else zero.
Vec3 DirectEmission(const GBuffer& gbuffer, size_t i, const std::vector<LightTriangle>& lights);

// True when the segment from the receiver to a light point is blocked (shadow ray shortened so it stops short
// of the light itself).
bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       SceneFrame frame = SceneFrame::kCurrent);

}  // namespace restir
