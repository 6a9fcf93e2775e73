// `restir-sim report`: reads a run's metrics.csv and run.json (and its frame previews and EXRs when present) and
// writes OUT/summary.json and a self-contained OUT/report.html (DESIGN §6, §9; docs/metrics.md defines both).
#pragma once

#include <string>
#include <vector>

namespace restir {

// The per-frame series of one preset in metrics.csv, rows in file order.
struct PresetSeries {
  std::string name;                         // preset name
  std::vector<int> frames;                  // frame of each row
  std::vector<std::vector<double>> values;  // [numeric column][row], columns as MetricsTable::columns
  std::vector<std::string> imageHashes;     // image_hash of each row ("" when the column is absent)
};

// metrics.csv parsed generically: every column other than frame, preset and image_hash is numeric, so columns
// added later (e.g. flip) need no change here.
struct MetricsTable {
  std::string path;                   // the file read
  std::vector<std::string> columns;   // numeric columns in file order
  std::vector<PresetSeries> presets;  // in order of first appearance
  bool hasImageHash = false;          // the file has an image_hash column

  int Column(const std::string& name) const;  // index into columns, -1 when absent
  const PresetSeries* Preset(const std::string& name) const;  // null when absent
};

// Reads metrics.csv. Throws InputError naming the file (and line) when it is missing or malformed.
MetricsTable ReadMetricsCsv(const std::string& path);

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

// Metrics that report.html plots, one inline SVG each, in this order, when metrics.csv has the column.
const std::vector<std::string>& ReportPlotMetrics();

// Writes OUT/summary.json, OUT/report.html and (when the run wrote frames) OUT/report_images/<preset>/NNNN_error.png
// and NNNN_flip.png, each atomically. Same inputs give the same bytes. Throws InputError for a missing OUT, a
// missing or malformed metrics.csv, or a malformed run.json.
void WriteReport(const std::string& outDir);

}  // namespace restir
