// `restir-sim compare` (sim/metrics/compare.h): the batch-means t-test on fixed numbers, identical runs, and the CLI.
#include "sim/metrics/compare.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sim/scene/sequence.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

// 32 frames of a noisy metric (uniform noise of +-0.3 around 1, rounded; fixed numbers).
const std::vector<double> kA = {1.074, 1.145, 1.177, 1.265, 1.144, 1.253, 0.717, 0.979, 1.266, 1.089, 1.241,
                                0.768, 0.981, 0.848, 1.026, 1.044, 0.708, 0.83,  0.868, 1.25,  1.159, 0.796,
                                1.178, 0.783, 1.07,  0.776, 0.701, 1.223, 0.826, 0.829, 1.289, 1.223};
// kA plus independent noise of +-0.3 and no shift: the batch means of B - A are 0.0955, -0.0874, -0.0431, 0.0121,
// so t = -0.145 with 3 degrees of freedom (p = 0.89).
const std::vector<double> kNoisy = {0.948, 1.422, 1.201, 1.372, 0.967, 1.518, 0.831, 1.259, 1.502, 0.968, 1.158,
                                    0.568, 0.768, 0.587, 0.907, 1.106, 0.41,  0.937, 0.771, 1.136, 1.35,  0.784,
                                    1.067, 0.772, 1.193, 0.51,  0.986, 0.937, 0.976, 1.036, 1.0,   1.396};

TEST(Compare, StudentTPValueMatchesTables) {
  EXPECT_NEAR(StudentTTwoSidedP(0.0, 5), 1.0, 1e-12);
  EXPECT_NEAR(StudentTTwoSidedP(12.706204736, 1), 0.05, 1e-6);  // t_{0.975, 1}
  EXPECT_NEAR(StudentTTwoSidedP(3.182446305, 3), 0.05, 1e-6);   // t_{0.975, 3}
  EXPECT_NEAR(StudentTTwoSidedP(-2.228138852, 10), 0.05, 1e-6);  // symmetric
  EXPECT_NEAR(StudentTTwoSidedP(2.0, 10), 0.0733880, 1e-6);
  EXPECT_NEAR(StudentTTwoSidedP(1.959963985, 100000), 0.05, 1e-4);  // tends to the normal
}

TEST(Compare, LargeShiftIsSignificant) {
  std::vector<double> b = kNoisy;
  for (double& x : b) x += 0.5;  // the same noise, shifted by half the mean
  const ColumnComparison c = CompareSeries("relmse", kA, b);
  EXPECT_EQ(c.verdict, CompareVerdict::kSignificant);
  EXPECT_EQ(c.batches, 4);
  EXPECT_LT(c.p, 0.002);  // batch means 0.60, 0.41, 0.46, 0.51: t = 12.5 with 3 dof, p = 0.0011
  EXPECT_GT(c.meanB, c.meanA);
  EXPECT_NEAR(c.relativeChange, (c.meanB - c.meanA) / c.meanA, 1e-12);
}

TEST(Compare, PureNoiseDifferenceIsNotSignificant) {
  const ColumnComparison c = CompareSeries("relmse", kA, kNoisy);
  EXPECT_EQ(c.verdict, CompareVerdict::kNotSignificant);
  EXPECT_NEAR(c.t, -0.14514, 1e-4);
  EXPECT_GT(c.p, 0.8);
}

TEST(Compare, FewerThanFourBatchesIsTooFewFrames) {
  const std::vector<double> a(kA.begin(), kA.begin() + 31), b(kNoisy.begin(), kNoisy.begin() + 31);
  const ColumnComparison c = CompareSeries("relmse", a, b);  // 3 whole batches of 8
  EXPECT_EQ(c.verdict, CompareVerdict::kTooFewFrames);
  EXPECT_EQ(c.batches, 3);
}

fs::path WriteRun(const std::string& name, const std::vector<double>& relmse, const std::vector<double>& ms,
                  const std::string& hashSuffix) {
  const fs::path dir = fs::path(::testing::TempDir()) / (name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream f(dir / "metrics.csv");
  f << "frame,preset,ms_frame,relmse,image_hash\n";
  for (size_t i = 0; i < relmse.size(); ++i)
    for (const char* preset : {"ris", "temporal"})
      f << i << "," << preset << "," << ms[i] << "," << relmse[i] << "," << preset << i << hashSuffix << "\n";
  return dir;
}

TEST(Compare, IdenticalRunsAreReportedIdentical) {
  const fs::path a = WriteRun("restir-compare-a", kA, kNoisy, "");
  const fs::path b = WriteRun("restir-compare-a2", kA, kNoisy, "");
  const RunComparison c = CompareRuns(a.string(), b.string());
  ASSERT_EQ(c.presets.size(), 2u);
  for (const PresetComparison& p : c.presets) {
    EXPECT_EQ(p.frames, 32);
    EXPECT_EQ(p.imageHashesDiffering, 0);
    ASSERT_EQ(p.columns.size(), 2u);
    for (const ColumnComparison& col : p.columns) EXPECT_EQ(col.verdict, CompareVerdict::kIdentical) << col.column;
  }
  const std::string text = FormatComparison(c);
  EXPECT_NE(text.find("image_hash identical in every frame"), std::string::npos) << text;
  EXPECT_NE(text.find("identical in both runs (2): ms_frame, relmse"), std::string::npos) << text;
}

TEST(Compare, RunsWithAShiftedMetricFlagOnlyThatColumn) {
  std::vector<double> shifted = kNoisy;
  for (double& x : shifted) x += 0.5;
  const fs::path a = WriteRun("restir-compare-b", kA, kNoisy, "");
  const fs::path b = WriteRun("restir-compare-b2", shifted, kNoisy, "x");  // relmse shifted, images differ
  const RunComparison c = CompareRuns(a.string(), (b / "metrics.csv").string());
  ASSERT_EQ(c.presets.size(), 2u);
  EXPECT_EQ(c.presets[0].imageHashesDiffering, 32);
  EXPECT_EQ(c.presets[0].columns[0].column, "ms_frame");
  EXPECT_EQ(c.presets[0].columns[0].verdict, CompareVerdict::kIdentical);
  EXPECT_EQ(c.presets[0].columns[1].column, "relmse");
  EXPECT_EQ(c.presets[0].columns[1].verdict, CompareVerdict::kSignificant);
  EXPECT_NE(FormatComparison(c).find("SIGNIFICANT"), std::string::npos);
  EXPECT_THROW(CompareRuns(a.string(), (a / "missing").string()), InputError);
}

int RunCli(const std::string& args, std::string& output) {
  const restir::test::ShellResult r = restir::test::RunSim(args);
  output += r.output;
  return r.status;
}

TEST(CompareCli, PrintsTableAndExitsZeroOrTwoOnBadInput) {
  const fs::path a = WriteRun("restir-compare-cli-a", kA, kNoisy, "");
  const fs::path b = WriteRun("restir-compare-cli-b", kNoisy, kNoisy, "x");
  std::string out;
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 0) << out;
  EXPECT_NE(out.find("paired t-test on the means of batches of 8"), std::string::npos) << out;
  EXPECT_NE(out.find("not significant"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(RunCli("compare " + a.string() + " " + (a / "nope").string(), out), 2) << out;
  out.clear();
  std::ofstream(b / "metrics.csv", std::ios::app) << "40,ris,1\n";  // too few fields on line 66
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 2) << out;
  EXPECT_NE(out.find((b / "metrics.csv").string() + ":66:"), std::string::npos) << out;
}

// compare pairs frames by number, which is the same image only within one sequence: two runs whose run.json name
// other sequences are refused, and so is a metrics.csv whose rows are not its run.json's (a frame outside its
// range, a preset it did not run). Runs without a run.json are compared as before.
TEST(CompareCli, RunsOfOtherSequencesOrRowsThatAreNotTheRunsAreRefused) {
  const fs::path a = WriteRun("restir-compare-cli-seq-a", kA, kNoisy, "");
  const fs::path b = WriteRun("restir-compare-cli-seq-b", kNoisy, kNoisy, "x");
  auto runJson = [](const fs::path& dir, const std::string& hash, int end, bool withRis = true) {
    nlohmann::json presets = {{"temporal", nlohmann::json::object()}};
    if (withRis) presets["ris"] = nlohmann::json::object();
    std::ofstream(dir / "run.json")
        << nlohmann::json{{"sequence", {{"contentHash", hash}}}, {"frames", {0, end}}, {"presets", presets}}.dump();
  };
  std::string out;
  runJson(a, "00000000000000aa", int(kA.size()));
  runJson(b, "00000000000000aa", int(kA.size()));
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 0) << out;
  out.clear();
  runJson(b, "00000000000000bb", int(kA.size()));
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 2) << out;
  EXPECT_NE(out.find("sequence 00000000000000bb is not"), std::string::npos) << out;
  out.clear();
  runJson(b, "00000000000000aa", 10);
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 2) << out;
  EXPECT_NE(out.find("frame 10 of preset ris is outside"), std::string::npos) << out;
  out.clear();
  runJson(b, "00000000000000aa", int(kA.size()), false);
  EXPECT_EQ(RunCli("compare " + a.string() + " " + b.string(), out), 2) << out;
  EXPECT_NE(out.find("preset ris is not one of"), std::string::npos) << out;
}

}  // namespace
}  // namespace restir
