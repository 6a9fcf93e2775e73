// `restir-sim run --resume`: a run killed with SIGKILL mid-sequence and resumed writes the same outputs, bit for
// bit, as an uninterrupted run (DESIGN §10; the reservoirs, accumulation and metric state are checkpointed).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include "sim_binary.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;

using restir::test::SimBinary;

pid_t Spawn(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
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

std::vector<std::string> RunArgs(const std::string& sequence, const fs::path& out, bool resume) {
  std::vector<std::string> a = {SimBinary(), "run", sequence, "--preset", "ris,restir-unbiased",
                                "--resolution", "192x108", "--reference-spp", "32", "--out", out.string(),
                                "--cache-dir", (out / "cache").string(), "--no-progress"};
  if (resume) a.push_back("--resume");
  return a;
}

// Both sequences have 6 frames; the second has a sky whose sun, map rotation and intensity change every frame, which
// the checkpoint must carry for the previous frame (temporal reuse evaluates targets under last frame's sky).
class Resume : public ::testing::TestWithParam<std::string> {};

TEST_P(Resume, KilledAndResumedRunIsBitIdenticalToUninterrupted) {
  const std::string sequence = GetParam();
  const fs::path base = fs::path(::testing::TempDir()) / ("restir-resume-test-" + fs::path(sequence).stem().string());
  fs::remove_all(base);
  const fs::path full = base / "full", killed = base / "killed";

  const int status = Wait(Spawn(RunArgs(sequence, full, false)));
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const int totalRows = CsvRows(full / "metrics.csv");
  ASSERT_EQ(totalRows, 2 * 6);
  EXPECT_FALSE(fs::exists(full / "checkpoint.bin"));  // removed when the run completes

  // Kill once two frames are done (4 rows), wherever the third frame's work stands.
  const pid_t pid = Spawn(RunArgs(sequence, killed, false));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (CsvRows(killed / "metrics.csv") < 4 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGKILL);
  const int killedStatus = Wait(pid);
  ASSERT_TRUE(WIFSIGNALED(killedStatus)) << "the run finished before it could be killed";
  const int rowsAtKill = CsvRows(killed / "metrics.csv");
  ASSERT_LT(rowsAtKill, totalRows);
  ASSERT_TRUE(fs::exists(killed / "checkpoint.bin"));

  const int resumed = Wait(Spawn(RunArgs(sequence, killed, true)));
  ASSERT_TRUE(WIFEXITED(resumed) && WEXITSTATUS(resumed) == 0);
  EXPECT_EQ(CsvWithoutTimings(full / "metrics.csv"), CsvWithoutTimings(killed / "metrics.csv"));
  int compared = 0;
  for (const auto& e : fs::recursive_directory_iterator(full / "frames")) {
    if (!e.is_regular_file()) continue;
    const fs::path other = killed / fs::relative(e.path(), full);
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(ReadAll(e.path()), ReadAll(other)) << other;
    ++compared;
  }
  EXPECT_EQ(compared, 2 * 6 * 2);  // EXR and PNG per frame and preset
  // No temporary survived: the resumed run removed whatever the kill interrupted.
  for (const auto& e : fs::recursive_directory_iterator(killed))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

INSTANTIATE_TEST_SUITE_P(Sequences, Resume, ::testing::Values("sequences/smoke.json", "tests/data/sky_smoke.json"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return fs::path(info.param).stem().string();
                         });

}  // namespace
