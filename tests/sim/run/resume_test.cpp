// `restir-sim run --resume`: a run killed with SIGKILL mid-sequence and resumed writes the same outputs, bit for
// bit, as an uninterrupted run (DESIGN §10; the reservoirs, accumulation and metric state are checkpointed).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include "tests/sim/sim_binary.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;

using restir::test::SimBinary;

pid_t Spawn(const std::vector<std::string>& args, const std::string& stderrPath = "/dev/null") {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, stderrPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  EXPECT_EQ(posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

int Wait(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

std::string ReadAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

int CsvRows(const fs::path& p) {
  std::ifstream f(p);
  int n = -1;  // header
  for (std::string line; std::getline(f, line);) ++n;
  return std::max(n, 0);
}

// metrics.csv without the timing columns (ms_*, reference_cached), which legitimately differ between runs.
std::string CsvWithoutTimings(const fs::path& p) {
  std::ifstream f(p);
  std::string header;
  std::getline(f, header);
  std::vector<bool> keep;
  std::stringstream hs(header);
  for (std::string col; std::getline(hs, col, ',');)
    keep.push_back(col.rfind("ms_", 0) != 0 && col != "reference_cached");
  std::string out;
  for (std::string line; std::getline(f, line);) {
    std::stringstream ls(line);
    size_t k = 0;
    for (std::string cell; std::getline(ls, cell, ','); ++k)
      if (k < keep.size() && keep[k]) out += cell + ",";
    out += "\n";
  }
  return out;
}

// The reference cache is in the run's key (run.json names it): runs copied to resume share one outside them.
// `images` is --images: which frames get their EXR and preview (every frame's scrub PNGs are written either way).
std::vector<std::string> RunArgs(const std::string& sequence, const fs::path& out, bool resume,
                                 const std::string& presets = "ris,restir-unbiased", fs::path cache = {},
                                 const std::string& images = "report") {
  if (cache.empty()) cache = out / "cache";
  std::vector<std::string> a = {SimBinary(), "run", sequence, "--preset", presets,
                                "--resolution", "192x108", "--reference-spp", "32", "--out", out.string(),
                                "--cache-dir", cache.string(), "--no-progress", "--images", images};
  if (resume) a.push_back("--resume");
  return a;
}

// The same with a checkpoint after every frame, so a kill loses no finished frame.
std::vector<std::string> EveryFrame(std::vector<std::string> args) {
  args.insert(args.end(), {"--checkpoint-seconds", "0"});
  return args;
}

// Starts the run and kills it with SIGKILL once `rows` metric rows exist; false if it finished first.
bool RunAndKill(const std::vector<std::string>& args, const fs::path& out, int rows) {
  const pid_t pid = Spawn(args);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (CsvRows(out / "metrics.csv") < rows && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGKILL);
  return WIFSIGNALED(Wait(pid));
}

// Every file under `dir` of `expected` has the same bytes in `actual`; returns how many were compared.
int ExpectSameFiles(const fs::path& expected, const fs::path& actual, const std::string& dir) {
  int compared = 0;
  if (!fs::exists(expected / dir)) return 0;
  for (const auto& e : fs::recursive_directory_iterator(expected / dir)) {
    if (!e.is_regular_file()) continue;
    const fs::path other = actual / fs::relative(e.path(), expected);
    EXPECT_TRUE(fs::exists(other)) << other;
    EXPECT_TRUE(ReadAll(e.path()) == ReadAll(other)) << other;
    ++compared;
  }
  return compared;
}

// The frame files (frames/), whose count is returned; and every frame's scrub PNGs (scrub/), the videos made from
// them and the report's images, which must match too (the scrub exposure comes from the first frame, so a resumed
// run gets it only from its checkpoint). `samePresetOrder` false: the videos and report images, laid out in the
// presets' order, are not compared.
int ExpectSameFrames(const fs::path& expected, const fs::path& actual, int frames = 6, int presets = 2,
                     bool samePresetOrder = true) {
  // Per frame the reference and the disocclusion mask; per preset the estimate, error and FLIP maps.
  EXPECT_EQ(ExpectSameFiles(expected, actual, "scrub"), frames * (2 + 3 * presets));
  if (samePresetOrder) {
    EXPECT_EQ(ExpectSameFiles(expected, actual, "videos"), presets + 1);  // one per preset, one of them all
    EXPECT_GT(ExpectSameFiles(expected, actual, "report_images"), 0);
  }
  return ExpectSameFiles(expected, actual, "frames");
}

// The presets column of metrics.csv, row by row.
std::vector<std::string> CsvPresets(const fs::path& p) {
  std::ifstream f(p);
  std::string header;
  std::getline(f, header);
  std::stringstream hs(header);
  size_t column = 0;
  for (std::string col; std::getline(hs, col, ',') && col != "preset";) ++column;
  std::vector<std::string> out;
  for (std::string line; std::getline(f, line);) {
    std::stringstream ls(line);
    std::string cell;
    for (size_t k = 0; k <= column; ++k) std::getline(ls, cell, ',');
    out.push_back(cell);
  }
  return out;
}

std::vector<std::string> SortedLines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::sort(lines.begin(), lines.end());
  return lines;
}

// Both sequences have 6 frames; the second has a sky whose sun, map rotation and intensity change every frame, which
// the checkpoint must carry for the previous frame (temporal reuse evaluates targets under last frame's sky).
class Resume : public ::testing::TestWithParam<std::string> {};

TEST_P(Resume, KilledAndResumedRunIsBitIdenticalToUninterrupted) {
  // "#gi": ReSTIR GI's presets, whose reservoirs and held vertices the checkpoint carries too (issue 41).
  const bool gi = GetParam().find("#gi") != std::string::npos;
  const std::string sequence = GetParam().substr(0, GetParam().find('#'));
  const fs::path base = fs::path(::testing::TempDir()) /
                        ("restir-resume-test-" + fs::path(sequence).stem().string() + (gi ? "-gi" : ""));
  fs::remove_all(base);
  const fs::path full = base / "full", killed = base / "killed";

  // Every frame's EXR for one sequence, the default (the report's three) for the other.
  const std::string images = sequence == "sequences/smoke.json" ? "all" : "report";
  const int frameFiles = images == "all" ? 6 : 3;
  auto args = [&](const fs::path& out, bool resume) {
    return RunArgs(sequence, out, resume, gi ? "restir-gi-unbiased,restir-gi-spmis" : "ris,restir-unbiased", {},
                   images);
  };
  const int status = Wait(Spawn(args(full, false)));
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const int totalRows = CsvRows(full / "metrics.csv");
  ASSERT_EQ(totalRows, 2 * 6);
  EXPECT_FALSE(fs::exists(full / "checkpoint.bin"));  // removed when the run completes

  // Kill once two frames are done (4 rows), wherever the third frame's work stands.
  ASSERT_TRUE(RunAndKill(args(killed, false), killed, 4)) << "the run finished before it was killed";
  const int rowsAtKill = CsvRows(killed / "metrics.csv");
  ASSERT_LT(rowsAtKill, totalRows);
  ASSERT_TRUE(fs::exists(killed / "checkpoint.bin"));

  const int resumed = Wait(Spawn(args(killed, true)));
  ASSERT_TRUE(WIFEXITED(resumed) && WEXITSTATUS(resumed) == 0);
  EXPECT_EQ(CsvWithoutTimings(full / "metrics.csv"), CsvWithoutTimings(killed / "metrics.csv"));
  EXPECT_EQ(ExpectSameFrames(full, killed), 2 * frameFiles * 2);  // EXR and PNG per frame file and preset
  // No temporary survived: the resumed run removed whatever the kill interrupted.
  for (const auto& e : fs::recursive_directory_iterator(killed))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// A checkpoint holds each preset's state by name: a run killed with the presets in one order and resumed with them
// in any of the six orders of three writes every frame file with the uninterrupted run's bits, and metrics.csv
// holds its rows (each frame's in the resumed run's order). One killed run, copied once per order.
TEST(ResumeOrder, AnyOrderOfThePresetsResumesEachPresetsOwnState) {
  const std::string sequence = "sequences/smoke.json";
  const fs::path base = fs::path(::testing::TempDir()) / "restir-resume-order-test";
  fs::remove_all(base);
  const std::vector<std::string> order = {"ris", "restir-unbiased", "restir-biased"};
  auto joined = [](const std::vector<std::string>& v) { return v[0] + "," + v[1] + "," + v[2]; };
  const fs::path full = base / "full", killed = base / "killed";
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, full, false, joined(order), base / "cache")))), 0);
  ASSERT_EQ(CsvRows(full / "metrics.csv"), 3 * 6);
  ASSERT_TRUE(RunAndKill(EveryFrame(RunArgs(sequence, killed, false, joined(order), base / "cache")), killed, 6))
      << "the run finished before it was killed";
  ASSERT_TRUE(fs::exists(killed / "checkpoint.bin"));
  std::vector<std::string> permutation = order;
  std::sort(permutation.begin(), permutation.end());
  int orders = 0;
  do {
    const fs::path resumed = base / ("resumed-" + std::to_string(orders++));
    fs::copy(killed, resumed, fs::copy_options::recursive);
    const std::string log = (base / ("resumed-" + std::to_string(orders) + ".log")).string();
    ASSERT_EQ(WEXITSTATUS(Wait(Spawn(EveryFrame(RunArgs(sequence, resumed, true, joined(permutation), base / "cache")),
                                     log))),
              0)
        << joined(permutation);
    // It resumed: a checkpoint it refused would start from frame 0 and prove nothing.
    EXPECT_NE(ReadAll(log).find("resumed at frame"), std::string::npos) << ReadAll(log);
    SCOPED_TRACE(joined(permutation));
    EXPECT_EQ(ExpectSameFrames(full, resumed, 6, 3, false), 3 * 3 * 2);
    EXPECT_EQ(SortedLines(CsvWithoutTimings(full / "metrics.csv")),
              SortedLines(CsvWithoutTimings(resumed / "metrics.csv")));
    const std::vector<std::string> presets = CsvPresets(resumed / "metrics.csv");
    ASSERT_EQ(presets.size(), 3u * 6u);
    // Rows restored from the checkpoint too follow the resumed run's order.
    for (size_t i = 0; i < presets.size(); ++i) EXPECT_EQ(presets[i], permutation[i % 3]) << "row " << i;
  } while (std::next_permutation(permutation.begin(), permutation.end()));
  EXPECT_EQ(orders, 6);
}

// A resume checks every frame file its finished frames wrote (size and checksum recorded at write): one deleted
// and one changed in place after the run completed, or after it was killed, are written again with their bits and
// named on stderr, where before the resume said "complete" or carried on past them.
TEST(ResumeOutputs, MissingOrDamagedFrameFilesAreWrittenAgain) {
  const std::string sequence = "sequences/smoke.json";
  const fs::path base = fs::path(::testing::TempDir()) / "restir-resume-outputs-test";
  fs::remove_all(base);
  const fs::path full = base / "full", damaged = base / "damaged", killed = base / "killed";
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, full, false, "ris,restir-unbiased", base / "cache")))), 0);
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, damaged, false, "ris,restir-unbiased", base / "cache")))), 0);
  // The default --images writes frames 0, 3 and 5's EXR and preview; every frame's scrub PNGs.
  fs::remove(damaged / "frames/ris/0003.exr");
  fs::remove(damaged / "scrub/presets/ris/0001_error.png");
  {
    std::string png = ReadAll(damaged / "frames/restir-unbiased/0005.png");
    png[png.size() / 2] ^= 0x40;  // same size, other bytes
    std::ofstream(damaged / "frames/restir-unbiased/0005.png", std::ios::binary | std::ios::trunc) << png;
  }
  const std::string log = (base / "damaged.log").string();
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, damaged, true, "ris,restir-unbiased", base / "cache"), log))), 0);
  const std::string said = ReadAll(log);
  EXPECT_NE(said.find("frames/ris/0003.exr is missing"), std::string::npos) << said;
  EXPECT_NE(said.find("scrub/presets/ris/0001_error.png is missing"), std::string::npos) << said;
  EXPECT_NE(said.find("frames/restir-unbiased/0005.png has other bytes"), std::string::npos) << said;
  EXPECT_EQ(ExpectSameFrames(full, damaged), 2 * 3 * 2);
  // A second resume finds every file as written: nothing to say, nothing to do.
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, damaged, true, "ris,restir-unbiased", base / "cache"), log))), 0);
  EXPECT_EQ(ReadAll(log).find("restir-sim: "), std::string::npos) << ReadAll(log);
  // Stopped while its report was made (run.json already complete): a resume makes the report and videos again.
  fs::remove(damaged / "report.html");
  fs::remove(damaged / "summary.json");
  fs::remove_all(damaged / "videos");
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(RunArgs(sequence, damaged, true, "ris,restir-unbiased", base / "cache"), log))), 0);
  EXPECT_NE(ReadAll(log).find("already complete (run.json); wrote its missing report"), std::string::npos)
      << ReadAll(log);
  EXPECT_TRUE(fs::exists(damaged / "report.html"));
  EXPECT_TRUE(fs::exists(damaged / "summary.json"));
  EXPECT_EQ(ExpectSameFrames(full, damaged), 2 * 3 * 2);  // the videos too, to the byte

  ASSERT_TRUE(RunAndKill(EveryFrame(RunArgs(sequence, killed, false, "ris,restir-unbiased", base / "cache")), killed, 6))
      << "the run finished before it was killed";
  ASSERT_TRUE(fs::exists(killed / "checkpoint.bin"));
  fs::remove(killed / "frames/ris/0000.exr");
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(EveryFrame(RunArgs(sequence, killed, true, "ris,restir-unbiased", base / "cache")), log))), 0);
  EXPECT_NE(ReadAll(log).find("frames/ris/0000.exr is missing"), std::string::npos) << ReadAll(log);
  EXPECT_EQ(ExpectSameFrames(full, killed), 2 * 3 * 2);
  EXPECT_EQ(CsvWithoutTimings(full / "metrics.csv"), CsvWithoutTimings(killed / "metrics.csv"));
}

// An ensemble's converged-image columns (ensemble_accum_rmspe*) read every member's running mean since the scene
// state last changed: on a static sequence, killed after two frames and resumed, they come back only if the
// checkpoint carried the other members' running sums, not just member 0's.
TEST(ResumeEnsemble, MembersRunningMeansSurviveTheCheckpoint) {
  const fs::path base = fs::path(::testing::TempDir()) / "restir-resume-ensemble-test";
  fs::remove_all(base);
  const fs::path full = base / "full", killed = base / "killed";
  auto args = [&](const fs::path& out, bool resume) {
    std::vector<std::string> a = {SimBinary(), "run", "sequences/static_room.json", "--preset", "restir-vis",
                                  "--resolution", "96x54", "--frames", "0:5", "--ensemble", "3",
                                  "--reference-spp", "32", "--out", out.string(), "--cache-dir",
                                  (base / "cache").string(), "--no-progress", "--no-images"};
    if (resume) a.push_back("--resume");
    return EveryFrame(a);
  };
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(args(full, false)))), 0);
  ASSERT_EQ(CsvRows(full / "metrics.csv"), 5);
  ASSERT_NE(ReadAll(full / "metrics.csv").find("ensemble_accum_rmspe_bias_high"), std::string::npos);
  ASSERT_TRUE(RunAndKill(args(killed, false), killed, 2)) << "the run finished before it was killed";
  ASSERT_TRUE(fs::exists(killed / "checkpoint.bin"));
  const std::string log = (base / "resumed.log").string();
  ASSERT_EQ(WEXITSTATUS(Wait(Spawn(args(killed, true), log))), 0);
  EXPECT_NE(ReadAll(log).find("resumed at frame"), std::string::npos) << ReadAll(log);
  EXPECT_EQ(CsvWithoutTimings(full / "metrics.csv"), CsvWithoutTimings(killed / "metrics.csv"));
}

INSTANTIATE_TEST_SUITE_P(Sequences, Resume,
                         ::testing::Values("sequences/smoke.json", "tests/data/sky_smoke.json",
                                           "tests/data/sky_smoke.json#gi"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           const std::string& p = info.param;
                           return fs::path(p.substr(0, p.find('#'))).stem().string() +
                                  (p.find("#gi") != std::string::npos ? "_gi" : "");
                         });

}  // namespace
