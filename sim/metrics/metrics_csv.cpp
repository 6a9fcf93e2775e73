#include "sim/metrics/metrics_csv.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

#include "sim/util/input_file.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

int MetricsTable::Column(const std::string& name) const {
  for (size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return static_cast<int>(i);
  return -1;
}

const PresetSeries* MetricsTable::Preset(const std::string& name) const {
  for (const PresetSeries& p : presets)
    if (p.name == name) return &p;
  return nullptr;
}

namespace {

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

bool ParseDouble(const std::string& s, double& v) {
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return false;
  char* end = nullptr;
  v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size();
}

bool IsColumnName(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

// Preset names become directories (frames/<preset>/, report_images/<preset>/): nothing that leaves the run's
// directory or hides in it.
bool IsPresetName(const std::string& s) {
  return !s.empty() && s[0] != '.' && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '+' || c == '=' || c == '-';
  });
}

}  // namespace

MetricsTable ParseMetricsCsv(const std::string& text, const std::string& path) {
  MetricsTable t;
  t.path = path;
  int lineNo = 0;
  auto fail = [&](const std::string& what) {
    throw InputError(path + ":" + std::to_string(std::max(lineNo, 1)) + ": error: " + what);
  };
  std::vector<std::string> header;
  int frameCol = -1, presetCol = -1, hashCol = -1;
  std::vector<int> numericOf;  // file column -> numeric column index, -1 for frame/preset/image_hash
  std::map<std::string, size_t> presetIndex;
  std::vector<std::map<int, int>> rowLines;  // per preset: frame -> line (for duplicate messages)
  size_t pos = 0;
  while (pos < text.size()) {
    ++lineNo;
    const size_t end = text.find('\n', pos);
    if (end == std::string::npos)
      fail(header.empty() ? "the file ends inside its header (cut short?)" : "the last line has no end (cut short?)");
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    for (size_t i = 0; i < line.size(); ++i)
      if (std::iscntrl(static_cast<unsigned char>(line[i])))
        fail("control byte " + std::to_string(static_cast<unsigned char>(line[i])) + " at column " +
             std::to_string(i + 1) + (line[i] == '\0' ? " (a NUL: damaged file?)" : ""));
    if (header.empty()) {
      if (line.empty()) fail("empty header line");
      header = SplitCsvLine(line);
      for (size_t i = 0; i < header.size(); ++i) {
        const std::string& h = header[i];
        if (!IsColumnName(h))
          fail("column " + std::to_string(i + 1) + ": '" + Printable(h) + "' is not a column name (A-Z a-z 0-9 _)");
        for (size_t j = 0; j < i; ++j)
          if (header[j] == h) fail("column '" + h + "' appears twice");
        if (h == "frame") frameCol = static_cast<int>(i);
        if (h == "preset") presetCol = static_cast<int>(i);
        if (h == "image_hash") hashCol = static_cast<int>(i);
        if (h == "frame" || h == "preset" || h == "image_hash") {
          numericOf.push_back(-1);
        } else {
          numericOf.push_back(static_cast<int>(t.columns.size()));
          t.columns.push_back(h);
        }
      }
      if (frameCol < 0 || presetCol < 0) fail("the header has no 'frame' or no 'preset' column");
      t.hasImageHash = hashCol >= 0;
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> fields = SplitCsvLine(line);
    if (fields.size() != header.size())
      fail(std::to_string(fields.size()) + " fields, the header has " + std::to_string(header.size()));
    double frameValue = 0.0;
    if (!ParseDouble(fields[frameCol], frameValue) || frameValue != std::floor(frameValue) || frameValue < 0 ||
        frameValue > 1e9)
      fail("column 'frame': '" + Printable(fields[frameCol]) + "' is not a frame number");
    const std::string& name = fields[presetCol];
    if (!IsPresetName(name)) fail("column 'preset': '" + Printable(name) + "' is not a preset name");
    auto it = presetIndex.find(name);
    if (it == presetIndex.end()) {
      it = presetIndex.emplace(name, t.presets.size()).first;
      PresetSeries s;
      s.name = name;
      s.values.resize(t.columns.size());
      t.presets.push_back(std::move(s));
      rowLines.emplace_back();
    }
    PresetSeries& s = t.presets[it->second];
    const int frame = static_cast<int>(frameValue);
    if (const auto seen = rowLines[it->second].find(frame); seen != rowLines[it->second].end())
      fail("frame " + std::to_string(frame) + " of preset '" + name + "' already appears on line " +
           std::to_string(seen->second));
    rowLines[it->second].emplace(frame, lineNo);
    s.frames.push_back(frame);
    s.imageHashes.push_back(hashCol >= 0 ? fields[hashCol] : std::string());
    for (size_t i = 0; i < fields.size(); ++i) {
      if (numericOf[i] < 0) continue;
      double v = 0.0;
      if (!ParseDouble(fields[i], v))
        fail("column '" + header[i] + "': '" + Printable(fields[i]) + "' is not a number");
      s.values[numericOf[i]].push_back(v);
    }
  }
  if (header.empty()) throw InputError(path + ":1: error: empty file (no header)");
  if (t.presets.empty()) throw InputError(path + ":" + std::to_string(lineNo) + ": error: no rows after the header");
  // Rows in frame order within each preset (the runner writes them so; a hand-made file need not).
  for (PresetSeries& s : t.presets) {
    std::vector<size_t> order(s.frames.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return s.frames[a] < s.frames[b]; });
    PresetSeries sorted;
    sorted.name = s.name;
    sorted.values.resize(s.values.size());
    for (size_t i : order) {
      sorted.frames.push_back(s.frames[i]);
      sorted.imageHashes.push_back(s.imageHashes[i]);
      for (size_t c = 0; c < s.values.size(); ++c) sorted.values[c].push_back(s.values[c][i]);
    }
    s = std::move(sorted);
  }
  return t;
}

MetricsTable ReadMetricsCsv(const std::string& path) {
  std::string text, problem;
  if (!TryReadRegularFile(path, size_t(1) << 30, text, problem)) {
    if (problem == "no such file")
      throw InputError(path + ": error: cannot open (no metrics.csv: is this a run's output directory?)");
    throw InputError(path + ": error: cannot read (" + problem + ")");
  }
  return ParseMetricsCsv(text, path);
}

}  // namespace restir
