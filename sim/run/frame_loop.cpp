#include "sim/run/frame_loop.h"

#include <algorithm>
#include <cmath>

#include "sim/reference/reference_paths.h"
#include "sim/util/clock.h"
#include "sim/scene/shading_point.h"
#include "sim/scene/sky_frame.h"

namespace restir {

FrameLoop::FrameLoop(const Sequence& sequence, int width, int height)
    : sequence_(sequence), width_(width), height_(height), scene_(sequence), bsdfs_(MaterialBsdfs(sequence)) {}

void FrameLoop::BeginFrame(int frame) {
  state_ = Evaluate(sequence_, frame, width_, height_);
  const auto t0 = Clock::now();
  scene_.Update(state_);
  timings_.sceneUpdate = MsSince(t0);
  timings_.primary = Primary();
  timings_.reproject = Reprojection();
  disocclusionAge_ = AgeDisocclusion(current_, hasPrevious_ ? disocclusionAge_ : std::vector<uint16_t>());
  lights_ = std::make_unique<LightSampler>(scene_.LightTriangles(), LightSelection::kPower);
  inputs_ = MakeInputs();
}

double FrameLoop::Primary() {
  const auto t0 = Clock::now();
  SurfaceTextures textures;
  textures.materials = &sequence_.materials;
  textures.textures = &sequence_.textures;
  textures.tableOffset = TextureTableOffset(sequence_.materials.size(), width_, height_, state_.frame);
  TracePrimary(scene_, state_.camera, current_, sequence_.textures.empty() ? nullptr : &textures);
  return MsSince(t0);
}

double FrameLoop::Reprojection() {
  const auto t0 = Clock::now();
  // A reference either way: `hasPrevious_ ? previous_ : GBuffer()` would copy the whole previous G-buffer.
  static const GBuffer kNoPrevious;
  const GBuffer& previous = hasPrevious_ ? previous_ : kNoPrevious;
  Reproject(state_, previousState_, previous, scene_.LightObjectId(), ReprojectionParams{}, current_);
  return MsSince(t0);
}

FrameInputs FrameLoop::Inputs(uint32_t seed) const {
  FrameInputs in = inputs_;
  in.seed = seed;
  return in;
}

FrameInputs FrameLoop::MakeInputs() const {
  FrameInputs in;
  in.state = &state_;
  in.scene = &scene_;
  in.gbuffer = &current_;
  in.lights = lights_.get();
  in.materials = &bsdfs_;
  if (!sequence_.textures.empty()) in.sceneMaterials = &sequence_.materials;
  in.frame = static_cast<uint32_t>(state_.frame);
  in.sky = MakeSky(sequence_, state_);
  if (hasPrevious_) {
    in.previousSky = MakeSky(sequence_, previousState_);
    in.previousState = &previousState_;
    in.previousGbuffer = &previous_;
    in.previousLights = &previousLights_;
  }
  return in;
}

FrameResult FrameLoop::RenderPreset(Pipeline& pipeline, const FrameInputs& inputs) const {
  FrameResult result = pipeline.RenderFrame(inputs);
  const IndirectParams& indirect = pipeline.Settings().indirect;
  if (indirect.bounces <= 0) return result;
  const auto t0 = Clock::now();
  PassStats pass;
  ImageRgb image;
  double msDiagnostics = 0.0;  // RenderIndirect's measuring, not the pass's work
  if (indirect.reuse) {
    IndirectVertices paths = SecondaryVertices(sequence_, state_, scene_, current_, indirect.bounces, inputs.seed,
                                               inputs.frame, pass.rays);
    FrameResult gi = pipeline.RenderIndirect(inputs, paths.vertices);
    result.indirectDiagnostics = gi.diagnostics;
    result.indirectSpatial = gi.indirectSpatial;
    msDiagnostics = gi.msDiagnostics;
    image = std::move(paths.unshifted);
    for (size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] += gi.image.pixels[i];
    const uint64_t pathRays = pass.rays;
    pass = gi.passes.front();  // the reservoirs' passes, and the paths' rays
    pass.rays += pathRays;
  } else {
    image = IndirectImage(sequence_, state_, scene_, current_, indirect.bounces, inputs.seed, inputs.frame,
                          pass.rays);
  }
  pass.name = "indirect";
  // The pipeline's guard (DESIGN §10) ran before this pass: a non-finite path is caught here, counted as its own.
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    const Vec3& v = image.pixels[i];
    if (std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)) {
      result.image.pixels[i] += v;
    } else {
      ++pass.guarded;
    }
  }
  result.guardedEvents += pass.guarded;
  result.crossObjectReuse += pass.crossObjectReuse;
  pass.ms = std::max(0.0, MsSince(t0) - msDiagnostics);
  result.passes.push_back(pass);
  return result;
}

ReferenceImage FrameLoop::Reference(int spp) const {
  ReferenceParams params;
  params.samplesPerPixel = spp;
  return Reference(params);
}

ReferenceImage FrameLoop::Reference(const ReferenceParams& params) const {
  return RenderReference(sequence_, state_, scene_, current_, params);
}

void FrameLoop::EndFrame() {
  std::swap(current_, previous_);
  previousState_ = state_;
  previousLights_ = scene_.LightTriangles();
  hasPrevious_ = true;
}

void FrameLoop::RestoreScene() {
  if (hasPrevious_) scene_.Update(previousState_);
}

}  // namespace restir
