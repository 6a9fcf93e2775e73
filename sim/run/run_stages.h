// `restir-sim run` in its stages, which sim/run/runner.cpp defines and its Run reads as: PlanRun before
// anything is written; then per frame of FrameLoop::Play, StartFrame, RenderFrameReference,
// PrepareSharedInputs, RenderPresets (each preset's files handed to the background writer as soon as it is
// rendered), MeasurePresets, KeepRows and WriteMetricsCsv, and once the loop keeps the frame, CheckpointIfDue;
// then FinishRun. Declared here so that a test can call a stage alone.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/metrics/flip.h"
#include "sim/metrics/metrics.h"
#include "sim/output/background_writer.h"
#include "sim/output/output_manifest.h"
#include "sim/reference/reference.h"
#include "sim/run/frame_loop.h"
#include "sim/run/progress.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/sequence.h"
#include "sim/util/atomic_file.h"
#include "sim/util/clock.h"
#include "sim/util/image.h"

namespace restir {

struct RunOptions;  // sim/run/runner.h
struct RunResult;

namespace run_stages {

// What a run decided before its first frame (PlanRun).
struct RunPlan {
  int width = 0, height = 0;
  int frameEnd = 0;  // one past the last frame
  uint32_t seed = 0;
  // Per preset, K pipelines (--ensemble K): member k runs with seed + k; member 0 is the run's own estimate.
  int members = 1;
  int threads = 0;
  std::vector<Preset> presets;  // with every --set applied
  ReferenceParams refParams;
  nlohmann::json runJson;  // as the run starts ("status": "running"); FinishRun completes it
  std::string runJsonPath, csvPath, checkpointPath;
  std::string configKey;  // what a checkpoint or a completed run must match (ConfigurationKey)
  std::vector<int> frameFileFrames;  // the frames whose EXR and preview are written (RunOptions::imageFrames), sorted
};

// The references a run rendered (not read from the cache), for run.json.
struct ReferenceTally {
  int frames = 0, cachedFrames = 0;
  uint64_t rays = 0, samples = 0;
  double ms = 0.0;
};

// A frame's inputs to its presets' image files that the frame loop does not keep: the reference, and the G-buffer
// arrays the EXR shows (disocclusion, depth, shading normal; the snapshot's other arrays stay empty).
struct FrameImageInputs {
  bool hasReference = false;
  bool frameFiles = false;   // this frame's EXR and preview are written (RunPlan::frameFileFrames); scrub PNGs always
  std::string sequenceHash;  // the sequence's content hash, stamped on every EXR
  ImageRgb reference, referenceStdError;
  GBuffer gbuffer;
  // With a reference, every preset's preview of the frame shares its exposure and its reference panel: made once,
  // by the frame's first image job.
  mutable std::once_flag previewOnce;
  mutable float exposure = 1.0f;
  mutable std::vector<unsigned char> referencePanel;
};

// One preset's frame between rendering and writing (Run's frame loop).
struct PresetFrame {
  FrameResult fr;                           // member 0's frame
  ImageRgb ensembleBias, ensembleVariance;  // --ensemble K > 1: the members' split, and its statistics
  EnsembleStats ensemble;
  ConvergedRmspe converged;                 // --ensemble K >= 3: the members' running means against the reference
  FlipMap flipMap;                          // against the reference (empty without one)
  FrameMetricsRow row;                      // its metrics.csv row
};

// What a preset carries from frame to frame besides its pipelines' reservoirs.
struct PresetState {
  Preset preset;
  bool sharesInitialPass = false;                  // another preset runs its initial pass (SharesInitialPass)
  std::vector<std::unique_ptr<Pipeline>> members;  // --ensemble K: member k runs with seed + k
  ImageRgb previousImage;                          // member 0's estimate of the previous frame
  ImageRgb accumSum;                               // Σ of member 0's estimates since the scene state changed
  std::vector<ImageRgb> memberAccumSums;           // the same for members 1..K−1 (--ensemble K >= 3 only)
};

// Everything the next frame reads, in one list for writing and reading a checkpoint.
struct RunState {
  FrameLoop& loop;
  std::vector<PresetState>& presets;
  ImageRgb& previousReference;
  int& accumFrames;
  std::vector<FrameMetricsRow>& rows;
  // The scrub PNGs' exposure, chosen from the run's first frame (its reference, else its first estimate) and kept,
  // so that a resumed run's frames match an uninterrupted one's; 0 until chosen.
  float& scrubExposure;
  // Io: ByteCounter, BinaryWriter or BinaryReader (sim/util/binary_io.h); defined in sim/run/runner.cpp.
  template <typename Io>
  void Transfer(Io& io, int& nextFrame);
  // Rows restored from a checkpoint written with the presets in another order: each frame's rows in this run's
  // order, as an uninterrupted run writes metrics.csv.
  void InPresetOrder(std::vector<FrameMetricsRow>& restored) const;
};

// What lasts from a run's first frame to its last, for the frame's stages (Run's own objects).
struct RunContext {
  const RunOptions& opt;
  RunPlan& plan;
  FrameLoop& loop;
  RunState& state;  // the presets, the previous reference, the accumulated frames, the rows
  ProgressBar& progress;
  ReferenceTally& refRendered;
  OutputManifest& written;           // the frame files written so far
  BackgroundWriter* imageWriter;     // null: no images (RunOptions::writeImages)
  AtomicFileWriter* relativeErrors;  // null: none (RunOptions::relativeErrorPath)
};

// One frame of a run: what its stages hand each other besides the frame loop. Kept until the frame's
// checkpoint.
struct RunFrame {
  int frame = 0;
  std::vector<uint8_t> recentMask;  // pixels revealed in the last 4 frames (RecentDisocclusionMask)
  std::vector<uint8_t> restMask;    // the complement: pixels not revealed in the last 4 frames
  bool hasPrevious = false;         // true after a resume too: the checkpoint restored it
  bool stateChanged = false;        // the scene state differs from the previous frame's (or there is none)
  ReferenceImage ref;               // empty without a reference
  // What this frame's image files read after the loop has moved on (null without images).
  std::shared_ptr<const FrameImageInputs> imageInputs;
  // FLIP's work on the reference (empty without one).
  std::optional<FlipReference> flipReference;
  // Presets with equal initial-sampling parameters run the frame's initial pass once
  // (sim/estimator/pipeline.h).
  InitialSamplingShare initialShare;
  std::vector<PresetFrame> work;  // per preset, in the run's order
};

// When the last checkpoint was written.
struct CheckpointClock {
  Clock::time_point last = Clock::now();
  bool written = false;
};

// Before anything is written: the frame range and presets checked, the run's memory against what it may take,
// and run.json as the run starts. Throws InputError.
RunPlan PlanRun(const RunOptions& opt, const Sequence& seq);
// --resume: this configuration completed in the output directory, and every file it wrote is as written.
bool CompleteRunIntact(const RunOptions& opt, const RunPlan& plan);
// Each preset's pipelines (RunPlan::members of them).
std::vector<PresetState> MakePresetStates(const RunPlan& plan);
// The frame to start from: frameBegin, or a checkpoint's next frame with the run's state and its record of
// written files restored.
int LoadCheckpoint(const std::string& path, const std::string& configKey, const std::string& outDir,
                   OutputManifest& written, RunState& state, int frameBegin);
void SaveCheckpoint(const std::string& path, const std::string& configKey, OutputManifest& written,
                    RunState& state, int nextFrame);

// The frame's stages, after FrameLoop::BeginFrame, in this order.
void StartFrame(RunContext& run, int frame, RunFrame& f);
void RenderFrameReference(RunContext& run, RunFrame& f);
// What the presets' files and FLIP share: the frame's image inputs and the FLIP reference.
void PrepareSharedInputs(RunContext& run, RunFrame& f);
void RenderPresets(RunContext& run, RunFrame& f);
void MeasurePresets(RunContext& run, RunFrame& f);
void KeepRows(RunContext& run, RunFrame& f);
void WriteMetricsCsv(RunContext& run);
// After FrameLoop::EndFrame: the checkpoint, on the first frame and then every RunOptions::checkpointSeconds.
void CheckpointIfDue(RunContext& run, int frame, CheckpointClock& clock);
// After the last frame: the files finished, run.json complete, the report.
void FinishRun(RunContext& run, Clock::time_point start, RunResult& result);

std::string MetricsCsv(const std::vector<FrameMetricsRow>& rows);
// The checkpoint (--resume) is keyed by the configuration: run.json without the fields that do not change the
// results, so a different run never resumes from it.
std::string ConfigurationKey(nlohmann::json runJson);

}  // namespace run_stages
}  // namespace restir
