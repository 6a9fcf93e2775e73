// The one frame loop (DESIGN §2): a frame's state is evaluated, the scene updated, primary rays traced, the
// G-buffer reprojected into the previous frame and its disocclusion aged, the light sampler built; any number of
// pipelines then render the frame from Inputs(seed); EndFrame keeps it as the previous frame. `restir-sim run`,
// the whole-frame benchmark and the tests all drive frames through Play, the one loop over frames.
#pragma once

#include <memory>
#include <vector>

#include "core/light_sampler.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/estimator/pipeline.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"

namespace restir {

// Wall time of a frame's shared stages (metrics.csv ms_scene_update, ms_primary, ms_reproject).
struct FrameTimings {
  double sceneUpdate = 0.0;
  double primary = 0.0;
  double reproject = 0.0;
};

class FrameLoop {
 public:
  FrameLoop(const Sequence& sequence, int width, int height);

  // Makes `frame` the current frame; what EndFrame kept becomes the previous one.
  void BeginFrame(int frame);
  // The frame's primary rays and G-buffer again, or its reprojection again (a benchmark re-times them: they
  // depend only on the frame's state, so the G-buffer comes out the same); ms taken.
  double Primary();
  double Reprojection();
  // What a pipeline renders this frame from: the frame's inputs, made once by BeginFrame, with `seed`.
  FrameInputs Inputs(uint32_t seed) const;
  FrameResult Render(Pipeline& pipeline, uint32_t seed) const { return RenderPreset(pipeline, Inputs(seed)); }
  // A preset's frame: the pipeline's passes, then, where its settings ask for indirect light (indirect.bounces > 0),
  // the indirect pass: one path a pixel from the frame's primary hits (sim/reference/reference_paths.h
  // IndirectImage, keyed by inputs.seed and the frame) added to the image, its time and rays reported as the pass
  // "indirect". Every preset frame of a run, a benchmark or a test is rendered through it.
  FrameResult RenderPreset(Pipeline& pipeline, const FrameInputs& inputs) const;
  // The frame's reference: `spp` samples a pixel and no cache, or as `params` say (`restir-sim run`: its
  // cache and error target).
  ReferenceImage Reference(int spp) const;
  ReferenceImage Reference(const ReferenceParams& params) const;
  // Keeps the current frame as the previous one.
  void EndFrame();

  // The loop over frames (pbrt-v4's ImageTileIntegrator::Render: one loop, one extension point): for each
  // frame of [begin, end), BeginFrame, then `render(frame)` (the frame's presets, its reference, what the
  // caller measures), then EndFrame, then `kept(frame)` with the frame kept as the previous one (what a
  // checkpoint saves).
  template <typename Body, typename Kept>
  void Play(int begin, int end, Body&& render, Kept&& kept);
  template <typename Body>
  void Play(int begin, int end, Body&& render) {
    Play(begin, end, render, [](int) {});
  }

  const Sequence& GetSequence() const { return sequence_; }
  EmbreeScene& Scene() { return scene_; }
  const EmbreeScene& Scene() const { return scene_; }
  const FrameState& State() const { return state_; }
  const FrameState& PreviousState() const { return previousState_; }
  const GBuffer& Gbuffer() const { return current_; }
  const GBuffer& PreviousGbuffer() const { return previous_; }
  bool HasPrevious() const { return hasPrevious_; }
  const LightSampler& Lights() const { return *lights_; }
  const std::vector<Bsdf>& Bsdfs() const { return bsdfs_; }
  const FrameTimings& Timings() const { return timings_; }
  // Per pixel: frames since its surface was revealed (sim/scene/gbuffer.h AgeDisocclusion).
  const std::vector<uint16_t>& DisocclusionAge() const { return disocclusionAge_; }
  double MsSceneUpdate() const { return timings_.sceneUpdate; }

  // The previous frame's state, for checkpoints (Io: BinaryWriter or BinaryReader, sim/util/binary_io.h). After
  // reading one, RestoreScene() makes the scene's previous frame that state, as an uninterrupted run has it.
  template <typename Io>
  void Transfer(Io& io);
  void RestoreScene();

 private:
  const Sequence& sequence_;
  int width_, height_;
  EmbreeScene scene_;
  std::vector<Bsdf> bsdfs_;
  GBuffer current_, previous_;
  FrameState state_, previousState_;
  std::vector<LightTriangle> previousLights_;
  std::vector<uint16_t> disocclusionAge_;
  std::unique_ptr<LightSampler> lights_;
  bool hasPrevious_ = false;
  FrameTimings timings_;
  // The frame's inputs with seed 0, made by BeginFrame: Inputs(seed) copies them rather than making them
  // again (the skies included) for every preset and ensemble member. Points into this loop, which never moves
  // (EmbreeScene is neither copied nor moved).
  FrameInputs inputs_;

  FrameInputs MakeInputs() const;
};

template <typename Body, typename Kept>
void FrameLoop::Play(int begin, int end, Body&& render, Kept&& kept) {
  for (int frame = begin; frame < end; ++frame) {
    BeginFrame(frame);
    render(frame);
    EndFrame();
    kept(frame);
  }
}

template <typename Io>
void FrameLoop::Transfer(Io& io) {
  io.Pod(previous_.width);
  io.Pod(previous_.height);
  GBuffer::ForEachArray(previous_, [&](auto& v) { io.Vector(v); });
  io.Pod(previousState_.frame);
  io.Pod(previousState_.camera);
  io.Vector(previousState_.objectToWorld);
  io.Vector(previousState_.lightOn);
  io.Pod(previousState_.environmentIntensity);
  io.Pod(previousState_.environmentRotationDegrees);
  io.Pod(previousState_.sunDirection);
  io.Pod(previousState_.sunIntensity);
  io.Vector(previousLights_);
  io.Vector(disocclusionAge_);
  io.Pod(hasPrevious_);
}

}  // namespace restir
