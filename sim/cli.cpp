#include "sim/cli.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "core/simd.h"
#include "sim/compare.h"
#include "sim/presets.h"
#include "sim/report.h"
#include "sim/runner.h"
#include "sim/sequence.h"
#include "sim/sweep.h"

namespace restir {

namespace {

// "A:B" -> [A, B); "A:" -> [A, end); "A" -> [A, A+1).
void ParseFrameRange(const std::string& text, RunOptions& opt) {
  const auto colon = text.find(':');
  try {
    size_t used = 0;
    if (colon == std::string::npos) {
      opt.frameBegin = std::stoi(text, &used);
      if (used != text.size()) throw std::invalid_argument("trailing");
      opt.frameEnd = opt.frameBegin + 1;
      return;
    }
    const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
    opt.frameBegin = a.empty() ? 0 : std::stoi(a, &used);
    if (!a.empty() && used != a.size()) throw std::invalid_argument("trailing");
    opt.frameEnd = b.empty() ? -1 : std::stoi(b, &used);
    if (!b.empty() && used != b.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw InputError("--frames: error: '" + text + "' is not a frame range A:B");
  }
}

void ParseResolution(const std::string& text, RunOptions& opt) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 1 ||
      h < 1 || w > 16384 || h > 16384)
    throw InputError("--resolution: error: '" + text + "' is not WxH with 1 <= W, H <= 16384");
  opt.width = w;
  opt.height = h;
}

// The file's render.presets are only names to the loader; check them here so the message can name the file and
// the JSON path (validate and a plain run report the same line).
void CheckFilePresets(const Sequence& seq) {
  for (size_t i = 0; i < seq.defaults.presets.size(); ++i) {
    if (FindPreset(seq.defaults.presets[i])) continue;
    throw InputError(seq.path + ": error at /render/presets/" + std::to_string(i) + ": " +
                     UnknownPresetMessage(seq.defaults.presets[i]));
  }
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

  RunOptions opt;
  std::string presetList, frames, resolution;
  int64_t seed = -1;
  bool noReference = false, noImages = false, noProgress = false;
  CLI::App* run = app.add_subcommand("run", "Replay a sequence with one or more presets; write frames, "
                                            "metrics.csv and run.json");
  run->add_option("sequence", opt.sequencePath, "Sequence file (JSON)")->required();
  run->add_option("--preset,-p", presetList,
                  "Comma-separated presets to run side by side on the same frames and references, or 'all' "
                  "(default: the sequence's render.presets); see `restir-sim presets`");
  run->add_option("--frames", frames, "Frames A:B (A to B-1; either side may be empty)");
  run->add_option("--resolution", resolution, "Override the sequence's resolution, WxH");
  run->add_option("--threads", opt.threads, "Worker threads (default: every core); results do not depend on it")
      ->check(CLI::Range(1, 1024));
  run->add_option("--seed", seed, "Override the sequence's seed")->check(CLI::Range(int64_t{0}, int64_t{4294967295}));
  run->add_option("--reference-spp", opt.referenceSpp, "Reference samples per pixel (default: the sequence's)")
      ->check(CLI::Range(1, 1 << 24));
  run->add_option("--set", opt.settings,
                  "Override a preset setting for every preset, KEY=VALUE (repeatable), e.g. "
                  "--set temporal.maxHistory=8; keys: `restir-sim presets`");
  run->add_flag("--no-reference", noReference, "Skip the reference and the error metrics");
  run->add_option("--out,-o", opt.outDir, "Output directory")->capture_default_str();
  run->add_option("--cache-dir", opt.cacheDir, "Reference cache directory ('' disables the cache)")
      ->capture_default_str();
  run->add_flag("--no-images", noImages, "Do not write EXR/PNG frames (metrics only)");
  run->add_flag("--no-progress", noProgress, "No progress line on stderr");
  bool noReport = false;
  run->add_flag("--no-report", noReport, "Do not write summary.json and report.html at the end");
  run->add_option("--ensemble", opt.ensemble,
                  "Run each preset K times with seeds S..S+K-1 and split the error into bias² and variance "
                  "(ensemble_* columns, bias and variance EXR layers)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  run->add_flag("--resume", opt.resume,
                "Continue an interrupted run from OUT/checkpoint.bin (same configuration); the outputs are "
                "bit-identical to an uninterrupted run");
  std::string simdName = "auto";
  run->add_option("--simd", simdName,
                  "SIMD target of the kernels: scalar, sse4, avx2, avx512 or auto (the best this CPU supports); "
                  "every target gives the same bits")
      ->capture_default_str();

  std::string validatePath;
  CLI::App* validate = app.add_subcommand("validate", "Check a sequence file and print a one-screen summary");
  validate->add_option("sequence", validatePath, "Sequence file (JSON)")->required();

  CLI::App* presetsCmd = app.add_subcommand("presets", "List every preset with its settings and source");

  std::string reportDir;
  CLI::App* reportCmd = app.add_subcommand("report", "Write OUTDIR/summary.json and OUTDIR/report.html from a run's "
                                                     "metrics.csv and run.json (docs/metrics.md)");
  reportCmd->add_option("outdir", reportDir, "A run's output directory")->required();

  std::string compareA, compareB;
  CLI::App* compareCmd = app.add_subcommand(
      "compare", "Compare two runs' metrics per preset and column: means, relative change, and a paired t-test "
                 "on 8-frame batch means (two-sided, 5%)");
  compareCmd->add_option("run_a", compareA, "Run A: output directory or metrics.csv")->required();
  compareCmd->add_option("run_b", compareB, "Run B: output directory or metrics.csv")->required();

  std::string sweepPath, sweepOut = "out/sweep";
  int sweepThreads = 0;
  CLI::App* sweep = app.add_subcommand(
      "sweep", "Run a grid of presets and settings (docs/sweep-format.md); write sweep.csv, sweep.svg (Pareto plot "
               "of relmse against ms/frame) and sweep.md (equal-time and equal-sample tables)");
  sweep->add_option("sweep", sweepPath, "Sweep file (JSON)")->required();
  sweep->add_option("--out", sweepOut, "Output directory (runs go to OUT/runs/<config>)")->capture_default_str();
  sweep->add_option("--threads", sweepThreads, "Worker threads (0: every core)")->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }

  try {
    if (sweep->parsed()) {
      SweepSpec spec = LoadSweep(sweepPath);
      spec.base.threads = sweepThreads;
      spec.base.progress = false;
      for (int i = 0; i < argc; ++i) spec.base.commandLine += (i ? " " : "") + std::string(argv[i]);
      const std::vector<SweepPoint> points = RunSweep(spec, sweepOut);
      std::fprintf(stderr, "wrote %zu configurations to %s/sweep.{csv,svg,md}\n", points.size(), sweepOut.c_str());
      return 0;
    }
    if (reportCmd->parsed()) {
      WriteReport(reportDir);
      std::fprintf(stderr, "wrote %s/summary.json and %s/report.html\n", reportDir.c_str(), reportDir.c_str());
      return 0;
    }
    if (compareCmd->parsed()) {
      std::cout << FormatComparison(CompareRuns(compareA, compareB));
      return 0;
    }
    if (presetsCmd->parsed()) {
      std::cout << DescribePresets();
      return 0;
    }
    if (validate->parsed()) {
      const Sequence seq = LoadSequence(validatePath);
      CheckFilePresets(seq);
      std::cout << SummarizeSequence(seq);
      return 0;
    }
    if (run->parsed()) {
      for (int i = 0; i < argc; ++i) opt.commandLine += (i ? " " : "") + std::string(argv[i]);
      if (presetList.empty()) CheckFilePresets(LoadSequence(opt.sequencePath));
      if (presetList == "all") {
        for (const Preset& p : AllPresets()) opt.presets.push_back(p.name);
      } else if (!presetList.empty()) {
        std::stringstream ss(presetList);
        for (std::string item; std::getline(ss, item, ',');)
          if (!item.empty()) opt.presets.push_back(item);
      }
      if (!frames.empty()) ParseFrameRange(frames, opt);
      if (!resolution.empty()) ParseResolution(resolution, opt);
      if (seed >= 0) opt.seed = static_cast<uint32_t>(seed);
      opt.reference = !noReference;
      opt.writeImages = !noImages;
      opt.progress = !noProgress;
      opt.report = !noReport;
      const std::optional<SimdTarget> simd = ParseSimdTarget(simdName);
      if (!simd) throw InputError("--simd: error: '" + simdName + "' is not one of scalar, sse4, avx2, avx512, auto");
      if (!SetSimdTarget(*simd))
        throw InputError("--simd: error: this CPU (or this build) does not support '" + simdName + "'");
      const RunResult r = Run(opt);
      std::fprintf(stderr, "wrote %zu metric rows to %s/metrics.csv in %.1f s\n", r.rows.size(),
                   opt.outDir.c_str(), r.wallSeconds);
      return 0;
    }
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
