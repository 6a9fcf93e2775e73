#include "sim/runner.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
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
#include "sim/embree_scene.h"
#include "sim/flip.h"
#include "sim/frame_writer.h"
#include "sim/gbuffer.h"
#include "sim/metrics.h"
#include "sim/pipeline.h"
#include "sim/presets.h"
#include "sim/reference.h"
#include "sim/report.h"
#include "sim/sequence.h"
#include "sim/settings.h"

namespace restir {

namespace {

using Clock = std::chrono::steady_clock;

constexpr uint16_t kNeverDisoccluded = 0xFFFF;
constexpr uint16_t kDisoccWindow = 4;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
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

std::string FormatDuration(double seconds) {
  const int s = static_cast<int>(seconds + 0.5);
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%d:%02d:%02d", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

// Checkpoint fields, one list for both directions (Io is BinaryWriter or BinaryReader).
template <typename Io>
void TransferGbuffer(Io& io, GBuffer& g) {
  io.Pod(g.width);
  io.Pod(g.height);
  GBuffer::ForEachArray(g, [&](auto& v) { io.Vector(v); });
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

constexpr uint64_t kCheckpointMagic = 0x33544B43'52545352ull;  // "RSTRCKT3"

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
  const std::vector<std::string> presetNames = opt.presets.empty() ? seq.defaults.presets : opt.presets;
  std::vector<Preset> presets;
  for (const std::string& name : presetNames) {
    const Preset* p = FindPreset(name);
    if (!p) {
      std::string known;
      for (const Preset& q : AllPresets()) known += (known.empty() ? "" : ", ") + q.name;
      throw InputError("--preset: error: unknown preset '" + name + "' (known: " + known + ")");
    }
    presets.push_back(*p);
    for (const std::string& assignment : opt.settings) ApplySettingAssignment(presets.back().settings, assignment);
  }
  const uint32_t seed = opt.seed.value_or(seq.seed);
  // Per preset, K pipelines (--ensemble K): member k runs with seed + k; member 0 is the run's own estimate.
  // The split needs a reference, so without one the other members would be rendered for nothing.
  const int members = opt.reference ? std::max(1, opt.ensemble) : 1;
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
  for (const Preset& p : presets)
    runJson["presets"][p.name] = {{"source", p.source}, {"settings", SettingsJson(p.settings)}};
  runJson["overrides"] = opt.settings;
  const std::string runJsonPath = (std::filesystem::path(opt.outDir) / "run.json").string();
  const std::string csvPath = (std::filesystem::path(opt.outDir) / "metrics.csv").string();
  WriteFileAtomic(runJsonPath, runJson.dump(2) + "\n");

  EmbreeScene scene(seq);
  const std::vector<Bsdf> bsdfs = MaterialBsdfs(seq);
  std::vector<std::unique_ptr<Pipeline>> pipelines;
  for (const Preset& p : presets)
    for (int k = 0; k < members; ++k) pipelines.push_back(std::make_unique<Pipeline>(p.settings));
  GBuffer current, previous;
  FrameState previousState;
  std::vector<LightTriangle> previousLights;
  ImageRgb previousReference;
  // Per preset: last image, and the running sum since the scene state last changed (accumulated accuracy).
  std::vector<ImageRgb> previousImages(presets.size()), accumSum(presets.size());
  int accumFrames = 0;
  std::vector<uint16_t> disoccAge;  // per pixel: frames since its surface was revealed
  RunResult result;
  const bool showProgress = opt.progress && ::isatty(STDERR_FILENO);
  const int totalFrames = frameEnd - opt.frameBegin;
  // Progress bar on stderr (a terminal only): frames done, what the current frame is doing (reference or which
  // preset), elapsed time and ETA from the mean time of the finished frames of this session.
  int sessionFrames = 0;
  auto progress = [&](int done, const std::string& stage) {
    constexpr int kBar = 24;
    const int filled = totalFrames > 0 ? done * kBar / totalFrames : kBar;
    const double elapsed = std::chrono::duration<double>(Clock::now() - tRun).count();
    const int remaining = totalFrames - done;
    const std::string eta = sessionFrames > 0 ? FormatDuration(elapsed / sessionFrames * remaining) : "?";
    std::fprintf(stderr, "\r%s [%s%s] %d/%d frames  %-28s elapsed %s  ETA %s ", seq.name.c_str(),
                 std::string(filled, '#').c_str(), std::string(kBar - filled, '.').c_str(), done, totalFrames,
                 stage.c_str(), FormatDuration(elapsed).c_str(), eta.c_str());
    std::fflush(stderr);
  };

  // Checkpoint (--resume): everything the next frame reads, written after each frame's outputs. Keyed by the
  // configuration (run.json without the volatile fields), so a different run never resumes from it.
  nlohmann::json keyJson = runJson;
  keyJson.erase("commandLine");
  keyJson.erase("status");
  keyJson.erase("threads");
  keyJson.erase("simd");  // every target gives the same bits (DESIGN §3)
  const std::string configKey = keyJson.dump();
  const std::string checkpointPath = (std::filesystem::path(opt.outDir) / "checkpoint.bin").string();
  // Everything the next frame reads, in one list for writing and reading.
  auto transferState = [&](auto& io, int& nextFrame) {
    io.Pod(nextFrame);
    TransferGbuffer(io, previous);
    io.Pod(previousState.frame);
    io.Pod(previousState.camera);
    io.Vector(previousState.objectToWorld);
    io.Vector(previousState.lightOn);
    io.Vector(previousLights);
    TransferImage(io, previousReference);
    for (size_t p = 0; p < presets.size(); ++p) {
      TransferImage(io, previousImages[p]);
      TransferImage(io, accumSum[p]);
      for (int k = 0; k < members; ++k) io.Vector(pipelines[p * members + k]->History());
    }
    io.Pod(accumFrames);
    io.Vector(disoccAge);
    TransferRows(io, result.rows);
  };
  auto saveCheckpoint = [&](int nextFrame) {
    BinaryWriter w;
    w.Pod(kCheckpointMagic);
    w.String(configKey);
    transferState(w, nextFrame);
    WriteFileAtomic(checkpointPath, w.Bytes());
  };
  int firstFrame = opt.frameBegin;
  if (opt.resume) {
    std::ifstream f(checkpointPath, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    try {
      BinaryReader r(bytes);
      uint64_t magic = 0;
      std::string key;
      if (!bytes.empty()) r.Pod(magic);
      if (magic == kCheckpointMagic) r.String(key);
      if (magic == kCheckpointMagic && key == configKey) {
        int nextFrame = 0;
        transferState(r, nextFrame);
        if (!r.AtEnd()) throw std::runtime_error("trailing bytes");
        firstFrame = nextFrame;
        result.resumedAtFrame = nextFrame;
        // The scene's current frame becomes the previous one at the next Update, as in an uninterrupted run.
        if (firstFrame > opt.frameBegin) scene.Update(previousState);
      } else if (!bytes.empty()) {
        std::fprintf(stderr, "restir-sim: %s is from another configuration; starting from frame %d\n",
                     checkpointPath.c_str(), opt.frameBegin);
      }
    } catch (const std::runtime_error& e) {
      // Checkpoints are renamed into place whole, so this is outside damage: refuse rather than guess.
      throw InputError(checkpointPath + ": error: unreadable checkpoint (" + e.what() +
                       "); delete it or run without --resume");
    }
  }

  for (int frame = firstFrame; frame < frameEnd; ++frame) {
    const FrameState state = Evaluate(seq, frame, width, height);
    auto t0 = Clock::now();
    scene.Update(state);
    const double msSceneUpdate = MsSince(t0);
    t0 = Clock::now();
    TracePrimary(scene, state.camera, current);
    const double msPrimary = MsSince(t0);
    t0 = Clock::now();
    Reproject(state, previousState, previous, scene.LightObjectId(), ReprojectionParams{}, current);
    const double msReproject = MsSince(t0);
    const double disoccFraction = MaskFraction(current.disoccluded);
    // Age of each pixel's surface since it was revealed, carried through reprojection, so the `*_disocc` metrics
    // follow the revealed region for kDisoccWindow frames (DESIGN §6: "disoccluded in the last 4 frames").
    std::vector<uint16_t> age(current.Size(), kNeverDisoccluded);
    for (size_t i = 0; i < current.Size(); ++i) {
      if (current.disoccluded[i]) {
        age[i] = 0;
      } else if (current.prevValid[i] && !disoccAge.empty()) {
        const int px = std::clamp(static_cast<int>(current.prevX[i]), 0, width - 1);
        const int py = std::clamp(static_cast<int>(current.prevY[i]), 0, height - 1);
        const uint16_t a = disoccAge[static_cast<size_t>(py) * width + px];
        age[i] = a == kNeverDisoccluded ? a : static_cast<uint16_t>(std::min<int>(a + 1, kNeverDisoccluded - 1));
      }
    }
    disoccAge = std::move(age);
    std::vector<uint8_t> recentMask(current.Size());
    for (size_t i = 0; i < current.Size(); ++i) recentMask[i] = disoccAge[i] < kDisoccWindow;
    const double recentFraction = MaskFraction(recentMask);
    std::vector<uint8_t> restMask(current.Size());  // the complement: pixels not revealed in the last 4 frames
    for (size_t i = 0; i < current.Size(); ++i) restMask[i] = !recentMask[i];
    const LightSampler lights(scene.LightTriangles(), LightSelection::kPower);

    const bool hasPrevious = frame > opt.frameBegin;  // true after a resume too: the checkpoint restored it
    const bool stateChanged = !hasPrevious || !SameSceneState(state, previousState);
    accumFrames = stateChanged ? 1 : accumFrames + 1;
    ReferenceImage ref;
    if (showProgress && opt.reference) progress(frame - opt.frameBegin, "reference");
    if (opt.reference) ref = RenderReference(seq, state, scene, current, refParams);
    const double refRelStdErr = opt.reference ? MeanRelativeStandardError(ref) : 0.0;

    for (size_t p = 0; p < presets.size(); ++p) {
      if (showProgress)
        progress(frame - opt.frameBegin, presets[p].name + " (" + std::to_string(p + 1) + "/" +
                                             std::to_string(presets.size()) + ")");
      FrameInputs in;
      in.sequence = &seq;
      in.state = &state;
      in.scene = &scene;
      in.gbuffer = &current;
      in.lights = &lights;
      in.materials = &bsdfs;
      in.seed = seed;
      in.frame = static_cast<uint32_t>(frame);
      if (hasPrevious) {
        in.previousState = &previousState;
        in.previousGbuffer = &previous;
        in.previousLights = &previousLights;
      }
      FrameResult fr = pipelines[p * members]->RenderFrame(in);
      // The other ensemble members, for the bias²/variance split of this frame (DESIGN §6 seed ensembles).
      ImageRgb ensembleBias, ensembleVariance;
      EnsembleStats ens;
      if (members > 1) {
        std::vector<ImageRgb> images;
        images.push_back(fr.image);
        for (int k = 1; k < members; ++k) {
          FrameInputs ink = in;
          ink.seed = seed + static_cast<uint32_t>(k);
          images.push_back(pipelines[p * members + k]->RenderFrame(ink).image);
        }
        ens = MeasureEnsemble(images, ref.mean, ref.standardError, ensembleBias, ensembleVariance);
      }
      if (stateChanged) {
        accumSum[p] = fr.image;
      } else {
        for (size_t i = 0; i < fr.image.Size(); ++i) accumSum[p].pixels[i] += fr.image.pixels[i];
      }

      FrameMetricsRow row;
      row.frame = frame;
      row.preset = presets[p].name;
      double msPasses = 0.0;
      uint64_t rays = static_cast<uint64_t>(current.Size());  // primary rays
      row.values.emplace_back("ms_scene_update", msSceneUpdate);
      row.values.emplace_back("ms_primary", msPrimary);
      row.values.emplace_back("ms_reproject", msReproject);
      // Fixed columns for every preset: a pass the preset does not run reports 0.
      auto findPass = [&](const char* name) -> const PassStats* {
        for (const PassStats& ps : fr.passes)
          if (ps.name == name) return &ps;
        return nullptr;
      };
      for (const char* name : kPassNames) {
        const PassStats* ps = findPass(name);
        row.values.emplace_back(std::string("ms_") + name, ps ? ps->ms : 0.0);
        msPasses += ps ? ps->ms : 0.0;
        rays += ps ? ps->rays : 0;
      }
      row.values.emplace_back("ms_frame", msSceneUpdate + msPrimary + msReproject + msPasses);
      row.values.emplace_back("ms_reference", opt.reference ? ref.ms : 0.0);
      row.values.emplace_back("reference_cached", ref.fromCache ? 1.0 : 0.0);
      row.values.emplace_back("rays", static_cast<double>(rays));
      for (const char* name : kPassNames) {
        const PassStats* ps = findPass(name);
        row.values.emplace_back(std::string("rays_per_pixel_") + name,
                                ps ? double(ps->rays) / double(current.Size()) : 0.0);
      }
      FlipMap flipMap;  // per-pixel HDR-FLIP against the reference (empty without one)
      if (opt.reference) {
        const AccuracyMetrics m = MeasureAccuracy(fr.image, ref.mean);
        flipMap = HdrFlip(ref.mean, fr.image);
        row.values.emplace_back("rmse", m.rmse);
        row.values.emplace_back("luma_rmse", m.lumaRmse);
        row.values.emplace_back("relmse", m.relmse);
        row.values.emplace_back("luma_ratio", m.lumaRatio);
        row.values.emplace_back("rmspe", m.rmspe);
        row.values.emplace_back("flip", MeanFlip(flipMap));
        row.values.emplace_back("luma_sum", m.lumaSum);
        row.values.emplace_back("reference_luma_sum", m.referenceLumaSum);
        row.values.emplace_back("reference_rel_stderr", refRelStdErr);
        ImageRgb mean(width, height);
        for (size_t i = 0; i < mean.Size(); ++i) mean.pixels[i] = accumSum[p].pixels[i] / float(accumFrames);
        const AccuracyMetrics acc = MeasureAccuracy(mean, ref.mean);
        const AccuracyMetrics md = MeasureAccuracy(fr.image, ref.mean, &recentMask);
        row.values.emplace_back("rmse_disocc", md.rmse);
        row.values.emplace_back("luma_rmse_disocc", md.lumaRmse);
        row.values.emplace_back("relmse_disocc", md.relmse);
        row.values.emplace_back("rmspe_disocc", md.rmspe);
        row.values.emplace_back("luma_ratio_disocc", md.pixels ? md.lumaRatio : 1.0);
        row.values.emplace_back("flip_disocc", MeanFlip(flipMap, &recentMask));
        const AccuracyMetrics mr = MeasureAccuracy(fr.image, ref.mean, &restMask);
        row.values.emplace_back("rmse_rest", mr.rmse);
        row.values.emplace_back("luma_rmse_rest", mr.lumaRmse);
        row.values.emplace_back("relmse_rest", mr.relmse);
        row.values.emplace_back("rmspe_rest", mr.rmspe);
        row.values.emplace_back("luma_ratio_rest", mr.pixels ? mr.lumaRatio : 1.0);
        row.values.emplace_back("flip_rest", MeanFlip(flipMap, &restMask));
        row.values.emplace_back("accum_frames", accumFrames);
        row.values.emplace_back("accum_rmse", acc.rmse);
        row.values.emplace_back("accum_luma_ratio", acc.lumaRatio);
        row.values.emplace_back("accum_rmspe", acc.rmspe);
        if (members > 1) {
          row.values.emplace_back("ensemble_mse", ens.mse);
          row.values.emplace_back("ensemble_bias2", ens.bias2);
          row.values.emplace_back("ensemble_variance", ens.variance);
          row.values.emplace_back("ensemble_bias2_noise", ens.bias2Noise);
          row.values.emplace_back("ensemble_luma_ratio", ens.lumaRatio);
          row.values.emplace_back("ensemble_luma_ratio_stderr", ens.lumaRatioStdError);
        }
        row.values.emplace_back("flicker", hasPrevious ? Flicker(fr.image, previousImages[p], ref.mean,
                                                                 previousReference)
                                                       : 0.0);
      }
      row.values.emplace_back("stability_luma_rmse",
                              hasPrevious ? StabilityLumaRmse(fr.image, previousImages[p]) : 0.0);
      row.values.emplace_back("disocc_fraction", disoccFraction);
      row.values.emplace_back("disocc_recent_fraction", recentFraction);
      row.values.emplace_back("temporal_acceptance", fr.temporalAcceptance);
      row.values.emplace_back("mean_confidence", fr.meanConfidence);
      row.values.emplace_back("cross_object_reuse", static_cast<double>(fr.crossObjectReuse));
      row.values.emplace_back("guarded", static_cast<double>(fr.guardedEvents));
      row.imageHash = HexHash(HashImage(fr.image));
      result.rows.push_back(row);

      if (opt.writeImages) {
        char name[32];
        std::snprintf(name, sizeof(name), "%04d", frame);
        const auto dir = std::filesystem::path(opt.outDir) / "frames" / presets[p].name;
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
      previousImages[p] = std::move(fr.image);
    }
    // The CSV is rewritten whole after every frame: it is always complete up to the last finished frame.
    WriteFileAtomic(csvPath, MetricsCsv(result.rows));
    std::swap(current, previous);
    previousState = state;
    previousLights = scene.LightTriangles();
    if (opt.reference) previousReference = std::move(ref.mean);
    saveCheckpoint(frame + 1);
    ++sessionFrames;

    if (showProgress) progress(frame - opt.frameBegin + 1, "done");
  }
  if (showProgress) std::fprintf(stderr, "\n");
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
