// The metrics.csv reader (report, compare, sweep) on what the runner writes and on every way a file can be
// damaged: cut anywhere, bytes changed, fields lost, names that would leave the run's directory.
#include "sim/metrics/metrics_csv.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "sim/scene/sequence.h"  // InputError

namespace restir {
namespace {

// A real run's file (the fuzz target's seed): 2 presets x 2 frames, 51 columns.
std::string RealFile() {
  std::ifstream f("tests/fuzz/metrics_seeds/metrics.csv", std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseMetricsCsv(text, "m.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(MetricsCsv, ReadsWhatTheRunnerWrites) {
  const std::string text = RealFile();
  ASSERT_FALSE(text.empty());
  const MetricsTable t = ParseMetricsCsv(text, "m.csv");
  ASSERT_EQ(t.presets.size(), 2u);
  EXPECT_EQ(t.presets[0].name, "ris");
  EXPECT_EQ(t.presets[0].frames, (std::vector<int>{0, 1}));
  EXPECT_TRUE(t.hasImageHash);
  EXPECT_GE(t.Column("relmse"), 0);
  // CRLF line ends (a file passed through another tool) read the same.
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  EXPECT_EQ(ParseMetricsCsv(crlf, "m.csv").presets[1].values, t.presets[1].values);
}

// Cut at every byte: refused, unless the cut falls just after a newline, where the prefix is itself a whole file
// of fewer rows (the runner's own state after each frame).
TEST(MetricsCsv, EveryCutIsRefusedUnlessItEndsAWholeRow) {
  const std::string text = RealFile();
  const size_t headerEnd = text.find('\n') + 1;
  for (size_t n = 0; n < text.size(); ++n) {
    const std::string cut = text.substr(0, n);
    const std::string error = ErrorOf(cut);
    if (n > headerEnd && text[n - 1] == '\n') {
      EXPECT_EQ(error, "") << n;
    } else {
      EXPECT_NE(error, "") << "a cut after byte " << n << " was accepted";
    }
  }
  EXPECT_NE(ErrorOf(text.substr(0, 40)).find("ends inside its header"), std::string::npos);
}

TEST(MetricsCsv, ControlBytesAnywhereAreRefused) {
  const std::string text = RealFile();
  for (size_t at : {size_t(0), size_t(8), text.find('\n') + 3, text.size() / 2, text.size() - 3})
    for (char c : {'\0', '\x01', '\x1b', '\x7f'}) {
      std::string bad = text;
      bad[at] = c;
      EXPECT_NE(ErrorOf(bad).find("control byte"), std::string::npos) << at << " " << int(c);
    }
  std::string nul = text;
  nul[8] = '\0';
  EXPECT_NE(ErrorOf(nul).find("NUL"), std::string::npos);
}

TEST(MetricsCsv, MalformedHeadersAndRowsNameTheLine) {
  const std::string h = "frame,preset,relmse\n";
  EXPECT_EQ(ErrorOf(""), "m.csv:1: error: empty file (no header)");
  EXPECT_EQ(ErrorOf(h), "m.csv:1: error: no rows after the header");
  EXPECT_EQ(ErrorOf(h + "0,ris\n"), "m.csv:2: error: 2 fields, the header has 3");
  EXPECT_EQ(ErrorOf(h + "0,ris,1,2\n"), "m.csv:2: error: 4 fields, the header has 3");
  EXPECT_EQ(ErrorOf(h + "0,ris,x\n"), "m.csv:2: error: column 'relmse': 'x' is not a number");
  EXPECT_EQ(ErrorOf(h + "0,ris, 1\n"), "m.csv:2: error: column 'relmse': ' 1' is not a number");
  EXPECT_EQ(ErrorOf(h + "1.5,ris,1\n"), "m.csv:2: error: column 'frame': '1.5' is not a frame number");
  EXPECT_EQ(ErrorOf(h + "0,ris,1\n0,ris,2\n"), "m.csv:3: error: frame 0 of preset 'ris' already appears on line 2");
  EXPECT_EQ(ErrorOf("frame,preset,rel mse\n0,ris,1\n"),
            "m.csv:1: error: column 3: 'rel mse' is not a column name (A-Z a-z 0-9 _)");
  EXPECT_EQ(ErrorOf("frame,relmse\n0,1\n"), "m.csv:1: error: the header has no 'frame' or no 'preset' column");
  EXPECT_EQ(ErrorOf("frame,preset,a,a\n0,ris,1,1\n"), "m.csv:1: error: column 'a' appears twice");
  EXPECT_EQ(ErrorOf(h + "0,ris,nan\n1,ris,inf\n"), "");  // the runner writes nan where a mean has no pixels
}

// Preset names become directories (frames/<preset>/, report_images/<preset>/).
TEST(MetricsCsv, PresetNamesThatLeaveTheRunDirectoryAreRefused) {
  for (const char* name : {"..", ".", "../../escape", "a/b", ".hidden", "", "/abs", "a\\b", "x y"})
    EXPECT_NE(ErrorOf(std::string("frame,preset,v\n0,") + name + ",1\n").find("preset"), std::string::npos) << name;
  for (const char* name : {"ris", "restir-spmis", "ris_temporal.maxHistory=8", "a+b", "v1.2"})
    EXPECT_EQ(ErrorOf(std::string("frame,preset,v\n0,") + name + ",1\n"), "") << name;
}

}  // namespace
}  // namespace restir
