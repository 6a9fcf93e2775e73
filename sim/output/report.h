// `restir-sim report`: reads a run's metrics.csv and run.json (and its frame previews and EXRs when present) and
// writes OUT/summary.json and a self-contained OUT/report.html (DESIGN §6, §9; docs/metrics.md defines both).
#pragma once

#include <string>
#include <vector>

#include "sim/metrics/metrics_csv.h"

namespace restir {

// Recovery after each reveal (docs/metrics.md "summary.json"). A post-reveal window is a maximal run of
// consecutive rows with disocc_recent_fraction > 0. The steady level is the median relmse over rows with
// disocc_recent_fraction == 0 except the first row (the run's first frame has no history: every pixel is new,
// although no disocclusion is recorded); over every row but the first when there are none. A window recovers at
// the first row k (0 = its first row) whose relmse_disocc <= 2 x steady; framesToRecover is then k, else -1
// (censored: the window ended, or the run did, first).
struct RecoveryWindow {
  int startFrame = 0;       // first frame of the window (the reveal)
  int length = 0;           // rows in the window
  int framesToRecover = -1; // rows after the reveal until relmse_disocc <= 2 x steady; -1: not within the window
};
struct Recovery {
  double steadyRelmse = 0.0;           // median relmse of the steady rows
  bool steadyFromAllFrames = false;    // no row was free of recent disocclusion, so every row but the first was used
  std::vector<RecoveryWindow> windows; // in frame order
};
// `disoccRecent`, `relmse` and `relmseDisocc` are one preset's per-row series, in frame order.
Recovery ComputeRecovery(const std::vector<int>& frames, const std::vector<double>& disoccRecent,
                         const std::vector<double>& relmse, const std::vector<double>& relmseDisocc);

// The frames whose images report.html's strips show: the first, middle (index size / 2) and last of `frames`
// (sorted, distinct). A run writes these frames' EXRs by default (--images report, sim/run/runner.h).
std::vector<int> ReportStripFrames(const std::vector<int>& frames);

// Metrics that report.html plots, one inline SVG each, in this order, when metrics.csv has the column.
const std::vector<std::string>& ReportPlotMetrics();

// Writes OUT/summary.json, OUT/report.html and (when the run wrote frames) OUT/report_images/<preset>/NNNN_error.png
// and NNNN_flip.png, each atomically. Same inputs give the same bytes. Throws InputError for a missing OUT, a
// missing or malformed metrics.csv, or a malformed run.json.
void WriteReport(const std::string& outDir);

}  // namespace restir
