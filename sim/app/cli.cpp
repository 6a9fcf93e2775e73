#include "sim/app/cli.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <charconv>
#include <cstdio>
#include <optional>
#include <thread>
#include <string_view>
#include <iostream>
#include <vector>

#include "core/simd.h"
#include "sim/util/atomic_file.h"
#include "sim/metrics/compare.h"
#include "sim/scene/embree_scene.h"
#include "sim/run/memory_estimate.h"
#include "sim/estimator/presets.h"
#include "sim/output/report.h"
#include "sim/run/runner.h"
#include "sim/scene/sequence.h"
#include "sim/study/sweep.h"

namespace restir {

namespace {

// A whole non-negative decimal integer no larger than `max`: no sign, no spaces, no suffix, no wrap-around
// (std::from_chars reports overflow where sscanf("%d") would wrap 4294967328 to 32).
std::optional<int64_t> ParseCount(std::string_view text, int64_t max) {
  int64_t v = 0;
  if (text.empty() || !std::isdigit(static_cast<unsigned char>(text.front()))) return std::nullopt;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v > max) return std::nullopt;
  return v;
}

// "A:B" -> [A, B); "A:" -> [A, end); "A" -> [A, A+1); A and B are frame numbers, B > A.
void ParseFrameRange(const std::string& text, RunOptions& opt) {
  constexpr int64_t kMaxFrame = 100000;  // the sequence format's frame limit
  const auto bad = [&](const std::string& why) {
    return InputError("--frames: error: '" + text + "' " + why);
  };
  const size_t colon = text.find(':');
  const std::string_view a = std::string_view(text).substr(0, colon);
  const std::optional<int64_t> begin = a.empty() && colon != std::string::npos ? 0 : ParseCount(a, kMaxFrame);
  if (!begin) throw bad("is not a frame range A:B of frame numbers 0 to 100000 (A to B-1; either side may be empty)");
  opt.frameBegin = static_cast<int>(*begin);
  if (colon == std::string::npos) {
    opt.frameEnd = opt.frameBegin + 1;
    return;
  }
  const std::string_view b = std::string_view(text).substr(colon + 1);
  if (b.empty()) {
    opt.frameEnd = -1;
    return;
  }
  const std::optional<int64_t> end = ParseCount(b, kMaxFrame);
  if (!end) throw bad("is not a frame range A:B of frame numbers 0 to 100000 (A to B-1; either side may be empty)");
  if (*end <= *begin) throw bad("is empty: B must be greater than A");
  opt.frameEnd = static_cast<int>(*end);
}

void ParseResolution(const std::string& text, RunOptions& opt) {
  const size_t x = text.find_first_of("xX");
  const std::optional<int64_t> w = x == std::string::npos ? std::nullopt : ParseCount(text.substr(0, x), 16384);
  const std::optional<int64_t> h = x == std::string::npos ? std::nullopt : ParseCount(text.substr(x + 1), 16384);
  if (!w || !h || *w < 1 || *h < 1)
    throw InputError("--resolution: error: '" + text + "' is not WxH with 1 <= W, H <= 16384");
  opt.width = static_cast<int>(*w);
  opt.height = static_cast<int>(*h);
}

void ApplyEmbreeIsa(const std::string& name) {
  if (name == "auto") {
    SetEmbreeIsa(BestEmbreeIsa());
    return;
  }
  const std::optional<EmbreeIsa> isa = ParseEmbreeIsa(name);
  if (!isa) throw InputError("--embree-isa: error: '" + name + "' is not one of sse4.2, avx2, avx512, auto");
  if (!SetEmbreeIsa(*isa))
    throw InputError("--embree-isa: error: this CPU (or this Embree) does not support '" + name + "'");
}

void ParseMaxMemory(const std::string& text, RunOptions& opt) {
  if (text == "none") {
    opt.maxMemoryBytes = -1.0;
    return;
  }
  const std::optional<double> bytes = ParseByteSize(text);
  if (!bytes || *bytes < 1.0)
    throw InputError("--max-memory: error: '" + text + "' is not a size such as 8G, 512M or 'none'");
  opt.maxMemoryBytes = *bytes;
}

// --threads up to 4 × the hardware threads: past what the machine runs, more threads only cost memory and start-up,
// and at several hundred the process runs out of threads or Embree cannot create its device (exit 1, an error that
// does not name the option). `zero` is the smallest value allowed (sweep's 0 means every core).
CLI::Validator ThreadLimit(int zero) {
  const int limit = 4 * static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return CLI::Validator(
      [zero, limit](std::string& v) {
        int n = 0;
        const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
        if (ec != std::errc() || end != v.data() + v.size())
          return std::string("a whole number is needed, not '") + v + "'";
        if (n < zero || n > limit)
          return v + " is outside [" + std::to_string(zero) + ", " + std::to_string(limit) +
                 "] (at most 4 x this machine's " + std::to_string(limit / 4) + " hardware threads)";
        return std::string();
      },
      "THREADS");
}

// CLI::Range lets NaN through (every comparison with it is false).
CLI::Validator Finite() {
  return CLI::Validator(
      [](std::string& v) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        return std::isfinite(x) ? std::string() : "not a finite number: " + v;
      },
      "FINITE");
}

// argv as one line, for run.json.
std::string CommandLine(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) line += (i ? " " : "") + std::string(argv[i]);
  return line;
}

// ---- run ----

// `run`'s options: RunOptions' own fields, and the text and flags that become RunOptions once parsed.
struct RunArgs {
  RunOptions opt;
  std::string presetList, frames, resolution, maxMemory, images = "report";
  std::string exrCompression = ExrCompressionName(ExrCompression::kZip);
  std::string simdName = "auto", embreeIsaName = "sse4.2";
  int64_t seed = -1;
  bool noReference = false, noImages = false, noProgress = false, noReport = false;
};

// What is run and measured: the sequence, presets, frames, seed and reference. --help lists them first.
void AddRunWorkOptions(CLI::App* run, RunArgs& a) {
  RunOptions& opt = a.opt;
  run->add_option("sequence", opt.sequencePath, "Sequence file (JSON)")->required();
  run->add_option("--preset,-p", a.presetList,
                  "Comma-separated presets to run side by side on the same frames and references, or 'all' "
                  "(default: the sequence's render.presets); see `restir-sim presets`");
  run->add_option("--frames", a.frames, "Frames A:B (A to B-1; either side may be empty)");
  run->add_option("--resolution", a.resolution, "Override the sequence's resolution, WxH");
  run->add_option("--threads", opt.threads, "Worker threads (default: every core); results do not depend on it")
      ->check(ThreadLimit(1));
  run->add_option("--seed", a.seed, "Override the sequence's seed")
      ->check(CLI::Range(int64_t{0}, int64_t{4294967295}));
  run->add_option("--reference-spp", opt.referenceSpp,
                  "Reference samples per pixel, a fixed budget (default: the sequence's referenceError when it has "
                  "one, else its referenceSpp)")
      ->check(CLI::Range(1, 1 << 24));
  run->add_option("--reference-error", opt.referenceError,
                  "Instead of a sample budget: sample each reference pixel until its estimated relative standard "
                  "error is this (e.g. 0.01), from a pilot pass; 16 to 65536 samples per pixel")
      ->check(Finite() & CLI::Range(1e-4, 1.0))
      ->excludes("--reference-spp");
  run->add_option("--reference-cap", opt.referenceSppCap,
                  "With an error target (--reference-error or the sequence's referenceError): the most samples a "
                  "frame's reference may take, as a mean per pixel; a frame that hits it is marked "
                  "reference_capped in metrics.csv (default: the sequence's referenceSppCap)")
      ->check(CLI::Range(32, 1 << 20))
      ->excludes("--reference-spp");
  run->add_option("--checkpoint-seconds", opt.checkpointSeconds,
                  "Seconds of work between checkpoints for --resume (the first frame's is always written; 0: every "
                  "frame)")
      ->check(Finite() & CLI::Range(0.0, 1e9))
      ->capture_default_str();
  run->add_option("--set", opt.settings,
                  "Override a preset setting for every preset, KEY=VALUE (repeatable), e.g. "
                  "--set temporal.maxHistory=8; keys: `restir-sim presets`");
  run->add_flag("--no-reference", a.noReference, "Skip the reference and the error metrics");
}

// What is written and how the machine runs it: outputs, ensembles, resuming, memory, ISA and SIMD. --help lists
// them after AddRunWorkOptions' options.
void AddRunOutputOptions(CLI::App* run, RunArgs& a) {
  RunOptions& opt = a.opt;
  run->add_option("--out,-o", opt.outDir, "Output directory")->capture_default_str();
  run->add_option("--cache-dir", opt.cacheDir, "Reference cache directory ('' disables the cache)")
      ->capture_default_str();
  run->add_option("--images", a.images,
                  "Which frames get an EXR (every layer) and a PNG preview under frames/: report (the first, middle "
                  "and last, which the report's strips show), all, or A:B (A to B-1, either side may be empty, "
                  "and the report's three). "
                  "Every frame's small PNGs for the report's scrubber and videos go to scrub/ whichever is chosen")
      ->capture_default_str();
  run->add_flag("--no-images", a.noImages,
                "Write no images at all (no frames/, no scrub/, no videos; metrics, plots and the report's tables "
                "only)");
  run->add_option("--exr-compression", a.exrCompression,
                  "How the frames' EXRs store their channels: zip (deflate: about 55% of the bytes; the default, as "
                  "by default a run writes three frames' EXRs), rle (run-length: about two thirds, cheaper to write) "
                  "or none (the fastest to write, for --images all on a fast disk); the pixels are the same")
      ->capture_default_str();
  run->add_flag("--no-progress", a.noProgress, "No progress on stderr");
  run->add_option("--progress-seconds", a.opt.progressSeconds,
                  "When stderr is not a terminal (a batch job's log), one progress line every this many seconds")
      ->check(Finite() & CLI::Range(0.0, 1e9))
      ->capture_default_str();
  run->add_flag("--no-report", a.noReport, "Do not write summary.json and report.html at the end");
  run->add_option("--ensemble", opt.ensemble,
                  "Run each preset K times with seeds S..S+K-1 and split the error into bias² and variance "
                  "(ensemble_* columns, bias and variance EXR layers)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  run->add_flag("--resume", opt.resume,
                "Continue an interrupted run from OUT/checkpoint.bin (same configuration); the outputs are "
                "bit-identical to an uninterrupted run");
  run->add_option("--max-memory", a.maxMemory,
                  "Refuse a run whose estimated memory exceeds SIZE (e.g. 8G, 512M) or, with 'none', never refuse "
                  "(default: the machine's memory, its control group's limit or ulimit -v, whichever is least)");
  run->add_option("--embree-isa", a.embreeIsaName,
                  "Embree's ISA: sse4.2 (the portable default), avx2, avx512 or auto (the widest this CPU has). The "
                  "wider ISAs trace 1.3-1.6x faster but may decide a ray grazing an edge differently, so a few "
                  "pixels can differ; run.json records the ISA")
      ->capture_default_str();
  run->add_option("--simd", a.simdName,
                  "SIMD target of the kernels: scalar, sse4, avx2, avx512 or auto (the best this CPU supports); "
                  "every target gives the same bits")
      ->capture_default_str();
}

CLI::App* AddRunCommand(CLI::App& app, RunArgs& a) {
  CLI::App* run = app.add_subcommand("run", "Replay a sequence with one or more presets; write frames, "
                                            "metrics.csv and run.json");
  AddRunWorkOptions(run, a);
  AddRunOutputOptions(run, a);
  return run;
}

// Turns the text options into a.opt, and sets the SIMD target.
void FinishRunOptions(RunArgs& a, int argc, char** argv) {
  RunOptions& opt = a.opt;
  opt.commandLine += CommandLine(argc, argv);
  if (a.presetList == "all") {
    for (const Preset& p : AllPresets()) opt.presets.push_back(p.name);
  } else if (!a.presetList.empty()) {
    std::stringstream ss(a.presetList);
    for (std::string item; std::getline(ss, item, ',');)
      if (!item.empty()) opt.presets.push_back(item);
  }
  if (!a.frames.empty()) ParseFrameRange(a.frames, opt);
  if (!a.resolution.empty()) ParseResolution(a.resolution, opt);
  if (!a.maxMemory.empty()) ParseMaxMemory(a.maxMemory, opt);
  if (a.seed >= 0) opt.seed = static_cast<uint32_t>(a.seed);
  opt.reference = !a.noReference;
  opt.writeImages = !a.noImages;
  const std::optional<ImageFrames> images = ParseImageFrames(a.images);
  if (!images)
    throw InputError("--images: error: '" + a.images + "' is not report, all or A:B (frames A to B-1, B > A)");
  opt.imageFrames = *images;
  const std::optional<ExrCompression> compression = ParseExrCompression(a.exrCompression);
  if (!compression)
    throw InputError("--exr-compression: error: '" + a.exrCompression + "' is not one of none, rle, zip");
  opt.exrCompression = *compression;
  opt.progress = !a.noProgress;
  opt.report = !a.noReport;
  const std::optional<SimdTarget> simd = ParseSimdTarget(a.simdName);
  if (!simd) throw InputError("--simd: error: '" + a.simdName + "' is not one of scalar, sse4, avx2, avx512, auto");
  if (!SetSimdTarget(*simd))
    throw InputError("--simd: error: this CPU (or this build) does not support '" + a.simdName + "'");
}

int ExecuteRun(RunArgs& a, int argc, char** argv) {
  ApplyEmbreeIsa(a.embreeIsaName);
  FinishRunOptions(a, argc, argv);
  const RunOptions& opt = a.opt;
  const RunResult r = Run(opt);
  if (r.alreadyComplete) {
    std::fprintf(stderr, "%s: this run is already complete (run.json); %s\n", opt.outDir.c_str(),
                 r.reportWritten ? "wrote its missing report" : "nothing to do");
    return 0;
  }
  if (r.resumedAtFrame >= 0)
    std::fprintf(stderr, "resumed at frame %d from %s/checkpoint.bin\n", r.resumedAtFrame, opt.outDir.c_str());
  std::fprintf(stderr, "wrote %zu metric rows to %s/metrics.csv in %.1f s\n", r.rows.size(), opt.outDir.c_str(),
               r.wallSeconds);
  return 0;
}

// ---- validate, presets, report, compare ----

CLI::App* AddValidateCommand(CLI::App& app, std::vector<std::string>& paths) {
  CLI::App* validate = app.add_subcommand(
      "validate", "Check sequence files and print a one-screen summary of each (a refused file: its one-line "
                  "message, the others still checked; exit status 2 if any was refused)");
  validate->add_option("sequence", paths, "Sequence files (JSON)")->required();
  return validate;
}

// Each file in turn, so that a directory of sequences is checked in one process: a refused one prints its one-line
// message (as a lone `validate FILE` does) and the rest are still checked.
int ExecuteValidate(const std::vector<std::string>& paths) {
  int status = 0;
  for (const std::string& path : paths) {
    try {
      const Sequence seq = LoadSequence(path);
      CheckSequencePresets(seq);
      std::cout << SummarizeSequence(seq);
    } catch (const InputError& e) {
      std::cout.flush();
      std::cerr << e.what() << "\n";
      status = 2;
    }
  }
  return status;
}

CLI::App* AddPresetsCommand(CLI::App& app) {
  return app.add_subcommand("presets", "List every preset with its settings and source");
}

int ExecutePresets() {
  std::cout << DescribePresets();
  return 0;
}

CLI::App* AddReportCommand(CLI::App& app, std::string& outDir) {
  CLI::App* report = app.add_subcommand("report", "Write OUTDIR/summary.json and OUTDIR/report.html from a run's "
                                                  "metrics.csv and run.json (docs/metrics.md)");
  report->add_option("outdir", outDir, "A run's output directory")->required();
  return report;
}

int ExecuteReport(const std::string& outDir) {
  const TemporaryRoot temporaries(outDir);
  WriteReport(outDir);
  std::fprintf(stderr, "wrote %s/summary.json and %s/report.html\n", outDir.c_str(), outDir.c_str());
  return 0;
}

struct CompareArgs {
  std::string runA, runB;
};

CLI::App* AddCompareCommand(CLI::App& app, CompareArgs& a) {
  CLI::App* compare = app.add_subcommand(
      "compare", "Compare two runs' metrics per preset and column: means, relative change, and a paired t-test "
                 "on 8-frame batch means (two-sided, 5%)");
  compare->add_option("run_a", a.runA, "Run A: output directory or metrics.csv")->required();
  compare->add_option("run_b", a.runB, "Run B: output directory or metrics.csv")->required();
  return compare;
}

int ExecuteCompare(const CompareArgs& a) {
  std::cout << FormatComparison(CompareRuns(a.runA, a.runB));
  return 0;
}

// ---- sweep ----

struct SweepArgs {
  std::string path, out = "out/sweep", job, format = "jsonl", cacheDir = ".cache/restir-sim";
  std::string embreeIsaName = "sse4.2";
  int threads = 0;
  bool plan = false, missing = false, merge = false;
  CLI::Option* jobOption = nullptr;
};

CLI::App* AddSweepCommand(CLI::App& app, SweepArgs& a) {
  CLI::App* sweep = app.add_subcommand(
      "sweep", "Run a study: configurations x sequences x seeds (docs/sweep-format.md), as one process or as "
               "independent jobs (--plan, --job, --merge; docs/cluster.md); write sweep.csv, the Pareto plots and "
               "sweep.md (equal-time, equal-sample and seed-ensemble tables)");
  sweep->add_option("sweep", a.path, "Sweep file (JSON)")->required();
  sweep->add_option("--out", a.out, "Output directory (job results go to OUT/runs/<sequence>/<config>/seed-<seed>)")
      ->capture_default_str();
  sweep->add_option("--cache-dir", a.cacheDir,
                    "Reference cache directory, shared by every job ('' disables it); on a cluster, a shared file "
                    "system")
      ->capture_default_str();
  sweep->add_option("--embree-isa", a.embreeIsaName, "Embree's ISA, as for run")->capture_default_str();
  sweep->add_option("--threads", a.threads, "Worker threads (0: every core)")
      ->check(ThreadLimit(0))
      ->capture_default_str();
  CLI::Option* planOpt = sweep->add_flag("--plan", a.plan,
                                         "Print the jobs, one per line, and run nothing (a Slurm array task passes "
                                         "its job's index to --job: $SLURM_ARRAY_TASK_ID; docs/cluster.md)");
  sweep->add_flag("--missing", a.missing, "With --plan: only the jobs without a complete result in OUT")
      ->needs(planOpt);
  sweep->add_option("--format", a.format,
                    "With --plan: jsonl (one JSON object per job), index (one index per line, for xargs) or array "
                    "(Slurm's --array list)")
      ->check(CLI::IsMember({"jsonl", "index", "array"}))
      ->needs(planOpt)
      ->capture_default_str();
  a.jobOption =
      sweep->add_option("--job", a.job, "Run one job (its index or id from --plan) into OUT")->excludes(planOpt);
  sweep->add_flag("--merge", a.merge, "Write the reports from whatever jobs in OUT are complete; run nothing")
      ->excludes(planOpt)
      ->excludes(a.jobOption);
  return sweep;
}

// --plan: the jobs on stdout, in --format.
void PrintSweepPlan(const SweepSpec& spec, const SweepArgs& a) {
  std::vector<SweepJob> jobs;
  for (const SweepJob& j : PlanSweep(spec))
    if (!a.missing || !SweepJobComplete(spec, j, a.out)) jobs.push_back(j);
  if (a.format == "array") {
    if (!jobs.empty()) std::cout << SlurmArraySpec(jobs) << "\n";
  } else {
    for (const SweepJob& j : jobs)
      std::cout << (a.format == "index" ? std::to_string(j.index) : SweepJobLine(spec, j)) << "\n";
  }
}

// --job: one job of the plan into OUT.
void RunOneSweepJob(const SweepSpec& spec, const SweepArgs& a) {
  const std::vector<SweepJob> jobs = PlanSweep(spec);
  const SweepJob& job = FindSweepJob(spec, jobs, a.job);
  std::fprintf(stderr, "sweep: job %zu/%zu %s\n", job.index + 1, jobs.size(), job.id.c_str());
  RunSweepJob(spec, job, a.out);
  std::fprintf(stderr, "wrote %s/%s\n", a.out.c_str(), job.dir.c_str());
}

void PrintSweepMerge(const SweepMerge& m, const std::string& out) {
  std::fprintf(stderr, "merged %zu of %zu jobs into %s/sweep.{csv,md} and the plots", m.jobs - m.missing.size(),
               m.jobs, out.c_str());
  if (!m.missing.empty()) {
    std::fprintf(stderr, "; %zu missing:", m.missing.size());
    for (size_t k = 0; k < m.missing.size() && k < 10; ++k) std::fprintf(stderr, " %s", m.missing[k].c_str());
    if (m.missing.size() > 10) std::fprintf(stderr, " ...");
  }
  std::fprintf(stderr, "\n");
}

int ExecuteSweep(const SweepArgs& a, int argc, char** argv) {
  ApplyEmbreeIsa(a.embreeIsaName);
  SweepSpec spec = LoadSweep(a.path);
  spec.base.threads = a.threads;
  spec.base.progress = false;
  spec.base.cacheDir = a.cacheDir;
  spec.base.commandLine += CommandLine(argc, argv);
  if (a.plan) {
    PrintSweepPlan(spec, a);
    return 0;
  }
  const TemporaryRoot temporaries(a.out);
  CheckWritableDirectory(a.out, "output directory");
  // Given, not non-empty: an empty id (an unset variable in a job script) is FindSweepJob's to refuse.
  if (a.jobOption->count() > 0) {
    RunOneSweepJob(spec, a);
    return 0;
  }
  PrintSweepMerge(a.merge ? MergeSweep(spec, a.out) : RunSweep(spec, a.out), a.out);
  return 0;
}

}  // namespace

int RunCommandLine(int argc, char** argv) {
  CLI::App app{"restir-sim: a deterministic, software-rendered ReSTIR DI simulator.\n"
               "Replays scripted sequences through the ReSTIR pipeline and reports per-frame error, stability\n"
               "and timing against a converged reference."};
  app.require_subcommand(1);
  // Bad command lines get one line too (DESIGN §10), not CLI11's two.
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return std::string("restir-sim: error: ") + e.what() + " (see --help)\n";
  });
  app.set_version_flag("--version", std::string(RESTIR_VERSION));

  // The options' values live here, for CLI11 to fill in during parse.
  RunArgs runArgs;
  std::vector<std::string> validatePaths;
  std::string reportDir;
  CompareArgs compareArgs;
  SweepArgs sweepArgs;
  CLI::App* run = AddRunCommand(app, runArgs);
  CLI::App* validate = AddValidateCommand(app, validatePaths);
  CLI::App* presets = AddPresetsCommand(app);
  CLI::App* report = AddReportCommand(app, reportDir);
  CLI::App* compare = AddCompareCommand(app, compareArgs);
  CLI::App* sweep = AddSweepCommand(app, sweepArgs);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }

  try {
    if (sweep->parsed()) return ExecuteSweep(sweepArgs, argc, argv);
    if (report->parsed()) return ExecuteReport(reportDir);
    if (compare->parsed()) return ExecuteCompare(compareArgs);
    if (presets->parsed()) return ExecutePresets();
    if (validate->parsed()) return ExecuteValidate(validatePaths);
    if (run->parsed()) return ExecuteRun(runArgs, argc, argv);
  } catch (const InputError& e) {
    std::cerr << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "restir-sim: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace restir
