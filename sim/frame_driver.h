// Drives the frames of one sequence as sim/runner.cpp does (Evaluate -> scene.Update -> TracePrimary ->
// Reproject -> Pipeline::RenderFrame with the previous frame's state, G-buffer and lights), for the tests that run
// many pipelines (seeds, presets) on the same frames and for the whole-frame benchmark, which times each stage
// and re-runs them (TracePrimary and Reproject depend only on the frame's state, so repeating them reproduces the
// same G-buffer).
#pragma once

#include <chrono>
#include <memory>
#include <vector>

#include "core/light_sampler.h"
#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/pipeline.h"
#include "sim/reference.h"
#include "sim/sequence.h"

namespace restir {

class FrameDriver {
 public:
  FrameDriver(const Sequence& seq, int width, int height)
      : seq_(seq), width_(width), height_(height), scene_(seq), bsdfs_(MaterialBsdfs(seq)) {}

  void BeginFrame(int frame) {
    frame_ = frame;
    state_ = Evaluate(seq_, frame, width_, height_);
    const auto t0 = std::chrono::steady_clock::now();
    scene_.Update(state_);
    msSceneUpdate_ = MsSince(t0);
    Primary();
    Reprojection();
    lights_ = std::make_unique<LightSampler>(scene_.LightTriangles(), LightSelection::kPower);
  }
  // The frame's primary rays and G-buffer again; ms taken.
  double Primary() {
    const auto t0 = std::chrono::steady_clock::now();
    TracePrimary(scene_, state_.camera, current_);
    return MsSince(t0);
  }
  // The frame's reprojection again; ms taken.
  double Reprojection() {
    const auto t0 = std::chrono::steady_clock::now();
    Reproject(state_, previousState_, previous_, scene_.LightObjectId(), ReprojectionParams{}, current_);
    return MsSince(t0);
  }

  FrameInputs Inputs(uint32_t seed) const {
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
    return in;
  }
  FrameResult Render(Pipeline& pipeline, uint32_t seed) const { return pipeline.RenderFrame(Inputs(seed)); }

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

  EmbreeScene& Scene() { return scene_; }
  const GBuffer& Gbuffer() const { return current_; }
  const GBuffer& PreviousGbuffer() const { return previous_; }
  const FrameState& State() const { return state_; }
  double MsSceneUpdate() const { return msSceneUpdate_; }

 private:
  static double MsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
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
  double msSceneUpdate_ = 0.0;
};

}  // namespace restir
