// Runs the restir-sim binary as a user would: exit status and the one-line message on bad input.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/sim/sim_binary.h"

namespace {

using Result = restir::test::ShellResult;

Result RunCli(const std::string& args) { return restir::test::RunSim(args); }

class Cli : public ::testing::Test {};

TEST_F(Cli, HelpExitsZeroAndListsCommands) {
  const Result r = RunCli("--help");
  EXPECT_EQ(r.status, 0);
  for (const char* w : {"run", "validate", "presets"}) EXPECT_NE(r.output.find(w), std::string::npos) << w;
  const Result rr = RunCli("run --help");
  EXPECT_EQ(rr.status, 0);
  for (const char* w : {"--preset", "--frames", "--resolution", "--threads", "--seed", "--reference-spp",
                        "--reference-error", "--checkpoint-seconds", "--no-reference", "--out"})
    EXPECT_NE(rr.output.find(w), std::string::npos) << w;
}

TEST_F(Cli, PresetsListsRis) {
  const Result r = RunCli("presets");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("ris"), std::string::npos);
}

TEST_F(Cli, ValidatePrintsSummary) {
  const Result r = RunCli("validate sequences/window_bars_pan.json");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("window_bars_pan"), std::string::npos);
}

// Several files: each is checked; a refused one gets its one line on stderr and the files after it are still
// summarised; the exit status is 2 if any was refused, 0 if none.
TEST_F(Cli, ValidateChecksEveryFileAndExitsTwoIfAnyWasRefused) {
  const std::string bad = ::testing::TempDir() + "/restir-cli-bad-among-good.json";
  FILE* f = fopen(bad.c_str(), "w");
  fputs("{\n  \"name\": \"x\",\n  \"frames\": ,\n}\n", f);
  fclose(f);
  Result r = RunCli("validate sequences/smoke.json sequences/static_room.json");
  EXPECT_EQ(r.status, 0) << r.output;
  r = RunCli("validate sequences/smoke.json " + bad + " sequences/static_room.json");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("smoke"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("static_room"), std::string::npos) << r.output;
  const Result err = restir::test::Shell(restir::test::SimBinary() + " validate sequences/smoke.json " + bad +
                                         " sequences/static_room.json 2>&1 >/dev/null");
  EXPECT_EQ(err.output.rfind(bad + ":3:", 0), 0u) << err.output;
  EXPECT_EQ(std::count(err.output.begin(), err.output.end(), '\n'), 1) << err.output;
}

TEST_F(Cli, BadInputExitsTwoWithOneMessage) {
  const std::string tmp = ::testing::TempDir() + "/restir-cli-bad.json";
  FILE* f = fopen(tmp.c_str(), "w");
  fputs("{\n  \"name\": \"x\",\n  \"frames\": ,\n}\n", f);
  fclose(f);
  Result r = RunCli("validate " + tmp);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find(tmp + ":3:"), std::string::npos) << r.output;
  r = RunCli("run sequences/smoke.json --preset nope --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("nope"), std::string::npos);
  r = RunCli("run sequences/smoke.json --frames 3:1 --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  r = RunCli("run sequences/smoke.json --resolution 0x5 --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  // The error target is a relative standard error in [1e-4, 1], and replaces the budget rather than joining it.
  for (const char* bad : {"--reference-error 0", "--reference-error -0.01", "--reference-error 2",
                          "--reference-error nan", "--reference-error 0.01 --reference-spp 64",
                          "--reference-cap 31", "--reference-cap 64 --reference-spp 64",
                          "--checkpoint-seconds -1", "--images some", "--images 3:1", "--images 2:2",
                          "--images 1:2:3", "--images -1:", "--images a:b", "--progress-seconds -1"}) {
    r = RunCli(std::string("run sequences/smoke.json --frames 0:1 ") + bad + " --out " + ::testing::TempDir() +
               "/restir-cli-out");
    EXPECT_EQ(r.status, 2) << bad << ": " << r.output;
  }
  r = RunCli("run does/not/exist.json");
  EXPECT_EQ(r.status, 2);
  r = RunCli("run");  // missing argument
  EXPECT_EQ(r.status, 2);
}

// Where stderr is not a terminal (a batch job's log; here a pipe), progress comes as whole lines, one every
// --progress-seconds, and a last one when the run finishes; a run shorter than the interval prints none.
TEST_F(Cli, ProgressIsOneLineAWhileWhenStderrIsNotATerminal) {
  const std::string out = ::testing::TempDir() + "/restir-cli-progress";
  const std::string run = "run sequences/smoke.json --frames 0:3 --resolution 32x18 --reference-spp 16 --no-images "
                          "--no-report --cache-dir '' --out " + out;
  Result r = RunCli(run + " --progress-seconds 0");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find('\r'), std::string::npos) << r.output;
  size_t lines = 0;
  for (size_t at = r.output.find(" frames "); at != std::string::npos; at = r.output.find(" frames ", at + 1)) ++lines;
  EXPECT_GE(lines, 4u) << r.output;  // each frame's stages, and the last line
  EXPECT_NE(r.output.find("3/3 frames  finished"), std::string::npos) << r.output;
  r = RunCli(run);  // the default interval, 30 s, is longer than this run
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find(" frames "), std::string::npos) << r.output;
  r = RunCli(run + " --progress-seconds 0 --no-progress");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find(" frames "), std::string::npos) << r.output;
}

}  // namespace
