// Drives the frames of one sequence exactly as sim/runner.cpp does (Evaluate -> scene.Update -> TracePrimary ->
// Reproject -> Pipeline::RenderFrame with the previous frame's state, G-buffer and lights), for tests that run
// many pipelines (seeds, presets) on the same frames.
#pragma once

#include <memory>
#include <vector>

#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/pipeline.h"
#include "sim/reference.h"
#include "sim/sequence.h"

namespace restir::test {

class FrameDriver {
 public:
  FrameDriver(const Sequence& seq, int width, int height)
      : seq_(seq), width_(width), height_(height), scene_(seq), bsdfs_(MaterialBsdfs(seq)) {}

  void BeginFrame(int frame) {
    frame_ = frame;
    state_ = Evaluate(seq_, frame, width_, height_);
    scene_.Update(state_);
    TracePrimary(scene_, state_.camera, current_);
    Reproject(state_, previousState_, previous_, scene_.LightObjectId(), ReprojectionParams{}, current_);
    lights_ = std::make_unique<LightSampler>(scene_.LightTriangles(), LightSelection::kPower);
  }

  FrameResult Render(Pipeline& pipeline, uint32_t seed) const {
    FrameInputs in;
    in.sequence = &seq_;
    in.state = &state_;
    in.scene = &scene_;
    in.gbuffer = &current_;
    in.lights = lights_.get();
    in.materials = &bsdfs_;
    in.seed = seed;
    in.frame = static_cast<uint32_t>(frame_);
    if (hasPrevious_) {
      in.previousState = &previousState_;
      in.previousGbuffer = &previous_;
      in.previousLights = &previousLights_;
    }
    return pipeline.RenderFrame(in);
  }

  ReferenceImage Reference(int spp) const {
    ReferenceParams params;
    params.samplesPerPixel = spp;
    return RenderReference(seq_, state_, scene_, current_, params);
  }

  void EndFrame() {
    std::swap(current_, previous_);
    previousState_ = state_;
    previousLights_ = scene_.LightTriangles();
    hasPrevious_ = true;
  }

  const GBuffer& Gbuffer() const { return current_; }
  const FrameState& State() const { return state_; }

 private:
  const Sequence& seq_;
  int width_, height_;
  EmbreeScene scene_;
  std::vector<Bsdf> bsdfs_;
  GBuffer current_, previous_;
  FrameState state_, previousState_;
  std::vector<LightTriangle> previousLights_;
  std::unique_ptr<LightSampler> lights_;
  bool hasPrevious_ = false;
  int frame_ = 0;
};

}  // namespace restir::test
