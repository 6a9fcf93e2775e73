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
#include "sim/output/scrub_frames.h"
#include "sim/run/run_stages.h"
#include "sim/reference/reference.h"
#include "sim/output/report.h"
#include "sim/scene/sequence.h"
#include "sim/estimator/settings.h"
#include "sim/metrics/relative_error_file.h"
#include "sim/metrics/seed_ensemble.h"

namespace restir {
namespace run_stages {

namespace {

std::shared_ptr<FrameImageInputs> SnapshotImageInputs(const ReferenceImage& ref, bool hasReference,
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

// "RSTRCKTB" (B: ReSTIR GI's held vertices compact, sim/estimator/pipeline.h HeldVertex; A: ReSTIR GI's reservoirs
// and vertices; 9: the scrub PNGs' exposure)
constexpr uint64_t kCheckpointMagic = 0x42544B43'52545352ull;

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

// The light transport the run's presets model (indirect.bounces), which its one reference must model too: a preset
// that models another is refused, as its errors against that reference would measure the difference.
int RunIndirectBounces(const std::vector<Preset>& presets) {
  if (presets.empty()) return 0;
  const Preset& first = presets.front();
  for (const Preset& p : presets)
    if (p.settings.indirect.bounces != first.settings.indirect.bounces)
      throw InputError("--preset: error: presets '" + first.name + "' (indirect.bounces=" +
                       std::to_string(first.settings.indirect.bounces) + ") and '" + p.name + "' (indirect.bounces=" +
                       std::to_string(p.settings.indirect.bounces) +
                       ") model different light; a run measures its presets against one reference, so they must "
                       "agree (--set indirect.bounces=N sets every preset's)");
  return first.settings.indirect.bounces;
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
  for (const Preset& p : presets) {
    shape.indirectPresets += p.settings.indirect.bounces > 0;
    shape.reusedIndirectPresets += p.settings.indirect.bounces > 0 && p.settings.indirect.reuse;
  }
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

// The reference's sampling: a budget given on the command line wins, then an error target given there, then the
// sequence's error target, then its budget. A cap applies to an error target only.
ReferenceParams ReferenceParamsFor(const RunOptions& opt, const RenderDefaults& defaults) {
  ReferenceParams params;
  params.samplesPerPixel = opt.referenceSpp > 0 ? opt.referenceSpp : defaults.referenceSpp;
  if (opt.referenceSpp <= 0) {
    params.targetRelativeError = opt.referenceError > 0.0 ? opt.referenceError : defaults.referenceError;
    if (params.targetRelativeError > 0.0)
      params.maxMeanSamplesPerPixel = opt.referenceSppCap > 0 ? opt.referenceSppCap : defaults.referenceSppCap;
  }
  return params;
}

// The frames of begin..end-1 that `images` selects for an EXR and a preview: a range adds to the report's three
// (the report shows those); a range that holds none of the run's frames is an InputError, as --frames's is.
std::vector<int> FrameFileFrames(const ImageFrames& images, int begin, int end) {
  std::vector<int> all;
  for (int f = begin; f < end; ++f) all.push_back(f);
  switch (images.kind) {
    case ImageFrames::Kind::kReport: return ReportStripFrames(all);
    case ImageFrames::Kind::kAll: return all;
    case ImageFrames::Kind::kRange: break;
  }
  const auto inRange = [&](int f) { return f >= images.begin && (images.end < 0 || f < images.end); };
  if (std::none_of(all.begin(), all.end(), inRange))
    throw InputError("--images: error: " + ImageFramesName(images) + " holds none of the run's frames " +
                     std::to_string(begin) + ":" + std::to_string(end));
  std::vector<int> chosen = ReportStripFrames(all);
  for (int f : all)
    if (inRange(f)) chosen.push_back(f);
  std::sort(chosen.begin(), chosen.end());
  chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
  return chosen;
}

// run.json as the run starts, so an interrupted run still says what it was.
nlohmann::json RunJson(const RunOptions& opt, const Sequence& seq, const RunPlan& plan) {
  const ReferenceParams& refParams = plan.refParams;
  nlohmann::json runJson = {
      {"program", "restir-sim"},
      {"version", RESTIR_VERSION},
      {"commandLine", opt.commandLine},
      {"sequence",
       {{"path", opt.sequencePath}, {"name", seq.name}, {"contentHash", seq.contentHash}, {"frameRate", seq.frameRate}}},
      {"resolution", {plan.width, plan.height}},
      {"frames", {opt.frameBegin, plan.frameEnd}},
      {"seed", plan.seed},
      {"ensemble", plan.members},
      {"simd", ActiveSimdTargetName()},
      {"embreeIsa", EmbreeIsaName(ActiveEmbreeIsa())},
      {"threads", plan.threads},
      {"exrCompression", opt.writeImages ? nlohmann::json(ExrCompressionName(opt.exrCompression)) : nullptr},
      {"reference", opt.reference ? nlohmann::json{{"samplesPerPixel", refParams.samplesPerPixel},
                                                    {"targetRelativeError", refParams.targetRelativeError},
                                                    {"sppCap", refParams.maxMeanSamplesPerPixel},
                                                    {"indirectBounces", refParams.indirectBounces},
                                                    {"cacheDir", refParams.cacheDir}}
                                  : nlohmann::json(nullptr)},
      {"status", "running"}};
  // Which frames have files: part of the configuration, so a resume with another --images starts again.
  runJson["images"] = opt.writeImages ? nlohmann::json{{"selection", ImageFramesName(opt.imageFrames)},
                                                       {"frameFiles", plan.frameFileFrames},
                                                       {"scrub", "every frame (scrub/)"}}
                                      : nlohmann::json(nullptr);
  for (const Preset& p : plan.presets)
    runJson["presets"][p.name] = {{"source", p.source}, {"settings", SettingsJson(p.settings)}};
  runJson["overrides"] = opt.settings;
  return runJson;
}

// What the reference cost where it was rendered: its rays (shadow rays and, on glossy pixels, BSDF rays) per
// second of its wall time, to set beside the ray floor of docs/performance.md.
nlohmann::json ReferenceThroughputJson(const ReferenceTally& refRendered, int width, int height) {
  return {
      {"framesRendered", refRendered.frames},
      {"framesFromCache", refRendered.cachedFrames},
      {"rays", refRendered.rays},
      {"samples", refRendered.samples},
      {"seconds", refRendered.ms / 1000.0},
      {"raysPerSecond", refRendered.ms > 0.0 ? double(refRendered.rays) / (refRendered.ms / 1000.0) : 0.0},
      {"samplesPerPixel", refRendered.frames > 0
                              ? double(refRendered.samples) / (double(width) * height * refRendered.frames)
                              : 0.0}};
}

// Which frames' references stopped at their sample cap short of the error target, read from the kept rows (so a
// resumed run counts the frames before its checkpoint too): one row per frame, the first preset's.
nlohmann::json ReferenceCappedJson(const std::vector<FrameMetricsRow>& rows) {
  nlohmann::json frames = nlohmann::json::array();
  std::string firstPreset;
  for (const FrameMetricsRow& r : rows) {
    if (firstPreset.empty()) firstPreset = r.preset;
    if (r.preset != firstPreset) continue;
    for (const auto& [name, value] : r.values)
      if (name == "reference_capped" && value > 0.0) frames.push_back(r.frame);
  }
  return {{"frames", frames}, {"count", frames.size()}};
}

// The other ensemble members, for the bias²/variance split of this frame (DESIGN §6 seed ensembles).
void RenderEnsemble(RunContext& run, const RunFrame& f, PresetState& ps, PresetFrame& pf,
                    InitialSamplingShare* share) {
  std::vector<ImageRgb> images;
  images.push_back(pf.fr.image);
  for (int k = 1; k < run.plan.members; ++k) {
    FrameInputs memberInputs = run.loop.Inputs(run.plan.seed + static_cast<uint32_t>(k));
    memberInputs.initialShare = share;
    images.push_back(run.loop.RenderPreset(*ps.members[k], memberInputs).image);
  }
  // The members' running means, for the converged image's RMSPE (seed 000 Fig. 2); member 0's is accumSum.
  if (run.plan.members >= 3) {
    for (size_t k = 1; k < images.size(); ++k) {
      ImageRgb& sum = ps.memberAccumSums[k - 1];
      if (f.stateChanged) {
        sum = images[k];
      } else {
        for (size_t i = 0; i < sum.Size(); ++i) sum.pixels[i] += images[k].pixels[i];
      }
    }
  }
  pf.ensemble =
      MeasureEnsemble(images, f.ref.mean, f.ref.standardError, pf.ensembleBias, pf.ensembleVariance);
}

// One preset's frame files (its EXR and preview when the frame has them) and its scrub PNGs, handed to the
// background writer.
void SubmitPresetFiles(RunContext& run, const RunFrame& f, const std::string& preset, PresetFrame& pf) {
  const std::string name = FrameNumber(f.frame);
  const auto stem = std::filesystem::path(run.opt.outDir) / "frames" / preset / name;
  // The job owns what it writes: this preset's images (the estimate and FLIP map copied, as MeasurePresets
  // reads them; the ensemble images moved) and the frame's shared inputs. Submitted now, so the writer
  // works while the next preset renders.
  auto images = std::make_shared<const PresetImages>(PresetImages{
      pf.fr.image, pf.flipMap.values, std::move(pf.ensembleBias), std::move(pf.ensembleVariance)});
  const std::string relative = "frames/" + preset + "/" + name;
  run.imageWriter->Submit([stem, relative, images, preset, frame = f.frame, frameInputs = f.imageInputs,
                           exposure = run.state.scrubExposure, outDir = run.opt.outDir,
                           compression = run.opt.exrCompression, written = &run.written] {
    if (frameInputs->frameFiles) {
      WritePresetFiles(stem.string(), *images, *frameInputs, compression);
      for (const char* extension : {".exr", ".png"}) written->Record(relative + extension);
    }
    const ImageRgb* reference = frameInputs->hasReference ? &frameInputs->reference : nullptr;
    const std::vector<float>* flip = frameInputs->hasReference ? &images->flip : nullptr;
    for (const std::string& path :
         WriteScrubPreset(outDir, preset, frame, images->estimate, reference, flip, exposure))
      written->Record(path);
  });
}

// The frame's shared scrub PNGs (the reference and the disocclusion mask), handed to the background writer.
void SubmitFrameScrub(RunContext& run, const RunFrame& f) {
  if (f.imageInputs->hasReference && run.state.scrubExposure <= 0.0f)
    run.state.scrubExposure = PreviewExposure(f.imageInputs->reference);
  run.imageWriter->Submit([frame = f.frame, frameInputs = f.imageInputs, recent = f.recentMask,
                           exposure = run.state.scrubExposure, outDir = run.opt.outDir, written = &run.written] {
    const GBuffer& g = frameInputs->gbuffer;
    const ImageRgb* reference = frameInputs->hasReference ? &frameInputs->reference : nullptr;
    for (const std::string& path :
         WriteScrubFrame(outDir, frame, g.width, g.height, reference, exposure, g.disoccluded, recent))
      written->Record(path);
  });
}

}  // namespace

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

template <typename Io>
void RunState::Transfer(Io& io, int& nextFrame) {
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
    for (ImageRgb& sum : p->memberAccumSums) TransferImage(io, sum);
    for (auto& member : p->members) {
      io.Vector(member->History());
      io.Vector(member->IndirectHistory());
      io.Vector(member->IndirectVertices());
    }
  }
  io.Pod(accumFrames);
  io.Pod(scrubExposure);
  TransferRows(io, rows);
  InPresetOrder(rows);
}

void RunState::InPresetOrder(std::vector<FrameMetricsRow>& restored) const {
  auto rank = [&](const FrameMetricsRow& r) {
    for (size_t i = 0; i < presets.size(); ++i)
      if (presets[i].preset.name == r.preset) return i;
    return presets.size();
  };
  std::stable_sort(restored.begin(), restored.end(), [&](const FrameMetricsRow& a, const FrameMetricsRow& b) {
    return a.frame != b.frame ? a.frame < b.frame : rank(a) < rank(b);
  });
}

// The checkpoint (--resume) is keyed by the configuration: run.json without the fields that do not change the
// results, so a different run never resumes from it.
std::string ConfigurationKey(nlohmann::json runJson) {
  // exrCompression changes the EXRs' bytes, never their pixels, like the thread count their timing.
  for (const char* volatileField :
       {"commandLine", "status", "threads", "simd", "exrCompression", "wallSeconds", "referenceThroughput",
        "referenceCapped", "outputs"})
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

RunPlan PlanRun(const RunOptions& opt, const Sequence& seq) {
  RunPlan plan;
  plan.width = opt.width > 0 ? opt.width : seq.width;
  plan.height = opt.height > 0 ? opt.height : seq.height;
  plan.frameEnd = opt.frameEnd < 0 ? seq.frameCount : opt.frameEnd;
  if (opt.frameBegin < 0 || opt.frameBegin >= plan.frameEnd || plan.frameEnd > seq.frameCount)
    throw InputError(opt.sequencePath + ": error: frame range " + std::to_string(opt.frameBegin) + ":" +
                     std::to_string(plan.frameEnd) + " is outside the sequence's frames 0:" +
                     std::to_string(seq.frameCount));
  plan.seed = opt.seed.value_or(seq.seed);
  // The ensemble's split needs a reference, so without one the other members would be rendered for nothing.
  plan.members = opt.reference ? std::max(1, opt.ensemble) : 1;
  plan.presets = ResolvePresets(opt, seq);
  if (!opt.relativeErrorPath.empty() && (plan.presets.size() != 1 || !opt.reference || opt.resume))
    throw InputError(opt.relativeErrorPath + ": error: relative-error frames need one preset, a reference and no "
                     "--resume");
  plan.refParams = ReferenceParamsFor(opt, seq.defaults);
  plan.refParams.cacheDir = opt.cacheDir;
  plan.refParams.indirectBounces = RunIndirectBounces(plan.presets);
  CheckRunMemory(opt, seq, plan.refParams, plan.width, plan.height, plan.frameEnd - opt.frameBegin,
                 plan.presets, plan.members);
  plan.threads = opt.threads > 0 ? opt.threads : tbb::info::default_concurrency();
  if (opt.writeImages) plan.frameFileFrames = FrameFileFrames(opt.imageFrames, opt.frameBegin, plan.frameEnd);
  plan.runJson = RunJson(opt, seq, plan);
  plan.runJsonPath = (std::filesystem::path(opt.outDir) / "run.json").string();
  plan.csvPath = (std::filesystem::path(opt.outDir) / "metrics.csv").string();
  plan.checkpointPath = (std::filesystem::path(opt.outDir) / "checkpoint.bin").string();
  plan.configKey = ConfigurationKey(plan.runJson);
  return plan;
}

bool CompleteRunIntact(const RunOptions& opt, const RunPlan& plan) {
  std::vector<OutputFile> completeOutputs;
  return CompleteRunExists(plan.runJsonPath, plan.configKey, completeOutputs) &&
         !ReportDamagedOutputs(opt.outDir, completeOutputs, opt.frameBegin);
}

std::vector<PresetState> MakePresetStates(const RunPlan& plan) {
  std::vector<PresetState> presets;
  for (const Preset& p : plan.presets) {
    PresetState& ps = presets.emplace_back();
    ps.preset = p;
    ps.sharesInitialPass = SharesInitialPass(plan.presets, presets.size() - 1);
    for (int k = 0; k < plan.members; ++k) ps.members.push_back(std::make_unique<Pipeline>(p.settings));
    if (plan.members >= 3) ps.memberAccumSums.resize(plan.members - 1);
  }
  return presets;
}

void StartFrame(RunContext& run, int frame, RunFrame& f) {
  f.frame = frame;
  f.recentMask = RecentDisocclusionMask(run.loop.DisocclusionAge());
  f.restMask.assign(f.recentMask.size(), 0);
  for (size_t i = 0; i < f.recentMask.size(); ++i) f.restMask[i] = !f.recentMask[i];
  f.hasPrevious = frame > run.opt.frameBegin;
  f.stateChanged = !f.hasPrevious || !SameSceneState(run.loop.State(), run.loop.PreviousState());
  run.state.accumFrames = f.stateChanged ? 1 : run.state.accumFrames + 1;
}

void RenderFrameReference(RunContext& run, RunFrame& f) {
  run.progress.Show(f.frame - run.opt.frameBegin, "reference");
  f.ref = run.loop.Reference(run.plan.refParams);
  ReferenceTally& refRendered = run.refRendered;
  if (!f.ref.fromCache) {
    refRendered.frames += 1;
    refRendered.rays += f.ref.rays;
    refRendered.samples += f.ref.samples;
    refRendered.ms += f.ref.ms;
  } else {
    refRendered.cachedFrames += 1;
  }
}

void PrepareSharedInputs(RunContext& run, RunFrame& f) {
  // What this frame's image files read after the loop has moved on: the reference (moved into
  // previousReference at the frame's end) and the G-buffer layers the EXR shows (the loop reuses its buffers).
  if (run.opt.writeImages) {
    auto inputs =
        SnapshotImageInputs(f.ref, run.opt.reference, run.loop.Gbuffer(), run.loop.GetSequence().contentHash);
    inputs->frameFiles = std::binary_search(run.plan.frameFileFrames.begin(), run.plan.frameFileFrames.end(), f.frame);
    f.imageInputs = std::move(inputs);
    SubmitFrameScrub(run, f);
  }
  // FLIP's work on the reference (its exposures, filtered planes, colours and features) once per frame, not
  // once per preset.
  if (run.opt.reference) f.flipReference.emplace(f.ref.mean);
}

// Each preset's frame: rendered and FLIP'd preset by preset (each of those parallel inside), then measured
// for all presets at once (MeasurePresets), then written in preset order (KeepRows).
void RenderPresets(RunContext& run, RunFrame& f) {
  std::vector<PresetState>& presets = run.state.presets;
  f.work.resize(presets.size());
  // Without a reference the run's one exposure comes from its first frame's estimate of the preset whose name sorts
  // first, not of the first given (a resume may give them in another order): that frame's files wait for it.
  const bool exposureDue = run.opt.writeImages && run.state.scrubExposure <= 0.0f;
  for (size_t p = 0; p < presets.size(); ++p) {
    PresetState& ps = presets[p];
    PresetFrame& pf = f.work[p];
    run.progress.Show(f.frame - run.opt.frameBegin,
                      ps.preset.name + " (" + std::to_string(p + 1) + "/" + std::to_string(presets.size()) + ")");
    FrameInputs inputs = run.loop.Inputs(run.plan.seed);
    inputs.measureReservoirs = true;
    inputs.diagnosticsRegion = &f.recentMask;
    InitialSamplingShare* share = ps.sharesInitialPass ? &f.initialShare : nullptr;
    inputs.initialShare = share;
    pf.fr = run.loop.RenderPreset(*ps.members[0], inputs);
    if (run.plan.members > 1) RenderEnsemble(run, f, ps, pf, share);
    if (run.opt.reference) pf.flipMap = HdrFlip(*f.flipReference, pf.fr.image);
    if (run.opt.writeImages && !exposureDue) SubmitPresetFiles(run, f, ps.preset.name, pf);
  }
  if (!exposureDue) return;
  size_t first = 0;
  for (size_t p = 1; p < presets.size(); ++p)
    if (presets[p].preset.name < presets[first].preset.name) first = p;
  run.state.scrubExposure = PreviewExposure(f.work[first].fr.image);
  for (size_t p = 0; p < presets.size(); ++p) SubmitPresetFiles(run, f, presets[p].preset.name, f.work[p]);
}

// A preset per task (MeasureFrame sums in pixel order, serially: the same bits whatever the thread count).
void MeasurePresets(RunContext& run, RunFrame& f) {
  const RunOptions& opt = run.opt;
  const FrameLoop& loop = run.loop;
  const ReferenceImage& ref = f.ref;
  const int accumFrames = run.state.accumFrames;
  const double referenceRelStdError = opt.reference ? MeanRelativeStandardError(ref) : 0.0;
  tbb::parallel_for(size_t{0}, run.state.presets.size(), [&](size_t p) {
    PresetState& ps = run.state.presets[p];
    PresetFrame& pf = f.work[p];
    const FrameResult& fr = pf.fr;
    if (f.stateChanged) {
      ps.accumSum = fr.image;
    } else {
      for (size_t i = 0; i < fr.image.Size(); ++i) ps.accumSum.pixels[i] += fr.image.pixels[i];
    }
    ImageRgb accumMean(run.plan.width, run.plan.height);
    for (size_t i = 0; i < accumMean.Size(); ++i) accumMean.pixels[i] = ps.accumSum.pixels[i] / float(accumFrames);

    FrameMeasurement m;
    m.frame = f.frame;
    m.preset = ps.preset.name;
    m.msSceneUpdate = loop.Timings().sceneUpdate;
    m.msPrimary = loop.Timings().primary;
    m.msReproject = loop.Timings().reproject;
    m.passes = &fr.passes;
    m.image = &fr.image;
    m.previousImage = f.hasPrevious ? &ps.previousImage : nullptr;
    m.guarded = fr.guardedEvents;
    m.temporalAcceptance = fr.temporalAcceptance;
    m.diagnostics = fr.diagnostics;
    m.indirectDiagnostics = fr.indirectDiagnostics ? &*fr.indirectDiagnostics : nullptr;
    m.indirectSpatial = fr.indirectSpatial ? &*fr.indirectSpatial : nullptr;
    m.crossObjectReuse = fr.crossObjectReuse;
    m.disoccFraction = MaskFraction(loop.Gbuffer().disoccluded);
    m.recentFraction = MaskFraction(f.recentMask);
    if (opt.reference) {
      m.reference = &ref.mean;
      m.msReference = ref.ms;
      m.referenceCached = ref.fromCache;
      m.referenceRelStdError = referenceRelStdError;
      m.referenceSpp = ref.allocation.meanSamplesPerPixel;
      m.referenceCapped = ref.allocation.scale < 1.0;
      m.referenceNoise = ReferenceNoise{&ref.standardError, &ref.lumaStandardError};
      m.previousReference = &run.state.previousReference;
      m.flip = &pf.flipMap;
      m.recentMask = &f.recentMask;
      m.restMask = &f.restMask;
      m.accumulatedMean = &accumMean;
      m.accumFrames = accumFrames;
      if (run.plan.members > 1) m.ensemble = &pf.ensemble;
      if (run.plan.members >= 3) {
        std::vector<const ImageRgb*> sums{&ps.accumSum};
        for (const ImageRgb& sum : ps.memberAccumSums) sums.push_back(&sum);
        pf.converged = MeasureConvergedRmspe(sums, accumFrames, ref.mean, ref.lumaStandardError);
        m.converged = &pf.converged;
      }
    }
    pf.row = MeasureFrame(m);
  });
}

void KeepRows(RunContext& run, RunFrame& f) {
  for (size_t p = 0; p < run.state.presets.size(); ++p) {
    PresetFrame& pf = f.work[p];
    run.state.rows.push_back(std::move(pf.row));
    if (run.relativeErrors) {
      std::vector<float> e;
      AppendRelativeError(pf.fr.image, f.ref.mean, e);
      run.relativeErrors->Write(EncodeRelativeErrorFrame(e));
    }
    run.state.presets[p].previousImage = std::move(pf.fr.image);
  }
}

// The CSV is rewritten whole after every frame: it is always complete up to the last finished frame. It may
// lead the frame files by the jobs the writer holds (a failed one is reported here or at the next Submit);
// the checkpoint never does.
void WriteMetricsCsv(RunContext& run) {
  if (run.imageWriter) run.imageWriter->Check();
  WriteFileAtomic(run.plan.csvPath, MetricsCsv(run.state.rows));
}

void CheckpointIfDue(RunContext& run, int frame, CheckpointClock& clock) {
  if (!clock.written || run.opt.checkpointSeconds <= 0.0 ||
      std::chrono::duration<double>(Clock::now() - clock.last).count() >= run.opt.checkpointSeconds) {
    if (run.imageWriter) run.imageWriter->Drain();  // a resume starts after this frame: its images must be on disk
    SaveCheckpoint(run.plan.checkpointPath, run.plan.configKey, run.written, run.state, frame + 1);
    clock.last = Clock::now();
    clock.written = true;
  }
}

void FinishRun(RunContext& run, Clock::time_point start, RunResult& result) {
  const RunOptions& opt = run.opt;
  if (run.imageWriter) run.imageWriter->Drain();
  run.progress.Finish();
  result.wallSeconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::error_code ec;
  std::filesystem::remove(run.plan.checkpointPath, ec);  // a finished run needs no checkpoint
  nlohmann::json& runJson = run.plan.runJson;
  runJson["status"] = "complete";
  runJson["wallSeconds"] = result.wallSeconds;
  if (opt.writeImages) runJson["outputs"] = OutputFilesJson(run.written.Files());
  if (opt.reference) {
    runJson["referenceThroughput"] =
        ReferenceThroughputJson(run.refRendered, run.plan.width, run.plan.height);
    runJson["referenceCapped"] = ReferenceCappedJson(run.state.rows);
  }
  if (run.relativeErrors) run.relativeErrors->Commit();
  WriteFileAtomic(run.plan.runJsonPath, runJson.dump(2) + "\n");
  if (opt.report) WriteReport(opt.outDir);
}

}  // namespace run_stages

std::optional<ImageFrames> ParseImageFrames(const std::string& text) {
  ImageFrames f;
  if (text == "report") return f;
  if (text == "all") {
    f.kind = ImageFrames::Kind::kAll;
    return f;
  }
  const size_t colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos) return std::nullopt;
  auto side = [](const std::string& s, int empty) -> std::optional<int> {
    if (s.empty()) return empty;
    if (s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
    return std::stoi(s);
  };
  const std::optional<int> a = side(text.substr(0, colon), 0), b = side(text.substr(colon + 1), -1);
  if (!a || !b || (*b >= 0 && *b <= *a)) return std::nullopt;
  f.kind = ImageFrames::Kind::kRange;
  f.begin = *a;
  f.end = *b;
  return f;
}

std::string ImageFramesName(const ImageFrames& f) {
  switch (f.kind) {
    case ImageFrames::Kind::kReport: return "report";
    case ImageFrames::Kind::kAll: return "all";
    case ImageFrames::Kind::kRange: break;
  }
  return std::to_string(f.begin) + ":" + (f.end < 0 ? std::string() : std::to_string(f.end));
}

RunResult Run(const RunOptions& opt) {
  using namespace run_stages;
  const auto tRun = Clock::now();
  const Sequence seq = LoadSequence(opt.sequencePath);
  RunPlan plan = PlanRun(opt, seq);
  RunResult result;
  // Resuming a finished run has nothing to do, and must not start it again beside its own summary.
  // Unless a file it wrote has gone or changed since: then it renders again to write it.
  if (opt.resume && CompleteRunIntact(opt, plan)) {
    result.alreadyComplete = true;
    // run.json says complete before the report is made (the report shows it), so a run stopped while its videos
    // were encoded is complete without a report: make it now.
    if (opt.report && (!std::filesystem::exists(std::filesystem::path(opt.outDir) / "report.html") ||
                       !std::filesystem::exists(std::filesystem::path(opt.outDir) / "summary.json"))) {
      WriteReport(opt.outDir);
      result.reportWritten = true;
    }
    return result;
  }

  const TemporaryRoot outputTemporaries(opt.outDir);
  CheckWritableDirectory(opt.outDir, "output directory");
  std::optional<TemporaryRoot> cacheTemporaries;
  if (opt.reference && !opt.cacheDir.empty()) {
    cacheTemporaries.emplace(opt.cacheDir);
    CheckWritableDirectory(opt.cacheDir, "reference cache directory");
  }
  tbb::global_control threadLimit(tbb::global_control::max_allowed_parallelism,
                                  static_cast<size_t>(plan.threads));
  if (opt.writeImages) SetExrThreads(plan.threads);
  WriteFileAtomic(plan.runJsonPath, plan.runJson.dump(2) + "\n");

  // opt.relativeErrorPath, written frame by frame (a long run's would not fit in memory twice).
  std::optional<AtomicFileWriter> relativeErrors;
  if (!opt.relativeErrorPath.empty()) {
    relativeErrors.emplace(opt.relativeErrorPath);
    relativeErrors->Write(EncodeRelativeErrorHeader(plan.width, plan.height, plan.frameEnd - opt.frameBegin));
  }
  std::vector<PresetState> presets = MakePresetStates(plan);
  FrameLoop loop(seq, plan.width, plan.height);
  ImageRgb previousReference;
  int accumFrames = 0;
  float scrubExposure = 0.0f;
  RunState state{loop, presets, previousReference, accumFrames, result.rows, scrubExposure};
  // Declared before the image writer, whose jobs record into it.
  OutputManifest written(opt.outDir);
  const int firstFrame =
      opt.resume ? LoadCheckpoint(plan.checkpointPath, plan.configKey, opt.outDir, written, state, opt.frameBegin)
                 : opt.frameBegin;
  if (firstFrame > opt.frameBegin) result.resumedAtFrame = firstFrame;
  ProgressBar progress(opt.progress, seq.name, plan.frameEnd - opt.frameBegin, opt.progressSeconds);
  ReferenceTally refRendered;  // the references this run rendered (not read from the cache), for run.json
  CheckpointClock checkpoints;
  // Frame images are encoded and written on a thread of their own while the next preset renders. Declared after
  // outputTemporaries, so it stops (and its temporaries are cleaned) before them; drained wherever the files must
  // exist: before a checkpoint (it says the frames before it are done) and at the end.
  std::optional<BackgroundWriter> imageWriter;
  if (opt.writeImages) imageWriter.emplace(size_t{kImageJobsWaiting});  // sim/run/memory_estimate.h
  RunContext run{opt, plan, loop, state, progress, refRendered, written, imageWriter ? &*imageWriter : nullptr,
                 relativeErrors ? &*relativeErrors : nullptr};
  // The frame in flight: what its stages hand each other, kept until its checkpoint is written (the memory
  // estimate counts the frame's inputs beside the checkpoint, sim/run/memory_estimate.cpp).
  std::optional<RunFrame> current;
  loop.Play(
      firstFrame, plan.frameEnd,
      [&](int frame) {
        RunFrame& f = current.emplace();
        StartFrame(run, frame, f);
        if (opt.reference) RenderFrameReference(run, f);
        PrepareSharedInputs(run, f);
        RenderPresets(run, f);
        MeasurePresets(run, f);
        KeepRows(run, f);
        WriteMetricsCsv(run);
      },
      [&](int frame) {  // the frame is now the loop's previous one: what a checkpoint saves
        if (opt.reference) previousReference = std::move(current->ref.mean);
        CheckpointIfDue(run, frame, checkpoints);
        progress.FrameDone();
        progress.Show(frame - opt.frameBegin + 1, "done");
        current.reset();
      });
  FinishRun(run, tRun, result);
  return result;
}

}  // namespace restir
