#include "sim/runner.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/simd.h"
#include "sim/atomic_file.h"
#include "sim/checkpoint.h"
#include "sim/clock.h"
#include "sim/flip.h"
#include "sim/frame_loop.h"
#include "sim/frame_writer.h"
#include "sim/metrics.h"
#include "sim/pipeline.h"
#include "sim/presets.h"
#include "sim/progress.h"
#include "sim/reference.h"
#include "sim/report.h"
#include "sim/sequence.h"
#include "sim/settings.h"

namespace restir {

namespace {

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
         ca.vfovDegrees == cb.vfovDegrees && a.objectToWorld == b.objectToWorld && a.lightOn == b.lightOn;
}

void CheckWritableDirectory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string probe = (std::filesystem::path(dir) / ".write-test").string();
  FILE* f = ec ? nullptr : std::fopen(probe.c_str(), "wb");
  if (!f) throw InputError(dir + ": error: output directory is not writable");
  std::fclose(f);
  std::filesystem::remove(probe, ec);
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

// A run killed while writing leaves its temporary (name.tmpPID.ext, see atomic_file.cpp) behind; the next run in
// the same directory removes them so that only whole files remain.
void RemoveStaleTemporaries(const std::string& dir) {
  static const std::regex temporary(R"(.*\.tmp[0-9]+(\..*)?)");
  std::error_code ec;
  std::vector<std::filesystem::path> stale;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec))
    if (it->is_regular_file() && std::regex_match(it->path().filename().string(), temporary))
      stale.push_back(it->path());
  for (const auto& p : stale) std::filesystem::remove(p, ec);
}

constexpr uint64_t kCheckpointMagic = 0x34544B43'52545352ull;  // "RSTRCKT4"

// What a preset carries from frame to frame besides its pipelines' reservoirs.
struct PresetState {
  Preset preset;
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
    for (PresetState& p : presets) {
      TransferImage(io, p.previousImage);
      TransferImage(io, p.accumSum);
      for (auto& member : p.members) io.Vector(member->History());
    }
    io.Pod(accumFrames);
    TransferRows(io, rows);
  }
};

void SaveCheckpoint(const std::string& path, const std::string& configKey, RunState& state, int nextFrame) {
  BinaryWriter w;
  w.Pod(kCheckpointMagic);
  w.String(configKey);
  state.Transfer(w, nextFrame);
  WriteFileAtomic(path, w.Bytes());
}

// The frame to start from: frameBegin, or the checkpoint's next frame with the run's state restored.
int LoadCheckpoint(const std::string& path, const std::string& configKey, RunState& state, int frameBegin) {
  std::ifstream f(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  try {
    BinaryReader r(bytes);
    uint64_t magic = 0;
    std::string key;
    if (!bytes.empty()) r.Pod(magic);
    if (magic == kCheckpointMagic) r.String(key);
    if (magic == kCheckpointMagic && key == configKey) {
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

// The presets a run replays, with every --set applied.
std::vector<Preset> ResolvePresets(const RunOptions& opt, const Sequence& seq) {
  std::vector<Preset> presets;
  for (const std::string& name : opt.presets.empty() ? seq.defaults.presets : opt.presets) {
    const Preset* p = FindPreset(name);
    if (!p) throw InputError("--preset: error: " + UnknownPresetMessage(name));
    presets.push_back(*p);
    for (const std::string& assignment : opt.settings) ApplySettingAssignment(presets.back().settings, assignment);
  }
  return presets;
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
  std::vector<PresetState> presets;
  for (const Preset& p : ResolvePresets(opt, seq)) {
    PresetState& ps = presets.emplace_back();
    ps.preset = p;
    for (int k = 0; k < members; ++k) ps.members.push_back(std::make_unique<Pipeline>(p.settings));
  }
  ReferenceParams refParams;
  refParams.samplesPerPixel = opt.referenceSpp > 0 ? opt.referenceSpp : seq.defaults.referenceSpp;
  refParams.cacheDir = opt.cacheDir;
  CheckWritableDirectory(opt.outDir);
  RemoveStaleTemporaries(opt.outDir);

  const int threads = opt.threads > 0 ? opt.threads : tbb::info::default_concurrency();
  tbb::global_control threadLimit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));

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
      {"threads", threads},
      {"reference", opt.reference ? nlohmann::json{{"samplesPerPixel", refParams.samplesPerPixel},
                                                    {"cacheDir", refParams.cacheDir}}
                                  : nlohmann::json(nullptr)},
      {"status", "running"}};
  for (const PresetState& p : presets)
    runJson["presets"][p.preset.name] = {{"source", p.preset.source}, {"settings", SettingsJson(p.preset.settings)}};
  runJson["overrides"] = opt.settings;
  const std::string runJsonPath = (std::filesystem::path(opt.outDir) / "run.json").string();
  const std::string csvPath = (std::filesystem::path(opt.outDir) / "metrics.csv").string();
  WriteFileAtomic(runJsonPath, runJson.dump(2) + "\n");

  FrameLoop loop(seq, width, height);
  ImageRgb previousReference;
  int accumFrames = 0;
  RunResult result;
  RunState state{loop, presets, previousReference, accumFrames, result.rows};
  // The checkpoint (--resume) is keyed by the configuration (run.json without the volatile fields), so a
  // different run never resumes from it.
  nlohmann::json keyJson = runJson;
  for (const char* volatileField : {"commandLine", "status", "threads", "simd"}) keyJson.erase(volatileField);
  const std::string configKey = keyJson.dump();
  const std::string checkpointPath = (std::filesystem::path(opt.outDir) / "checkpoint.bin").string();
  const int firstFrame = opt.resume ? LoadCheckpoint(checkpointPath, configKey, state, opt.frameBegin) : opt.frameBegin;
  if (firstFrame > opt.frameBegin) result.resumedAtFrame = firstFrame;
  ProgressBar progress(opt.progress, seq.name, frameEnd - opt.frameBegin);

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
    }

    for (size_t p = 0; p < presets.size(); ++p) {
      PresetState& ps = presets[p];
      progress.Show(frame - opt.frameBegin,
                    ps.preset.name + " (" + std::to_string(p + 1) + "/" + std::to_string(presets.size()) + ")");
      FrameResult fr = ps.members[0]->RenderFrame(loop.Inputs(seed));
      // The other ensemble members, for the bias²/variance split of this frame (DESIGN §6 seed ensembles).
      ImageRgb ensembleBias, ensembleVariance;
      EnsembleStats ens;
      if (members > 1) {
        std::vector<ImageRgb> images;
        images.push_back(fr.image);
        for (int k = 1; k < members; ++k)
          images.push_back(ps.members[k]->RenderFrame(loop.Inputs(seed + static_cast<uint32_t>(k))).image);
        ens = MeasureEnsemble(images, ref.mean, ref.standardError, ensembleBias, ensembleVariance);
      }
      if (stateChanged) {
        ps.accumSum = fr.image;
      } else {
        for (size_t i = 0; i < fr.image.Size(); ++i) ps.accumSum.pixels[i] += fr.image.pixels[i];
      }
      ImageRgb accumMean(width, height);
      for (size_t i = 0; i < accumMean.Size(); ++i) accumMean.pixels[i] = ps.accumSum.pixels[i] / float(accumFrames);
      const FlipMap flipMap = opt.reference ? HdrFlip(ref.mean, fr.image) : FlipMap{};

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
      m.meanConfidence = fr.meanConfidence;
      m.crossObjectReuse = fr.crossObjectReuse;
      m.disoccFraction = MaskFraction(current.disoccluded);
      m.recentFraction = MaskFraction(recentMask);
      if (opt.reference) {
        m.reference = &ref.mean;
        m.msReference = ref.ms;
        m.referenceCached = ref.fromCache;
        m.referenceRelStdError = MeanRelativeStandardError(ref);
        m.previousReference = &previousReference;
        m.flip = &flipMap;
        m.recentMask = &recentMask;
        m.restMask = &restMask;
        m.accumulatedMean = &accumMean;
        m.accumFrames = accumFrames;
        if (members > 1) m.ensemble = &ens;
      }
      result.rows.push_back(MeasureFrame(m));

      if (opt.writeImages) {
        char name[32];
        std::snprintf(name, sizeof(name), "%04d", frame);
        const auto dir = std::filesystem::path(opt.outDir) / "frames" / ps.preset.name;
        FrameLayers layers;
        layers.estimate = &fr.image;
        layers.reference = opt.reference ? &ref.mean : nullptr;
        layers.referenceStdError = opt.reference ? &ref.standardError : nullptr;
        layers.gbuffer = &current;
        layers.flip = opt.reference ? &flipMap.values : nullptr;
        layers.ensembleBias = ensembleBias.Size() ? &ensembleBias : nullptr;
        layers.ensembleVariance = ensembleVariance.Size() ? &ensembleVariance : nullptr;
        WriteFrameExr((dir / (std::string(name) + ".exr")).string(), layers);
        WritePreviewPng((dir / (std::string(name) + ".png")).string(), fr.image, layers.reference);
      }
      ps.previousImage = std::move(fr.image);
    }
    // The CSV is rewritten whole after every frame: it is always complete up to the last finished frame.
    WriteFileAtomic(csvPath, MetricsCsv(result.rows));
    loop.EndFrame();
    if (opt.reference) previousReference = std::move(ref.mean);
    SaveCheckpoint(checkpointPath, configKey, state, frame + 1);
    progress.FrameDone();
    progress.Show(frame - opt.frameBegin + 1, "done");
  }
  progress.Finish();
  result.wallSeconds = std::chrono::duration<double>(Clock::now() - tRun).count();
  std::error_code ec;
  std::filesystem::remove(checkpointPath, ec);  // a finished run needs no checkpoint
  runJson["status"] = "complete";
  runJson["wallSeconds"] = result.wallSeconds;
  WriteFileAtomic(runJsonPath, runJson.dump(2) + "\n");
  if (opt.report) WriteReport(opt.outDir);
  return result;
}

}  // namespace restir
