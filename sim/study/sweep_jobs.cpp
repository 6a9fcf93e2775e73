// A sweep's jobs and their merge (sim/study/sweep.h). A job's directory is complete when its job.json — written last —
// describes exactly the job the plan asks for; the merge reads only such directories, so it neither waits for nor
// trusts anything else, and a directory left by an edited sweep file or a job killed mid-run counts as missing.
#include <algorithm>
#include <memory>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "sim/util/atomic_file.h"
#include "sim/util/input_file.h"
#include "sim/metrics/metrics_csv.h"
#include "sim/metrics/relative_error_file.h"
#include "sim/metrics/seed_ensemble.h"
#include "sim/util/input_error.h"
#include "sim/metrics/summary.h"
#include "sim/study/sweep.h"

namespace restir {

namespace {

namespace fs = std::filesystem;

constexpr const char* kRelativeErrorFile = "relative_error.bin";

// What makes a job's result this job's: everything that changes its numbers (not its timings).
nlohmann::ordered_json JobDescription(const SweepSpec& spec, const SweepJob& job) {
  const SweepSequence& q = spec.sequences[job.sequence];
  const SweepConfig& c = spec.configs[job.config];
  const RunOptions& b = spec.base;
  return {{"id", job.id},
          {"sequence", q.name},
          {"sequenceContentHash", q.contentHash},
          {"preset", c.preset},
          {"set", c.overrides},
          {"seed", job.seed},
          {"resolution", {b.width, b.height}},
          {"frames", {b.frameBegin, b.frameEnd}},
          {"referenceSpp", b.referenceSpp},
          {"referenceError", b.referenceError},
          {"relativeErrors", q.seeds.size() >= 2},
          // Another build may compute other numbers (a reference or estimator change): its results are not merged.
          {"version", RESTIR_VERSION}};
}

fs::path JobDir(const std::string& outDir, const SweepJob& job) { return fs::path(outDir) / job.dir; }

// The job's metrics.csv as rows, checked against the frame count job.json recorded.
std::vector<FrameMetricsRow> ReadJobRows(const fs::path& dir, const std::string& preset, int frames) {
  const MetricsTable t = ReadMetricsCsv((dir / "metrics.csv").string());
  const PresetSeries* s = t.Preset(preset);
  if (!s || s->frames.size() != size_t(frames) || t.presets.size() != 1)
    throw InputError((dir / "metrics.csv").string() + ": error: not the " + std::to_string(frames) +
                     " frames of preset " + preset + " its job.json records");
  std::vector<FrameMetricsRow> rows(s->frames.size());
  for (size_t k = 0; k < rows.size(); ++k) {
    rows[k].frame = s->frames[k];
    rows[k].preset = preset;
    for (size_t c = 0; c < t.columns.size(); ++c) rows[k].values.emplace_back(t.columns[c], s->values[c][k]);
  }
  return rows;
}

double Column(const FrameMetricsRow& row, const std::string& name) {
  for (const auto& [n, v] : row.values)
    if (n == name) return v;
  return NAN;
}

// The frames job.json records (> 0), or 0 when the directory is not this job's complete result.
int CompleteFrames(const SweepSpec& spec, const SweepJob& job, const std::string& outDir, std::string* why) {
  const fs::path dir = JobDir(outDir, job);
  std::string bytes, problem;
  if (!TryReadRegularFile((dir / "job.json").string(), size_t(1) << 20, bytes, problem)) {
    if (why) *why = problem == "no such file" ? "not run, or not finished" : "job.json: " + problem;
    return 0;
  }
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(bytes, nullptr, false);
  if (!j.is_object() || !j.contains("job") || j["job"] != JobDescription(spec, job) || !j.contains("frames") ||
      !j["frames"].is_number_integer() || j["frames"].get<int64_t>() < 1 || j["frames"].get<int64_t>() > (1 << 20)) {
    if (why) *why = "job.json describes another job (the sweep file or the sequence changed since it ran)";
    return 0;
  }
  return static_cast<int>(j["frames"].get<int64_t>());
}

// Mean of the finite values (NaN for none).
double FiniteMean(const std::vector<double>& v) {
  double sum = 0.0;
  int n = 0;
  for (double x : v)
    if (!std::isnan(x)) sum += x, ++n;
  return n ? sum / n : NAN;
}

struct Resolution {
  int width = 0;   // the job's run.json "resolution"
  int height = 0;
};

// The resolution a job ran at, from its run.json (the relative-error file's size follows from it).
Resolution ReadResolution(const fs::path& dir) {
  const std::string path = (dir / "run.json").string();
  const nlohmann::json j = nlohmann::json::parse(ReadInputFile(path, size_t(1) << 20, "run.json"), nullptr, false);
  const bool ok = j.is_object() && j.contains("resolution") && j["resolution"].is_array() &&
                  j["resolution"].size() == 2 && j["resolution"][0].is_number_integer() &&
                  j["resolution"][1].is_number_integer();
  Resolution r;
  if (ok) r.width = j["resolution"][0].get<int>(), r.height = j["resolution"][1].get<int>();
  if (r.width < 1 || r.height < 1 || r.width > 16384 || r.height > 16384)
    throw InputError(path + ": error: no resolution [width, height] of at most 16384 each");
  return r;
}

// One (sequence, configuration): its completed seeds' summaries combined, and their ensemble split.
SweepPoint MergeSeeds(const SweepSpec& spec, const std::vector<const SweepJob*>& done, const std::string& outDir) {
  const SweepJob& first = *done.front();
  const SweepConfig& config = spec.configs[first.config];
  std::vector<SweepPoint> perSeed;
  std::vector<std::vector<FrameMetricsRow>> rows;
  const int frames = CompleteFrames(spec, first, outDir, nullptr);
  for (const SweepJob* j : done) {
    // The seeds' frames are paired in the split: a job.json claiming other frames than its siblings' is refused.
    if (CompleteFrames(spec, *j, outDir, nullptr) != frames)
      throw InputError((JobDir(outDir, *j) / "job.json").string() + ": error: " +
                       std::to_string(CompleteFrames(spec, *j, outDir, nullptr)) + " frames, its sibling seeds " +
                       std::to_string(frames));
    rows.push_back(ReadJobRows(JobDir(outDir, *j), config.preset, frames));
    perSeed.push_back(Summarize(config, rows.back()));
  }
  SweepPoint p;
  p.sequence = spec.sequences[first.sequence].name;
  p.config = config;
  p.seeds = static_cast<int>(done.size());
  auto mean = [&](double SweepPoint::*field) {
    std::vector<double> v;
    for (const SweepPoint& s : perSeed) v.push_back(s.*field);
    return FiniteMean(v);
  };
  p.relmse = mean(&SweepPoint::relmse);
  p.relmseDisocc = mean(&SweepPoint::relmseDisocc);
  p.flip = mean(&SweepPoint::flip);
  // Every seed has the same reference, so the mean of the seeds' ratios is Σ luma / Σ reference luma over all.
  p.lumaRatio = mean(&SweepPoint::lumaRatio);
  p.flicker = mean(&SweepPoint::flicker);
  p.msPerFrame = mean(&SweepPoint::msPerFrame);
  p.shadowRaysPerPixel = mean(&SweepPoint::shadowRaysPerPixel);
  p.efficiency = Efficiency(p.relmse, p.msPerFrame);
  const int s = p.seeds;
  if (s < 2) return p;
  double ss = 0.0;
  for (const SweepPoint& x : perSeed) ss += (x.relmse - p.relmse) * (x.relmse - p.relmse);
  p.relmseCi95 = StudentT975(s - 1) * std::sqrt(ss / (s - 1) / s);

  // The split reads every seed's relative errors frame by frame.
  const Resolution r = ReadResolution(JobDir(outDir, first));
  std::vector<std::unique_ptr<RelativeErrorFile>> files;
  for (const SweepJob* j : done)
    files.push_back(std::make_unique<RelativeErrorFile>((JobDir(outDir, *j) / kRelativeErrorFile).string(), r.width,
                                                        r.height, frames));
  SeedSplit split(s);
  std::vector<std::vector<float>> values(static_cast<size_t>(s));
  std::vector<const float*> pointers(static_cast<size_t>(s));
  for (int f = 0; f < frames; ++f) {
    for (int k = 0; k < s; ++k) {
      files[size_t(k)]->ReadFrame(f, values[size_t(k)]);
      pointers[size_t(k)] = values[size_t(k)].data();
    }
    // The reference's share of relmse, the same for every seed (the reference has its own seed).
    const double noise = Column(rows[0][size_t(f)], "relmse") - Column(rows[0][size_t(f)], "relmse_corrected");
    split.AddFrame(pointers, values[0].size(), std::isnan(noise) ? 0.0 : noise);
  }
  const SeedSplitResult split95 = split.Result();
  p.bias2 = split95.bias2, p.bias2Ci95 = split95.bias2Ci95, p.variance = split95.variance;
  p.varianceCi95 = split95.varianceCi95;
  return p;
}

}  // namespace

bool SweepJobComplete(const SweepSpec& spec, const SweepJob& job, const std::string& outDir, std::string* why) {
  const int frames = CompleteFrames(spec, job, outDir, why);
  if (frames == 0) return false;
  // Everything the merge will read, read now: a damaged job is missing (so --plan --missing lists it and a
  // resubmission reruns it), never a merge that stops at it.
  const fs::path dir = JobDir(outDir, job);
  try {
    ReadJobRows(dir, spec.configs[job.config].preset, frames);
    if (spec.sequences[job.sequence].seeds.size() >= 2) {
      const Resolution r = ReadResolution(dir);
      const RelativeErrorFile file((dir / kRelativeErrorFile).string(), r.width, r.height, frames);
      std::vector<float> values;
      for (int f = 0; f < frames; ++f) file.ReadFrame(f, values);
    }
  } catch (const InputError& e) {
    if (why) *why = e.what();
    return false;
  }
  return true;
}

void RunSweepJob(const SweepSpec& spec, const SweepJob& job, const std::string& outDir) {
  const SweepSequence& q = spec.sequences[job.sequence];
  const SweepConfig& c = spec.configs[job.config];
  const fs::path dir = JobDir(outDir, job);
  // A rerun first withdraws the old marker: until it finishes, the directory is not a complete result.
  std::error_code ec;
  fs::remove(dir / "job.json", ec);
  RunOptions o = spec.base;
  o.sequencePath = q.path;
  o.seed = job.seed;
  o.presets = {c.preset};
  o.settings = c.overrides;
  o.outDir = dir.string();
  o.resume = false;
  o.commandLine = spec.base.commandLine + " [sweep job " + job.id + "]";
  if (q.seeds.size() >= 2) o.relativeErrorPath = (dir / kRelativeErrorFile).string();
  const RunResult r = Run(o);
  const nlohmann::ordered_json marker = {{"job", JobDescription(spec, job)},
                                         {"frames", r.rows.size()},
                                         {"wallSeconds", r.wallSeconds}};
  WriteFileAtomic((dir / "job.json").string(), marker.dump(2) + "\n");
}

SweepMerge MergeSweep(const SweepSpec& spec, const std::string& outDir) {
  const std::vector<SweepJob> jobs = PlanSweep(spec);
  SweepMerge m;
  m.jobs = jobs.size();
  // Jobs are planned sequence, configuration, seed: each (sequence, configuration) is a run of consecutive jobs.
  for (size_t k = 0; k < jobs.size();) {
    size_t e = k;
    while (e < jobs.size() && jobs[e].sequence == jobs[k].sequence && jobs[e].config == jobs[k].config) ++e;
    std::vector<const SweepJob*> done;
    for (size_t i = k; i < e; ++i) {
      std::string why;
      if (SweepJobComplete(spec, jobs[i], outDir, &why)) {
        done.push_back(&jobs[i]);
      } else {
        m.missing.push_back(jobs[i].id);
        m.missingWhy.push_back(why);
      }
    }
    if (!done.empty()) m.points.push_back(MergeSeeds(spec, done, outDir));
    k = e;
  }
  MarkPareto(m.points);
  WriteFileAtomic((fs::path(outDir) / "sweep.csv").string(), SweepCsv(m.points));
  for (const SweepSequence& q : spec.sequences) {
    const std::string name = spec.sequences.size() == 1 ? "sweep.svg" : "sweep-" + q.name + ".svg";
    WriteFileAtomic((fs::path(outDir) / name).string(), SweepSvg(m.points, q.name));
  }
  WriteFileAtomic((fs::path(outDir) / "sweep.md").string(), SweepMarkdown(spec, m));
  return m;
}

SweepMerge RunSweep(const SweepSpec& spec, const std::string& outDir) {
  const std::vector<SweepJob> jobs = PlanSweep(spec);
  for (const SweepJob& j : jobs) {
    std::fprintf(stderr, "sweep: job %zu/%zu %s\n", j.index + 1, jobs.size(), j.id.c_str());
    RunSweepJob(spec, j, outDir);
  }
  return MergeSweep(spec, outDir);
}

}  // namespace restir
