// `restir-sim sweep`: the grid expands as documented, bad files are located, summaries and the Pareto front
// are what the definitions give, and a real (tiny) sweep writes its three reports.
#include "sim/sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "sim/sequence.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

std::string WriteTemp(const std::string& name, const std::string& text) {
  const fs::path p = fs::path(::testing::TempDir()) / name;
  std::ofstream(p) << text;
  return p.string();
}

// The sweep file sits in the temporary directory; its sequence path is relative to it.
std::string SmokePath() { return fs::absolute("sequences/smoke.json").string(); }

TEST(Sweep, GridIsPresetsTimesValuesInFileOrderThenConfigs) {
  const std::string path = WriteTemp("sweep-grid.json", R"({
  "sequence": ")" + SmokePath() + R"(",
  "presets": ["restir-unbiased", "restir-spmis"],
  "grid": {"spatial.neighbours": [3, 5], "spatial.radius": [10, 30.5]},
  "configs": [{"name": "spmis N8", "preset": "restir-spmis", "set": {"spatial.draws": 8}}]
})");
  const SweepSpec s = LoadSweep(path);
  ASSERT_EQ(s.configs.size(), 2u * 2u * 2u + 1u);
  EXPECT_EQ(s.configs[0].name, "restir-unbiased_spatial.neighbours=3_spatial.radius=10");
  EXPECT_EQ(s.configs[1].name, "restir-unbiased_spatial.neighbours=3_spatial.radius=30.5");
  EXPECT_EQ(s.configs[2].overrides, (std::vector<std::string>{"spatial.neighbours=5", "spatial.radius=10"}));
  EXPECT_EQ(s.configs[4].preset, "restir-spmis");
  EXPECT_EQ(s.configs[8].name, "spmis_N8");  // made safe for a directory name
  EXPECT_EQ(s.configs[8].overrides, (std::vector<std::string>{"spatial.draws=8"}));
}

TEST(Sweep, BadFilesNameFileLineColumnAndPath) {
  struct Case {
    std::string text, expect;
  };
  const std::string seq = "\"sequence\": \"" + SmokePath() + "\"";
  const std::vector<Case> cases = {
      {"{" + seq + ", \"presets\": [\"restir-fast\"]}", ":1:" /* same line */},
      {"{\n" + seq + ",\n\"presets\": [\"ris\"],\n\"grid\": {\"spatial.neighbors\": [3]}\n}", ":4:"},
      {"{\n" + seq + ",\n\"presetz\": [\"ris\"]\n}", ":3:1: error at /presetz: unknown key"},
      {"{\n" + seq + ",\n\"configs\": [{\"name\": \"a\", \"preset\": \"ris\", \"set\": {\"initial.candidates\": -4}}]\n}",
       ":3:"},
      {"{\n" + seq + "\n}", "no configurations"},
      {"{\"sequence\": \"nope.json\", \"presets\": [\"ris\"]}", "error at /sequence: no sequence file"},
      {"{\n" + seq + ",\n\"presets\": [\"ris\"],,\n}", "invalid JSON"},
  };
  for (const Case& c : cases) {
    const std::string path = WriteTemp("sweep-bad.json", c.text);
    try {
      LoadSweep(path);
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ":", 0), 0u) << m;
      EXPECT_NE(m.find(c.expect), std::string::npos) << m << "\n  want: " << c.expect;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
}

FrameMetricsRow Row(int frame, double relmse, double ms, double disoccRecent, double relmseDisocc) {
  FrameMetricsRow r;
  r.frame = frame;
  r.preset = "ris";
  r.values = {{"ms_frame", ms},          {"rays_per_pixel_initial", 1.0}, {"rays_per_pixel_shade", 1.0},
              {"relmse", relmse},        {"luma_sum", 9.0},               {"reference_luma_sum", 10.0},
              {"relmse_disocc", relmseDisocc}, {"flicker", 0.5},          {"disocc_recent_fraction", disoccRecent}};
  return r;
}

TEST(Sweep, SummaryMeansFollowTheDefinitions) {
  const std::vector<FrameMetricsRow> rows = {Row(0, 0.4, 100.0, 0.0, 0.0), Row(1, 0.2, 20.0, 0.1, 0.8),
                                             Row(2, 0.3, 30.0, 0.0, 0.0)};
  const SweepPoint p = Summarize(SweepConfig{"c", "ris", {}}, rows);
  EXPECT_DOUBLE_EQ(p.relmse, 0.3);
  EXPECT_DOUBLE_EQ(p.relmseDisocc, 0.8);     // only frame 1 had revealed pixels
  EXPECT_DOUBLE_EQ(p.msPerFrame, 25.0);      // the first frame's time is skipped
  EXPECT_DOUBLE_EQ(p.shadowRaysPerPixel, 2.0);
  EXPECT_DOUBLE_EQ(p.lumaRatio, 0.9);
  EXPECT_DOUBLE_EQ(p.efficiency, 1.0 / (0.3 * 0.025));
  EXPECT_TRUE(std::isnan(p.flip));           // no flip column
}

TEST(Sweep, ParetoFrontKeepsOnlyUndominatedPoints) {
  std::vector<SweepPoint> pts(4);
  pts[0].msPerFrame = 10, pts[0].relmse = 0.5;  // fastest
  pts[1].msPerFrame = 20, pts[1].relmse = 0.3;  // trade-off
  pts[2].msPerFrame = 25, pts[2].relmse = 0.4;  // dominated by 1
  pts[3].msPerFrame = 40, pts[3].relmse = 0.1;  // most accurate
  MarkPareto(pts);
  EXPECT_TRUE(pts[0].pareto);
  EXPECT_TRUE(pts[1].pareto);
  EXPECT_FALSE(pts[2].pareto);
  EXPECT_TRUE(pts[3].pareto);
}

TEST(Sweep, EqualTimeTablePicksTheBestConfigurationWithinBudget) {
  SweepSpec spec;
  spec.path = "x.json";
  std::vector<SweepPoint> pts(3);
  pts[0].config = {"fast", "a", {}}, pts[0].msPerFrame = 10, pts[0].relmse = 0.5;
  pts[1].config = {"slow", "a", {}}, pts[1].msPerFrame = 30, pts[1].relmse = 0.2;
  pts[2].config = {"mid", "b", {}}, pts[2].msPerFrame = 10.4, pts[2].relmse = 0.3;
  const std::string md = SweepMarkdown(spec, pts);
  // At 10 ms (b's 10.4 is within 5%): a's fast config and b's mid; at 30 ms a's slow one.
  EXPECT_NE(md.find("| 10 | 0.5000 (fast) | 0.3000 (mid) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 30 | 0.2000 (slow) | 0.3000 (mid) |"), std::string::npos) << md;
}

TEST(Sweep, TinySweepWritesCsvPlotAndTables) {
  const fs::path out = fs::path(::testing::TempDir()) / "restir-sweep-run";
  fs::remove_all(out);
  const std::string path = WriteTemp("sweep-run.json", R"({
  "sequence": ")" + SmokePath() + R"(", "resolution": [48, 27], "frames": [0, 3], "referenceSpp": 32,
  "presets": ["ris", "restir-unbiased"], "grid": {"initial.candidates": [4, 16]}
})");
  SweepSpec spec = LoadSweep(path);
  spec.base.progress = false;
  spec.base.cacheDir = (out / "cache").string();
  const std::vector<SweepPoint> pts = RunSweep(spec, out.string());
  ASSERT_EQ(pts.size(), 4u);
  for (const SweepPoint& p : pts) {
    EXPECT_TRUE(std::isfinite(p.relmse) && p.relmse > 0.0) << p.config.name;
    EXPECT_TRUE(fs::exists(out / "runs" / p.config.name / "metrics.csv")) << p.config.name;
  }
  // More candidates, less error (same preset, same frames and seed): 16 vs 4 candidates for ris.
  EXPECT_LT(pts[1].relmse, pts[0].relmse);
  std::ifstream csv(out / "sweep.csv");
  int lines = 0;
  for (std::string l; std::getline(csv, l);) ++lines;
  EXPECT_EQ(lines, 5);
  std::ifstream svg(out / "sweep.svg");
  const std::string s((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  int circles = 0;
  for (size_t k = s.find("<circle"); k != std::string::npos; k = s.find("<circle", k + 1)) ++circles;
  EXPECT_EQ(circles, 4 + 2);  // one per configuration, one per preset in the legend
  EXPECT_TRUE(fs::exists(out / "sweep.md"));
}

}  // namespace
}  // namespace restir
