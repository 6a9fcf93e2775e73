// A sweep's jobs as separate processes started all at once into one output directory and one reference cache,
// as `xargs -P` or a job array starts them: every job succeeds (their temporary areas and the cache's lock do
// not trip each other), and the merge equals the one-process sweep except timings.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/sim/sim_binary.h"
#include "tests/sim/sweep_fixtures.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::ReadText;
using test::WithoutTimings;

TEST(SweepProcesses, JobsStartedAtOnceIntoOneDirectoryMergeToTheLocalSweep) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-sweep-processes";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path sweep = dir / "s.json";
  std::ofstream(sweep) << R"({"sequences": [")" << fs::absolute("sequences/smoke.json").string() << R"(", ")"
                       << fs::absolute("sequences/hard/many_lights.json").string() << R"("],
    "resolution": [40, 24], "frames": [0, 3], "referenceSpp": 16, "seedCount": 3,
    "presets": ["ris", "restir-unbiased"]})";
  const std::string s = sweep.string(), out = (dir / "jobs").string(), cache = (dir / "cache").string();
  const test::ShellResult local = test::RunSim("sweep " + s + " --out " + (dir / "local").string() +
                                               " --cache-dir " + (dir / "cache-local").string());
  ASSERT_EQ(local.status, 0) << local.output;
  constexpr int kJobs = 2 * 2 * 3;
  std::vector<pid_t> pids;
  for (int k = 0; k < kJobs; ++k)
    pids.push_back(test::SpawnSim({"sweep", s, "--out", out, "--cache-dir", cache, "--threads", "1", "--job",
                          std::to_string(k)},
                                   (dir / ("log" + std::to_string(k))).string()));
  for (int k = 0; k < kJobs; ++k) {
    EXPECT_EQ(test::WaitSim(pids[size_t(k)]), 0) << ReadText(dir / ("log" + std::to_string(k)));
  }
  const test::ShellResult plan = test::RunSim("sweep " + s + " --out " + out + " --plan --missing");
  EXPECT_EQ(plan.status, 0);
  EXPECT_EQ(plan.output, "");  // nothing missing
  const test::ShellResult merge = test::RunSim("sweep " + s + " --out " + out + " --merge");
  ASSERT_EQ(merge.status, 0) << merge.output;
  EXPECT_NE(merge.output.find("merged 12 of 12 jobs"), std::string::npos) << merge.output;
  EXPECT_EQ(WithoutTimings(ReadText(fs::path(out) / "sweep.csv")), WithoutTimings(ReadText(dir / "local" / "sweep.csv")));
  EXPECT_FALSE(fs::exists(fs::path(out) / ".restir-sim-tmp"));
  EXPECT_FALSE(fs::exists(fs::path(cache) / ".restir-sim-tmp"));
}

TEST(SweepProcesses, BadJobAndPlanArgumentsExitTwoWithOneLine) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-sweep-args";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path sweep = dir / "s.json";
  std::ofstream(sweep) << R"({"sequence": ")" << fs::absolute("sequences/smoke.json").string()
                       << R"(", "resolution": [8, 8], "frames": [0, 1], "presets": ["ris"]})";
  const std::string s = sweep.string();
  for (const char* args : {"--job 7", "--job smoke/ris/seed-8", "--job -1", "--plan --job 0",
                           "--merge --plan", "--missing", "--plan --format xml"}) {
    const test::ShellResult r = test::RunSim("sweep " + s + " --out " + (dir / "o").string() + " " + args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.output;
  }
  const test::ShellResult r = test::RunSim("sweep " + s + " --out " + (dir / "o").string() + " --job 3");
  EXPECT_NE(r.output.find("no job 3 (the plan has jobs 0 to 0)"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace restir
