// `restir-sim run`: replays a sequence through one or more presets on the same frames and references, and
// writes frames, metrics.csv and run.json under the output directory.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/output/frame_writer.h"
#include "sim/metrics/metrics.h"

namespace restir {

// Which frames get their EXR and PNG preview under frames/ (--images). Every frame's scrubber PNGs (scrub/,
// sim/output/scrub_frames.h) are written whenever images are, whichever this selects.
struct ImageFrames {
  enum class Kind : uint8_t {
    kReport,  // the frames the report's strips show: first, middle and last (ReportStripFrames, sim/output/report.h)
    kAll,     // every frame
    kRange,   // frames begin..end-1 of the run, and the report's (a range asks for more, not other)
  };
  Kind kind = Kind::kReport;
  int begin = 0, end = 0;  // kRange only
};
// "report", "all" or "A:B" (A to B-1, as --frames; either side may be empty: the run's first, its end); nullopt
// for anything else.
std::optional<ImageFrames> ParseImageFrames(const std::string& text);
// The selection as run.json records it: "report", "all" or "A:B".
std::string ImageFramesName(const ImageFrames& f);

struct RunOptions {
  std::string sequencePath;              // the sequence file
  std::vector<std::string> presets;      // empty: the sequence's render.presets
  int frameBegin = 0;                    // first frame
  int frameEnd = -1;                     // one past the last frame; -1: the sequence's frame count
  int width = 0;                         // 0: the sequence's resolution
  int height = 0;
  int threads = 0;                       // 0: every core
  std::optional<uint32_t> seed;          // unset: the sequence's seed
  int referenceSpp = 0;                  // > 0: a fixed reference budget, whatever the sequence says
  double referenceError = 0.0;           // > 0: reference sampled to this relative standard error per pixel
  int referenceSppCap = 0;               // > 0: the error target's cap (else the sequence's referenceSppCap)
  bool reference = true;                 // false: no reference, no error metrics
  std::string outDir = "out";            // where frames, metrics.csv and run.json go
  std::string cacheDir = ".cache/restir-sim";  // reference cache; empty disables it
  bool writeImages = true;               // frame files and scrubber PNGs (off for tests and benchmarks)
  ImageFrames imageFrames;               // which frames get an EXR and a preview (with writeImages)
  ExrCompression exrCompression = ExrCompression::kZip;  // how the EXRs store their channels (same pixels)
  bool progress = true;                  // progress on stderr (a line in place on a terminal, else one a while)
  double progressSeconds = 30.0;         // seconds between progress lines when stderr is not a terminal
  bool resume = false;                   // continue from OUT/checkpoint.bin when it matches this configuration
  // Seconds of work between checkpoints (after the first frame's, which is always written); 0: every frame. A
  // checkpoint of the flagship at 640x360 with every preset is ~140 MB, so writing it every frame cost ~10% of
  // README command 1; a resumed run redoes at most this much.
  double checkpointSeconds = 60.0;
  bool report = true;                    // summary.json and report.html when the run completes
  int ensemble = 1;                      // K runs per preset with seeds seed..seed+K-1: bias²/variance split
  std::vector<std::string> settings;     // KEY=VALUE overrides applied to every preset (--set)
  // The memory the run may take (--max-memory): 0, the machine's (sim/run/memory_estimate.h); < 0, no check.
  double maxMemoryBytes = 0.0;
  std::string commandLine;               // recorded in run.json
  // Where to write each frame's relative error (I − R) / sqrt(R² + 0.01) (sim/metrics/seed_ensemble.h), for a sweep's
  // seed-ensemble split; empty: not written. Needs one preset and a reference, and no --resume (the frames before
  // a checkpoint would be missing).
  std::string relativeErrorPath;
};

struct RunResult {
  std::vector<FrameMetricsRow> rows;
  double wallSeconds = 0.0;
  int resumedAtFrame = -1;  // the first frame rendered after resuming from a checkpoint; -1: not resumed
  bool alreadyComplete = false;  // --resume found this configuration complete in the output directory: nothing done
  bool reportWritten = false;    // ... but for its report (and videos), which it was stopped before writing
};

// Throws InputError for bad input (unknown or repeated preset, frame range, unreadable sequence, unwritable output,
// a run larger than the memory it may take).
RunResult Run(const RunOptions& options);

}  // namespace restir
