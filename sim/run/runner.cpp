#include "sim/run/runner.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/simd.h"
#include "sim/util/atomic_file.h"
#include "sim/output/background_writer.h"
#include "sim/util/binary_io.h"
#include "sim/output/output_manifest.h"
#include "sim/util/clock.h"
#include "sim/metrics/flip.h"
#include "sim/util/input_file.h"
#include "sim/run/memory_estimate.h"
#include "sim/run/frame_loop.h"
#include "sim/output/frame_writer.h"
#include "sim/metrics/metrics.h"
#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/run/progress.h"
#include "sim/reference/reference.h"
#include "sim/output/report.h"
#include "sim/scene/sequence.h"
#include "sim/estimator/settings.h"
#include "sim/metrics/relative_error_file.h"
#include "sim/metrics/seed_ensemble.h"

namespace restir {

namespace {

// A frame's inputs to its presets' image files that the frame loop does not keep: the reference, and the G-buffer
// arrays the EXR shows (disocclusion, depth, shading normal; the snapshot's other arrays stay empty).
struct FrameImageInputs {
  bool hasReference = false;
  std::string sequenceHash;  // the sequence's content hash, stamped on every EXR
  ImageRgb reference, referenceStdError;
  GBuffer gbuffer;
  // With a reference, every preset's preview of the frame shares its exposure and its reference panel: made once,
  // by the frame's first image job.
  mutable std::once_flag previewOnce;
  mutable float exposure = 1.0f;
  mutable std::vector<unsigned char> referencePanel;
};

std::shared_ptr<const FrameImageInputs> SnapshotImageInputs(const ReferenceImage& ref, bool hasReference,
                                                            const GBuffer& g, const std::string& sequenceHash) {
  auto in = std::make_shared<FrameImageInputs>();
  in->hasReference = hasReference;
  in->sequenceHash = sequenceHash;
  if (hasReference) {
    in->reference = ref.mean;
    in->referenceStdError = ref.standardError;
  }
  in->gbuffer.width = g.width;
  in->gbuffer.height = g.height;
  in->gbuffer.disoccluded = g.disoccluded;
  in->gbuffer.depth = g.depth;
  in->gbuffer.nsX = g.nsX, in->gbuffer.nsY = g.nsY, in->gbuffer.nsZ = g.nsZ;
  return in;
}

// One preset's images of a frame, as its image job owns them.
struct PresetImages {
  ImageRgb estimate;
  std::vector<float> flip;                  // empty without a reference
  ImageRgb ensembleBias, ensembleVariance;  // empty without an ensemble
};

// One preset's frame files, on the background writer: the EXR (sim/output/frame_writer.h's layers) and the PNG preview,
// whose exposure and reference panel the frame's first job makes for all of them.
void WritePresetFiles(const std::string& stem, const PresetImages& images, const FrameImageInputs& frame,
                      ExrCompression compression) {
  FrameLayers layers;
  layers.estimate = &images.estimate;
  layers.reference = frame.hasReference ? &frame.reference : nullptr;
  layers.referenceStdError = frame.hasReference ? &frame.referenceStdError : nullptr;
  layers.gbuffer = &frame.gbuffer;
  layers.flip = frame.hasReference ? &images.flip : nullptr;
  layers.ensembleBias = images.ensembleBias.Size() ? &images.ensembleBias : nullptr;
  layers.ensembleVariance = images.ensembleVariance.Size() ? &images.ensembleVariance : nullptr;
  layers.sequenceHash = frame.sequenceHash;
  WriteFrameExr(stem + ".exr", layers, compression);
  if (!frame.hasReference) return WritePreviewPng(stem + ".png", images.estimate, nullptr);
  std::call_once(frame.previewOnce, [&] {
    frame.exposure = PreviewExposure(frame.reference);
    frame.referencePanel = TonemapPreview(frame.reference, frame.exposure);
  });
  const std::vector<unsigned char> left = TonemapPreview(images.estimate, frame.exposure);
  WritePreviewPng(stem + ".png", {&left, &frame.referencePanel}, images.estimate.width, images.estimate.height);
}

std::string FormatCsvNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", v);
  return buf;
}

std::string MetricsCsv(const std::vector<FrameMetricsRow>& rows) {
  std::ostringstream o;
  if (rows.empty()) return "";
  o << "frame,preset";
  for (const auto& [name, value] : rows.front().values) o << "," << name;
  o << ",image_hash\n";
  for (const FrameMetricsRow& r : rows) {
    o << r.frame << "," << r.preset;
    for (const auto& [name, value] : r.values) o << "," << FormatCsvNumber(value);
    o << "," << r.imageHash << "\n";
  }
  return o.str();
}

nlohmann::json SettingsJson(const PipelineSettings& s) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [key, value] : SettingsToStrings(s)) j[key] = value;
  return j;
}

bool SameSceneState(const FrameState& a, const FrameState& b) {
  const Camera &ca = a.camera, &cb = b.camera;
  return ca.position == cb.position && ca.forward == cb.forward && ca.up == cb.up &&
         ca.vfovDegrees == cb.vfovDegrees && a.objectToWorld == b.objectToWorld && a.lightOn == b.lightOn &&
         a.environmentIntensity == b.environmentIntensity &&
         a.environmentRotationDegrees == b.environmentRotationDegrees && a.sunDirection == b.sunDirection &&
         a.sunIntensity == b.sunIntensity;
}


template <typename Io>
void TransferImage(Io& io, ImageRgb& img) {
  io.Pod(img.width);
  io.Pod(img.height);
  io.Vector(img.pixels);
}

template <typename Io>
void TransferRows(Io& io, std::vector<FrameMetricsRow>& rows) {
  uint64_t n = rows.size();
  io.Count(n);
  rows.resize(n);
  for (FrameMetricsRow& row : rows) {
    io.Pod(row.frame);
    io.String(row.preset);
    io.String(row.imageHash);
    uint64_t values = row.values.size();
    io.Count(values);
    row.values.resize(values);
    for (auto& [name, value] : row.values) {
      io.String(name);
      io.Pod(value);
    }
  }
}

constexpr uint64_t kCheckpointMagic = 0x37544B43'52545352ull;  // "RSTRCKT7" (7: presets by name)

// One preset's frame between rendering and writing (Run's frame loop).
struct PresetFrame {
  FrameResult fr;                           // member 0's frame
  ImageRgb ensembleBias, ensembleVariance;  // --ensemble K > 1: the members' split, and its statistics
  EnsembleStats ensemble;
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
};

// Everything the next frame reads, in one list for writing and reading a checkpoint (Io: BinaryWriter or
// BinaryReader).
struct RunState {
  FrameLoop& loop;
  std::vector<PresetState>& presets;
  ImageRgb& previousReference;
  int& accumFrames;
  std::vector<FrameMetricsRow>& rows;
  template <typename Io>
  void Transfer(Io& io, int& nextFrame) {
    io.Pod(nextFrame);
    loop.Transfer(io);
    TransferImage(io, previousReference);
    // By name, in name order: the configuration key holds the presets as a set, so a resume may list them in
    // another order than the run that wrote the checkpoint, and each must get its own state back.
    std::vector<PresetState*> byName;
    for (PresetState& p : presets) byName.push_back(&p);
    std::sort(byName.begin(), byName.end(),
              [](const PresetState* a, const PresetState* b) { return a->preset.name < b->preset.name; });
    for (PresetState* p : byName) {
      std::string name = p->preset.name;
      io.String(name);
      if (name != p->preset.name) throw std::runtime_error("its presets are not this run's");
      TransferImage(io, p->previousImage);
      TransferImage(io, p->accumSum);
      for (auto& member : p->members) io.Vector(member->History());
    }
    io.Pod(accumFrames);
    TransferRows(io, rows);
    InPresetOrder(rows);
  }

  // Rows restored from a checkpoint written with the presets in another order: each frame's rows in this run's
  // order, as an uninterrupted run writes metrics.csv.
  void InPresetOrder(std::vector<FrameMetricsRow>& restored) const {
    auto rank = [&](const FrameMetricsRow& r) {
      for (size_t i = 0; i < presets.size(); ++i)
        if (presets[i].preset.name == r.preset) return i;
      return presets.size();
    };
    std::stable_sort(restored.begin(), restored.end(), [&](const FrameMetricsRow& a, const FrameMetricsRow& b) {
      return a.frame != b.frame ? a.frame < b.frame : rank(a) < rank(b);
    });
  }
};

// The checkpoint (--resume) is keyed by the configuration: run.json without the fields that do not change the
// results, so a different run never resumes from it.
std::string ConfigurationKey(nlohmann::json runJson) {
  // exrCompression changes the EXRs' bytes, never their pixels, like the thread count their timing.
  for (const char* volatileField :
       {"commandLine", "status", "threads", "simd", "exrCompression", "wallSeconds", "referenceThroughput", "outputs"})
    runJson.erase(volatileField);
  return runJson.dump();
}

// The frame files written so far come before the state, so a resume checks them before it restores anything.
void SaveCheckpoint(const std::string& path, const std::string& configKey, OutputManifest& written, RunState& state,
                    int nextFrame) {
  ByteCounter size;
  size.Pod(kCheckpointMagic);
  size.String(configKey);
  written.Transfer(size);
  state.Transfer(size, nextFrame);
  BinaryWriter w;
  w.Reserve(size.Bytes());
  w.Pod(kCheckpointMagic);
  w.String(configKey);
  written.Transfer(w);
  state.Transfer(w, nextFrame);
  WriteFileAtomic(path, w.Bytes());
}

// Says which recorded frame files are missing or damaged and that the run renders from `frameBegin` again to
// write them; false (saying nothing) when every one is as written.
bool ReportDamagedOutputs(const std::string& outDir, const std::vector<OutputFile>& files, int frameBegin) {
  const std::vector<std::string> damaged = DamagedOutputs(outDir, files);
  for (const std::string& line : damaged) std::fprintf(stderr, "restir-sim: %s\n", line.c_str());
  if (!damaged.empty())
    std::fprintf(stderr, "restir-sim: rendering again from frame %d to write %s\n", frameBegin,
                 damaged.size() == 1 ? "it" : "them");
  return !damaged.empty();
}

// The frame to start from: frameBegin, or the checkpoint's next frame with the run's state and its record of
// written files restored. A frame file of a finished frame that is missing or damaged starts the run again (its
// bits come back only by rendering the frames before it).
int LoadCheckpoint(const std::string& path, const std::string& configKey, const std::string& outDir,
                   OutputManifest& written, RunState& state, int frameBegin) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, std::numeric_limits<size_t>::max(), bytes, problem)) {
    if (problem != "no such file") throw InputError(path + ": error: cannot read checkpoint (" + problem + ")");
    bytes.clear();
  }
  try {
    BinaryReader r(bytes);
    uint64_t magic = 0;
    std::string key;
    if (!bytes.empty()) r.Pod(magic);
    if (magic == kCheckpointMagic) r.String(key);
    if (magic == kCheckpointMagic && key == configKey) {
      written.Transfer(r);
      if (ReportDamagedOutputs(outDir, written.Files(), frameBegin)) {
        written.Restore({});
        return frameBegin;
      }
      int nextFrame = 0;
      state.Transfer(r, nextFrame);
      if (!r.AtEnd()) throw std::runtime_error("trailing bytes");
      state.loop.RestoreScene();
      return nextFrame;
    }
    if (!bytes.empty())
      std::fprintf(stderr, "restir-sim: %s is from another configuration; starting from frame %d\n", path.c_str(),
                   frameBegin);
  } catch (const std::runtime_error& e) {
    // Checkpoints are renamed into place whole, so this is outside damage: refuse rather than guess.
    throw InputError(path + ": error: unreadable checkpoint (" + e.what() + "); delete it or run without --resume");
  }
  return frameBegin;
}

// The presets a run replays, with every --set applied. Names from the file are reported with their JSON path
// (validate reports the same line); a name given twice would write two sets of rows under one name.
std::vector<Preset> ResolvePresets(const RunOptions& opt, const Sequence& seq) {
  if (opt.presets.empty()) CheckSequencePresets(seq);
  std::vector<Preset> presets;
  for (const std::string& name : opt.presets.empty() ? seq.defaults.presets : opt.presets) {
    const Preset* p = FindPreset(name);
    if (!p) throw InputError("--preset: error: " + UnknownPresetMessage(name));
    for (const Preset& earlier : presets)
      if (earlier.name == p->name) throw InputError("--preset: error: preset '" + name + "' is given twice");
    presets.push_back(*p);
    for (const std::string& assignment : opt.settings) ApplySettingAssignment(presets.back().settings, assignment);
  }
  return presets;
}

// True when another of `presets` runs the same initial pass as presets[p] (InitialSamplingShare,
// sim/estimator/pipeline.h): a pass no other preset reads is not kept.
bool SharesInitialPass(const std::vector<Preset>& presets, size_t p) {
  for (size_t q = 0; q < presets.size(); ++q)
    if (q != p && presets[q].settings.initial == presets[p].settings.initial) return true;
  return false;
}

// The run's memory against what it may take (--max-memory; DESIGN §10), before anything is allocated or written.
void CheckRunMemory(const RunOptions& opt, const Sequence& seq, const ReferenceParams& refParams, int width,
                    int height, int frames, const std::vector<Preset>& presets, int members) {
  if (opt.maxMemoryBytes < 0.0) return;
  RunShape shape;
  shape.width = width;
  shape.height = height;
  shape.frames = frames;
  shape.presets = static_cast<int64_t>(presets.size());
  shape.members = members;
  std::vector<InitialSamplingParams> shared;  // what the frame's InitialSamplingShare keeps
  for (size_t p = 0; p < presets.size(); ++p)
    if (SharesInitialPass(presets, p) &&
        std::find(shared.begin(), shared.end(), presets[p].settings.initial) == shared.end())
      shared.push_back(presets[p].settings.initial);
  shape.sharedInitialPasses = static_cast<int64_t>(shared.size());
  shape.reference = opt.reference;
  shape.writeImages = opt.writeImages;
  for (const Object& o : seq.objects) shape.sceneTriangles += static_cast<int64_t>(o.mesh.triangles.size());
  for (const Light& l : seq.lights) shape.lightTriangles += static_cast<int64_t>(l.vertices.size() / 3);
  shape.lightGroups = CountLightGroups(seq.lights);
  shape.textures = !seq.textures.empty();
  shape.sky = seq.environment.present || seq.sun.present;
  shape.referenceSamplesPerPixel = ReferenceMaxSamplesPerPixel(refParams);
  shape.processBytes = CurrentResidentBytes();
  const MemoryEstimate estimate = EstimateRunMemory(shape);
  if (opt.maxMemoryBytes > 0.0) {
    CheckMemory(estimate, opt.maxMemoryBytes, "--max-memory", opt.sequencePath);
  } else if (const std::optional<MemoryLimit> limit = MachineMemoryLimit()) {
    CheckMemory(estimate, limit->bytes, limit->source, opt.sequencePath);
  }
}

// A completed run of this configuration in the output directory (run.json says "complete" under the same key).
// Its "outputs", the frame files it wrote, go to `outputs` (none from a run.json that predates them).
bool CompleteRunExists(const std::string& runJsonPath, const std::string& configKey,
                       std::vector<OutputFile>& outputs) {
  std::string text, problem;
  if (!TryReadRegularFile(runJsonPath, size_t(64) << 20, text, problem)) return false;
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object() || j.value("status", "") != "complete") return false;
  if (ConfigurationKey(j) != configKey) return false;
  if (!j.contains("outputs") || !OutputFilesFromJson(j["outputs"], outputs)) outputs.clear();
  return true;
}

}  // namespace

RunResult Run(const RunOptions& opt) {
  const auto tRun = Clock::now();
  const Sequence seq = LoadSequence(opt.sequencePath);
  const int width = opt.width > 0 ? opt.width : seq.width;
  const int height = opt.height > 0 ? opt.height : seq.height;
  const int frameEnd = opt.frameEnd < 0 ? seq.frameCount : opt.frameEnd;
  if (opt.frameBegin < 0 || opt.frameBegin >= frameEnd || frameEnd > seq.frameCount)
    throw InputError(opt.sequencePath + ": error: frame range " + std::to_string(opt.frameBegin) + ":" +
                     std::to_string(frameEnd) + " is outside the sequence's frames 0:" +
                     std::to_string(seq.frameCount));
  const uint32_t seed = opt.seed.value_or(seq.seed);
  // Per preset, K pipelines (--ensemble K): member k runs with seed + k; member 0 is the run's own estimate.
  // The split needs a reference, so without one the other members would be rendered for nothing.
  const int members = opt.reference ? std::max(1, opt.ensemble) : 1;
  const std::vector<Preset> resolved = ResolvePresets(opt, seq);
  if (!opt.relativeErrorPath.empty() && (resolved.size() != 1 || !opt.reference || opt.resume))
    throw InputError(opt.relativeErrorPath + ": error: relative-error frames need one preset, a reference and no "
                     "--resume");
  ReferenceParams refParams;
  refParams.samplesPerPixel = opt.referenceSpp > 0 ? opt.referenceSpp : seq.defaults.referenceSpp;
  refParams.targetRelativeError = opt.referenceError;
  refParams.cacheDir = opt.cacheDir;
  CheckRunMemory(opt, seq, refParams, width, height, frameEnd - opt.frameBegin, resolved, members);
  const int threads = opt.threads > 0 ? opt.threads : tbb::info::default_concurrency();

  // run.json first, so an interrupted run still says what it was.
  nlohmann::json runJson = {
      {"program", "restir-sim"},
      {"version", RESTIR_VERSION},
      {"commandLine", opt.commandLine},
      {"sequence", {{"path", opt.sequencePath}, {"name", seq.name}, {"contentHash", seq.contentHash}}},
      {"resolution", {width, height}},
      {"frames", {opt.frameBegin, frameEnd}},
      {"seed", seed},
      {"ensemble", members},
      {"simd", ActiveSimdTargetName()},
      {"embreeIsa", EmbreeIsaName(ActiveEmbreeIsa())},
      {"threads", threads},
      {"exrCompression", opt.writeImages ? nlohmann::json(ExrCompressionName(opt.exrCompression)) : nullptr},
      {"reference", opt.reference ? nlohmann::json{{"samplesPerPixel", refParams.samplesPerPixel},
                                                    {"targetRelativeError", refParams.targetRelativeError},
                                                    {"cacheDir", refParams.cacheDir}}
                                  : nlohmann::json(nullptr)},
      {"status", "running"}};
  for (const Preset& p : resolved)
    runJson["presets"][p.name] = {{"source", p.source}, {"settings", SettingsJson(p.settings)}};
  runJson["overrides"] = opt.settings;
  const std::string runJsonPath = (std::filesystem::path(opt.outDir) / "run.json").string();
  const std::string csvPath = (std::filesystem::path(opt.outDir) / "metrics.csv").string();
  const std::string configKey = ConfigurationKey(runJson);
  RunResult result;
  // Resuming a finished run has nothing to do, and must not start it again beside its own summary.
  // Unless a file it wrote has gone or changed since: then it renders again to write it.
  std::vector<OutputFile> completeOutputs;
  if (opt.resume && CompleteRunExists(runJsonPath, configKey, completeOutputs) &&
      !ReportDamagedOutputs(opt.outDir, completeOutputs, opt.frameBegin)) {
    result.alreadyComplete = true;
    return result;
  }

  const TemporaryRoot outputTemporaries(opt.outDir);
  CheckWritableDirectory(opt.outDir, "output directory");
  std::optional<TemporaryRoot> cacheTemporaries;
  if (opt.reference && !opt.cacheDir.empty()) {
    cacheTemporaries.emplace(opt.cacheDir);
    CheckWritableDirectory(opt.cacheDir, "reference cache directory");
  }
  tbb::global_control threadLimit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
  if (opt.writeImages) SetExrThreads(threads);
  WriteFileAtomic(runJsonPath, runJson.dump(2) + "\n");

  // opt.relativeErrorPath, written frame by frame (a long run's would not fit in memory twice).
  std::optional<AtomicFileWriter> relativeErrors;
  if (!opt.relativeErrorPath.empty()) {
    relativeErrors.emplace(opt.relativeErrorPath);
    relativeErrors->Write(EncodeRelativeErrorHeader(width, height, frameEnd - opt.frameBegin));
  }
  std::vector<PresetState> presets;
  for (const Preset& p : resolved) {
    PresetState& ps = presets.emplace_back();
    ps.preset = p;
    ps.sharesInitialPass = SharesInitialPass(resolved, presets.size() - 1);
    for (int k = 0; k < members; ++k) ps.members.push_back(std::make_unique<Pipeline>(p.settings));
  }
  FrameLoop loop(seq, width, height);
  ImageRgb previousReference;
  int accumFrames = 0;
  RunState state{loop, presets, previousReference, accumFrames, result.rows};
  const std::string checkpointPath = (std::filesystem::path(opt.outDir) / "checkpoint.bin").string();
  // Declared before the image writer, whose jobs record into it.
  OutputManifest written(opt.outDir);
  const int firstFrame =
      opt.resume ? LoadCheckpoint(checkpointPath, configKey, opt.outDir, written, state, opt.frameBegin)
                 : opt.frameBegin;
  if (firstFrame > opt.frameBegin) result.resumedAtFrame = firstFrame;
  ProgressBar progress(opt.progress, seq.name, frameEnd - opt.frameBegin);
  struct {
    int frames = 0, cachedFrames = 0;
    uint64_t rays = 0, samples = 0;
    double ms = 0.0;
  } refRendered;  // the references this run rendered (not read from the cache), for run.json

  auto lastCheckpoint = Clock::now();
  bool checkpointWritten = false;
  // Frame images are encoded and written on a thread of their own while the next preset renders. Declared after
  // outputTemporaries, so it stops (and its temporaries are cleaned) before them; drained wherever the files must
  // exist: before a checkpoint (it says the frames before it are done) and at the end.
  std::optional<BackgroundWriter> imageWriter;
  if (opt.writeImages) imageWriter.emplace(size_t{kImageJobsWaiting});  // sim/run/memory_estimate.h
  for (int frame = firstFrame; frame < frameEnd; ++frame) {
    loop.BeginFrame(frame);
    const FrameState& frameState = loop.State();
    const GBuffer& current = loop.Gbuffer();
    const std::vector<uint8_t> recentMask = RecentDisocclusionMask(loop.DisocclusionAge());
    std::vector<uint8_t> restMask(recentMask.size());  // the complement: pixels not revealed in the last 4 frames
    for (size_t i = 0; i < recentMask.size(); ++i) restMask[i] = !recentMask[i];
    const bool hasPrevious = frame > opt.frameBegin;  // true after a resume too: the checkpoint restored it
    const bool stateChanged = !hasPrevious || !SameSceneState(frameState, loop.PreviousState());
    accumFrames = stateChanged ? 1 : accumFrames + 1;
    ReferenceImage ref;
    if (opt.reference) {
      progress.Show(frame - opt.frameBegin, "reference");
      ref = RenderReference(seq, frameState, loop.Scene(), current, refParams);
      if (!ref.fromCache) {
        refRendered.frames += 1;
        refRendered.rays += ref.rays;
        refRendered.samples += ref.samples;
        refRendered.ms += ref.ms;
      } else {
        refRendered.cachedFrames += 1;
      }
    }

    // What this frame's image files read after the loop has moved on: the reference (moved into previousReference
    // at the frame's end) and the G-buffer layers the EXR shows (the loop reuses its buffers).
    std::shared_ptr<const FrameImageInputs> imageInputs;
    if (opt.writeImages) imageInputs = SnapshotImageInputs(ref, opt.reference, current, seq.contentHash);

    // FLIP's work on the reference (its exposures, filtered planes, colours and features) once per frame, not
    // once per preset.
    std::optional<FlipReference> flipReference;
    if (opt.reference) flipReference.emplace(ref.mean);

    // Presets with equal initial-sampling parameters run the frame's initial pass once (sim/estimator/pipeline.h).
    InitialSamplingShare initialShare;
    // Each preset's frame: rendered and FLIP'd preset by preset (each of those parallel inside), then measured for
    // all presets at once, a preset per task (MeasureFrame sums in pixel order, serially: the same bits whatever
    // the thread count), then written in preset order.
    std::vector<PresetFrame> work(presets.size());
    for (size_t p = 0; p < presets.size(); ++p) {
      PresetState& ps = presets[p];
      PresetFrame& pf = work[p];
      progress.Show(frame - opt.frameBegin,
                    ps.preset.name + " (" + std::to_string(p + 1) + "/" + std::to_string(presets.size()) + ")");
      FrameInputs inputs = loop.Inputs(seed);
      inputs.measureReservoirs = true;
      inputs.diagnosticsRegion = &recentMask;
      InitialSamplingShare* share = ps.sharesInitialPass ? &initialShare : nullptr;
      inputs.initialShare = share;
      pf.fr = ps.members[0]->RenderFrame(inputs);
      // The other ensemble members, for the bias²/variance split of this frame (DESIGN §6 seed ensembles).
      if (members > 1) {
        std::vector<ImageRgb> images;
        images.push_back(pf.fr.image);
        for (int k = 1; k < members; ++k) {
          FrameInputs memberInputs = loop.Inputs(seed + static_cast<uint32_t>(k));
          memberInputs.initialShare = share;
          images.push_back(ps.members[k]->RenderFrame(memberInputs).image);
        }
        pf.ensemble = MeasureEnsemble(images, ref.mean, ref.standardError, pf.ensembleBias, pf.ensembleVariance);
      }
      if (opt.reference) pf.flipMap = HdrFlip(*flipReference, pf.fr.image);
      if (opt.writeImages) {
        char name[32];
        std::snprintf(name, sizeof(name), "%04d", frame);
        const auto stem = std::filesystem::path(opt.outDir) / "frames" / ps.preset.name / name;
        // The job owns what it writes: this preset's images (the estimate and FLIP map copied, as the metrics
        // below read them; the ensemble images moved) and the frame's shared inputs. Submitted now, so the writer
        // works while the next preset renders.
        auto images = std::make_shared<const PresetImages>(PresetImages{
            pf.fr.image, pf.flipMap.values, std::move(pf.ensembleBias), std::move(pf.ensembleVariance)});
        const std::string relative = "frames/" + ps.preset.name + "/" + name;
        imageWriter->Submit([stem, relative, images, frameInputs = imageInputs, compression = opt.exrCompression,
                             &written] {
          WritePresetFiles(stem.string(), *images, *frameInputs, compression);
          for (const char* extension : {".exr", ".png"}) written.Record(relative + extension);
        });
      }
    }
    const double referenceRelStdError = opt.reference ? MeanRelativeStandardError(ref) : 0.0;
    tbb::parallel_for(size_t{0}, presets.size(), [&](size_t p) {
      PresetState& ps = presets[p];
      PresetFrame& pf = work[p];
      const FrameResult& fr = pf.fr;
      if (stateChanged) {
        ps.accumSum = fr.image;
      } else {
        for (size_t i = 0; i < fr.image.Size(); ++i) ps.accumSum.pixels[i] += fr.image.pixels[i];
      }
      ImageRgb accumMean(width, height);
      for (size_t i = 0; i < accumMean.Size(); ++i) accumMean.pixels[i] = ps.accumSum.pixels[i] / float(accumFrames);

      FrameMeasurement m;
      m.frame = frame;
      m.preset = ps.preset.name;
      m.msSceneUpdate = loop.Timings().sceneUpdate;
      m.msPrimary = loop.Timings().primary;
      m.msReproject = loop.Timings().reproject;
      m.passes = &fr.passes;
      m.image = &fr.image;
      m.previousImage = hasPrevious ? &ps.previousImage : nullptr;
      m.guarded = fr.guardedEvents;
      m.temporalAcceptance = fr.temporalAcceptance;
      m.diagnostics = fr.diagnostics;
      m.crossObjectReuse = fr.crossObjectReuse;
      m.disoccFraction = MaskFraction(current.disoccluded);
      m.recentFraction = MaskFraction(recentMask);
      if (opt.reference) {
        m.reference = &ref.mean;
        m.msReference = ref.ms;
        m.referenceCached = ref.fromCache;
        m.referenceRelStdError = referenceRelStdError;
        m.referenceNoise = ReferenceNoise{&ref.standardError, &ref.lumaStandardError};
        m.previousReference = &previousReference;
        m.flip = &pf.flipMap;
        m.recentMask = &recentMask;
        m.restMask = &restMask;
        m.accumulatedMean = &accumMean;
        m.accumFrames = accumFrames;
        if (members > 1) m.ensemble = &pf.ensemble;
      }
      pf.row = MeasureFrame(m);
    });
    for (size_t p = 0; p < presets.size(); ++p) {
      PresetFrame& pf = work[p];
      result.rows.push_back(std::move(pf.row));
      if (relativeErrors) {
        std::vector<float> e;
        AppendRelativeError(pf.fr.image, ref.mean, e);
        relativeErrors->Write(EncodeRelativeErrorFrame(e));
      }
      presets[p].previousImage = std::move(pf.fr.image);
    }
    // The CSV is rewritten whole after every frame: it is always complete up to the last finished frame. It may
    // lead the frame files by the jobs the writer holds (a failed one is reported here or at the next Submit);
    // the checkpoint never does.
    if (imageWriter) imageWriter->Check();
    WriteFileAtomic(csvPath, MetricsCsv(result.rows));
    loop.EndFrame();
    if (opt.reference) previousReference = std::move(ref.mean);
    if (!checkpointWritten || opt.checkpointSeconds <= 0.0 ||
        std::chrono::duration<double>(Clock::now() - lastCheckpoint).count() >= opt.checkpointSeconds) {
      if (imageWriter) imageWriter->Drain();  // a resume starts after this frame: its images must be on disk
      SaveCheckpoint(checkpointPath, configKey, written, state, frame + 1);
      lastCheckpoint = Clock::now();
      checkpointWritten = true;
    }
    progress.FrameDone();
    progress.Show(frame - opt.frameBegin + 1, "done");
  }
  if (imageWriter) imageWriter->Drain();
  progress.Finish();
  result.wallSeconds = std::chrono::duration<double>(Clock::now() - tRun).count();
  std::error_code ec;
  std::filesystem::remove(checkpointPath, ec);  // a finished run needs no checkpoint
  runJson["status"] = "complete";
  runJson["wallSeconds"] = result.wallSeconds;
  if (opt.writeImages) runJson["outputs"] = OutputFilesJson(written.Files());
  if (opt.reference) {
    // What the reference cost where it was rendered: its rays (shadow rays and, on glossy pixels, BSDF rays)
    // per second of its wall time, to set beside the ray floor of docs/performance.md.
    runJson["referenceThroughput"] = {
        {"framesRendered", refRendered.frames},
        {"framesFromCache", refRendered.cachedFrames},
        {"rays", refRendered.rays},
        {"samples", refRendered.samples},
        {"seconds", refRendered.ms / 1000.0},
        {"raysPerSecond", refRendered.ms > 0.0 ? double(refRendered.rays) / (refRendered.ms / 1000.0) : 0.0},
        {"samplesPerPixel", refRendered.frames > 0 ? double(refRendered.samples) / (double(width) * height *
                                                                                   refRendered.frames)
                                                   : 0.0}};
  }
  if (relativeErrors) relativeErrors->Commit();
  WriteFileAtomic(runJsonPath, runJson.dump(2) + "\n");
  if (opt.report) WriteReport(opt.outDir);
  return result;
}

}  // namespace restir
