// `restir-sim sweep SWEEP.json`: a study — configurations (presets × a settings grid, and explicit ones) × sequences
// × seeds — run as independent jobs and merged into reports of error against cost (DESIGN §9: speed against
// error): sweep.csv, a Pareto plot of relmse against ms per frame per sequence, and equal-time, equal-sample and
// seed-ensemble tables (sweep.md). docs/sweep-format.md describes the file; docs/cluster.md how to run the jobs
// on a Slurm cluster.
//
// Why jobs: each (sequence, configuration, seed) is one `run` that depends on nothing else, and a run's bits do
// not depend on the machine or thread count (DESIGN §3), so the jobs can run anywhere, in any order, and the
// merge — which reads only what the jobs wrote — equals the one-process sweep byte for byte except timings.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/run/runner.h"

namespace restir {

// One configuration of a sweep: a preset and the settings changed from it.
struct SweepConfig {
  std::string name;                    // unique, names its run directories OUT/runs/<sequence>/<name>/
  std::string preset;                  // a preset name (restir-sim presets)
  std::vector<std::string> overrides;  // KEY=VALUE, applied in order (as --set)
};

// One sequence of a sweep.
struct SweepSequence {
  std::string name;         // the file's stem, unique in the sweep: names its run directories and table rows
  std::string path;         // the sequence file (relative to the sweep file when written so, resolved here)
  std::string contentHash;  // the sequence's content hash: a job done on other content is not merged
  std::vector<uint32_t> seeds;  // the seeds its jobs run with (the sweep's list, or from the sequence's own seed)
};

struct SweepSpec {
  std::string path;                      // the sweep file, for messages
  RunOptions base;                       // frames, resolution, reference: shared by every run
  std::vector<SweepSequence> sequences;  // in file order
  std::vector<SweepConfig> configs;      // the grid's product, then the explicit configs, in file order
};

// One job: one run of a configuration on a sequence with a seed.
struct SweepJob {
  size_t index = 0;     // position in the plan (sequences slowest, then configurations, seeds fastest)
  std::string id;       // "<sequence>/<config>/seed-<seed>": stable while the sweep file names the same things
  size_t sequence = 0;  // into SweepSpec::sequences
  size_t config = 0;    // into SweepSpec::configs
  uint32_t seed = 0;    // the run's --seed
  std::string dir;      // its output directory relative to the sweep's: runs/<sequence>/<config>/seed-<seed>
};

// What one configuration measured on one sequence, averaged over its frames (the first frame's timings skipped:
// it has no temporal input and warms the caches) and then over its completed seeds.
struct SweepPoint {
  std::string sequence;         // SweepSequence::name
  SweepConfig config;           // the configuration measured
  int seeds = 1;                // completed seeds averaged
  double relmse = 0.0;          // mean per-frame relmse
  double relmseDisocc = 0.0;    // mean relmse_disocc over frames with recently disoccluded pixels (NaN: none)
  double flip = 0.0;            // mean flip (NaN when the column is absent)
  double lumaRatio = 0.0;       // Σ luma / Σ reference luma over every frame (and seed)
  double flicker = 0.0;         // mean flicker
  double msPerFrame = 0.0;      // mean ms_frame
  double shadowRaysPerPixel = 0.0;  // mean shadow rays per pixel (every pass): the sample budget
  double efficiency = 0.0;      // 1 / (relmse · seconds per frame)
  bool pareto = false;          // no other point of its sequence is at most as slow and as wrong, better in one
  // The seed-ensemble split (two or more seeds; NaN otherwise), relative like relmse (docs/sweep-format.md):
  double relmseCi95 = NAN;      // half-width of relmse's 95% interval over seeds (Student t; NaN under 2 seeds)
  double bias2 = NAN;           // relative bias², corrected for the seeds' and the reference's noise
  double bias2Ci95 = NAN;       // half-width of its 95% interval (jackknife over seeds; NaN under 3 seeds)
  double variance = NAN;        // relative variance of one seed's estimate
  double varianceCi95 = NAN;    // half-width of its 95% interval (jackknife over seeds; NaN under 3 seeds)
};

// Reads and validates a sweep file (and the sequences it names). Throws InputError with file:line:column and JSON
// path.
SweepSpec LoadSweep(const std::string& path);

// Every job of the sweep, in plan order.
std::vector<SweepJob> PlanSweep(const SweepSpec& spec);

// The job named by its id or its index in the plan (as `--job` takes it). Throws InputError naming the sweep.
const SweepJob& FindSweepJob(const SweepSpec& spec, const std::vector<SweepJob>& jobs, const std::string& idOrIndex);

// One line of `--plan`: the job as compact JSON (index, id, sequence, config, preset, set, seed, dir).
std::string SweepJobLine(const SweepSpec& spec, const SweepJob& job);

// Slurm's --array syntax for these indices, ranges compressed ("0-3,7,9-10").
std::string SlurmArraySpec(const std::vector<SweepJob>& jobs);

// Whether the job's results under outDir are complete and were written by this very job (same sequence content,
// settings, frames, resolution, reference, seed and program version) and every file the merge reads is whole
// (metrics.csv's rows, every relative-error frame's checksum); `why` says what is wrong otherwise.
bool SweepJobComplete(const SweepSpec& spec, const SweepJob& job, const std::string& outDir, std::string* why = nullptr);

// Runs one job into outDir/<job.dir>: metrics.csv, run.json, with two or more seeds the relative-error frames the
// ensemble split needs, and last job.json, which marks it complete.
void RunSweepJob(const SweepSpec& spec, const SweepJob& job, const std::string& outDir);

// What a merge found and wrote.
struct SweepMerge {
  std::vector<SweepPoint> points;    // one per (sequence, configuration) with at least one completed seed
  std::vector<std::string> missing;     // ids of the jobs not (or not validly) complete, in plan order
  std::vector<std::string> missingWhy;  // for each, why (not run or not finished, stale, damaged)
  size_t jobs = 0;                   // jobs in the plan
};

// Writes outDir/sweep.csv, the plots and sweep.md from whatever jobs are complete; sweep.md lists the missing.
SweepMerge MergeSweep(const SweepSpec& spec, const std::string& outDir);

// Every job in this process, then the merge.
SweepMerge RunSweep(const SweepSpec& spec, const std::string& outDir);

// Summarises one run's metric rows (one seed).
SweepPoint Summarize(const SweepConfig& config, const std::vector<FrameMetricsRow>& rows);

// Marks the Pareto front of (msPerFrame, relmse) within each sequence: lower is better in both.
void MarkPareto(std::vector<SweepPoint>& points);

// The reports, as text (deterministic: same points, same bytes). SweepSvg plots the points of one sequence.
std::string SweepCsv(const std::vector<SweepPoint>& points);
std::string SweepSvg(const std::vector<SweepPoint>& points, const std::string& sequence);
std::string SweepMarkdown(const SweepSpec& spec, const SweepMerge& merge);

}  // namespace restir
