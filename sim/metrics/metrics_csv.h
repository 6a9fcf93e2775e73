// Reading a run's metrics.csv back (report, compare, sweep): the file is input like any other (DESIGN §10), so
// the reader trusts nothing in it. Pure parsing, no image I/O, so the fuzz target can drive it.
#pragma once

#include <string>
#include <vector>

namespace restir {

// The per-frame series of one preset in metrics.csv, rows in frame order.
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

// Parses the text of a metrics.csv read from `path` (used in messages). What the runner writes and nothing that
// could be mistaken for it: a header of distinct names of [A-Za-z0-9_] with frame and preset, at least one row,
// every line ended by a newline (a file cut anywhere, inside its header included, is refused), no control bytes
// (NUL included), the header's field count on every row, numbers where numbers belong, preset names usable as a
// directory name (letters, digits, '.', '_', '+', '-', not starting with '.'), no frame twice per preset.
// Throws InputError "<path>:<line>: error: ..." otherwise.
MetricsTable ParseMetricsCsv(const std::string& text, const std::string& path);

// Reads and parses metrics.csv (a regular file of at most 1 GiB). Throws InputError naming the file.
MetricsTable ReadMetricsCsv(const std::string& path);

}  // namespace restir
