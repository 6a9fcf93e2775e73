// The reference cache shared by many processes (a sweep's jobs on one machine or a cluster's shared file system):
// concurrent runs render each reference once, agree to the bit, leave only whole entries; a damaged entry is
// rendered again, never used; a process waiting for another's entry reads it instead of rendering it. Real
// processes of the restir-sim binary, as a job array would start them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "sim/util/atomic_file.h"
#include "sim/metrics/metrics_csv.h"
#include "sim/reference/reference_cache.h"
#include "tests/sim/sim_binary.h"
#include "tests/sim/sweep_fixtures.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::ReadText;

// Starts restir-sim with `args`; its output goes to `log`.
pid_t Spawn(const std::vector<std::string>& args, const fs::path& log) { return test::SpawnSim(args, log.string()); }
int Wait(pid_t pid) { return test::WaitSim(pid); }

constexpr int kWidth = 64, kHeight = 36, kFrames = 4;

std::vector<std::string> RunArgs(const fs::path& cache, const fs::path& out) {
  return {"run", "sequences/smoke.json", "--preset", "ris", "--resolution", std::to_string(kWidth) + "x" +
          std::to_string(kHeight), "--frames", "0:" + std::to_string(kFrames), "--reference-spp", "64", "--threads",
          "1", "--no-images", "--no-progress", "--cache-dir", cache.string(), "--out", out.string()};
}

// Per frame: (reference_cached, the row's values other than timings, the image hash).
struct FrameRow {
  double cached = -1;
  std::vector<double> values;
  std::string hash;
};
std::vector<FrameRow> Rows(const fs::path& out) {
  const MetricsTable t = ReadMetricsCsv((out / "metrics.csv").string());
  const PresetSeries& s = t.presets.at(0);
  std::vector<FrameRow> rows(s.frames.size());
  for (size_t c = 0; c < t.columns.size(); ++c)
    for (size_t k = 0; k < rows.size(); ++k) {
      if (t.columns[c] == "reference_cached") rows[k].cached = s.values[c][k];
      else if (t.columns[c].rfind("ms_", 0) != 0) rows[k].values.push_back(s.values[c][k]);
    }
  for (size_t k = 0; k < rows.size(); ++k) rows[k].hash = s.imageHashes[k];
  return rows;
}

// Every ref-<key>.bin decodes as the answer to its own key at the run's size.
void ExpectWholeEntries(const fs::path& cache, size_t expected) {
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(cache)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".bin") continue;
    ++entries;
    const std::string key = name.substr(4, name.size() - 8);
    ImageRgb mean, se;
    std::vector<float> lumaSe;
    std::string problem;
    EXPECT_TRUE(DecodeReferenceCacheEntry(ReadText(e.path()), key, kWidth, kHeight, mean, se, lumaSe, problem))
        << name << ": " << problem;
  }
  EXPECT_EQ(entries, expected);
  EXPECT_FALSE(fs::exists(cache / ".restir-sim-tmp")) << "a temporary area was left behind";
}

fs::path Fresh(const std::string& name) {
  const fs::path p = fs::path(::testing::TempDir()) / name;
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

TEST(ReferenceCacheProcesses, ConcurrentRunsRenderEachReferenceOnceAndAgree) {
  const fs::path dir = Fresh("restir-cache-concurrent");
  const fs::path cache = dir / "cache";
  constexpr int kProcesses = 6;
  std::vector<pid_t> pids;
  for (int k = 0; k < kProcesses; ++k) {
    const fs::path out = dir / ("out" + std::to_string(k));
    pids.push_back(Spawn(RunArgs(cache, out), dir / ("log" + std::to_string(k))));
  }
  for (int k = 0; k < kProcesses; ++k)
    ASSERT_EQ(Wait(pids[size_t(k)]), 0) << ReadText(dir / ("log" + std::to_string(k)));
  const std::vector<FrameRow> first = Rows(dir / "out0");
  ASSERT_EQ(first.size(), size_t(kFrames));
  std::vector<int> rendered(kFrames, 0);
  for (int k = 0; k < kProcesses; ++k) {
    const std::vector<FrameRow> rows = Rows(dir / ("out" + std::to_string(k)));
    for (int f = 0; f < kFrames; ++f) {
      EXPECT_EQ(rows[size_t(f)].values, first[size_t(f)].values) << "process " << k << " frame " << f;
      EXPECT_EQ(rows[size_t(f)].hash, first[size_t(f)].hash);
      rendered[size_t(f)] += rows[size_t(f)].cached == 0.0;
    }
  }
  // The lock: one process rendered each frame's reference, the others waited for it and read it.
  for (int f = 0; f < kFrames; ++f) EXPECT_EQ(rendered[size_t(f)], 1) << "frame " << f;
  ExpectWholeEntries(cache, kFrames);
}

TEST(ReferenceCacheProcesses, DamagedEntriesAreRenderedAgainNeverUsed) {
  const fs::path dir = Fresh("restir-cache-damaged");
  const fs::path cache = dir / "cache";
  ASSERT_EQ(Wait(Spawn(RunArgs(cache, dir / "clean"), dir / "log0")), 0) << ReadText(dir / "log0");
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(cache))
    if (e.path().extension() == ".bin") entries.push_back(e.path());
  std::sort(entries.begin(), entries.end());
  ASSERT_EQ(entries.size(), size_t(kFrames));
  // Three kinds of damage a shared file system can produce: a cut copy, a flipped bit, another entry's bytes.
  fs::resize_file(entries[0], fs::file_size(entries[0]) / 2);
  {
    std::fstream f(entries[1], std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(fs::file_size(entries[1]) / 2));
    f.put('\x55');
  }
  fs::copy_file(entries[3], entries[2], fs::copy_options::overwrite_existing);
  ASSERT_EQ(Wait(Spawn(RunArgs(cache, dir / "again"), dir / "log1")), 0);
  const std::string log = ReadText(dir / "log1");
  int warnings = 0;
  for (size_t k = log.find("unusable reference cache entry"); k != std::string::npos;
       k = log.find("unusable reference cache entry", k + 1))
    ++warnings;
  EXPECT_EQ(warnings, 3) << log;
  const std::vector<FrameRow> clean = Rows(dir / "clean"), again = Rows(dir / "again");
  int rendered = 0;
  for (int f = 0; f < kFrames; ++f) {
    EXPECT_EQ(again[size_t(f)].values, clean[size_t(f)].values) << "frame " << f;
    rendered += again[size_t(f)].cached == 0.0;
  }
  EXPECT_EQ(rendered, 3);
  ExpectWholeEntries(cache, kFrames);  // rewritten whole
}

TEST(ReferenceCacheProcesses, AWaiterReadsTheEntryTheHolderWrote) {
  const fs::path dir = Fresh("restir-cache-waiter");
  const fs::path cache = dir / "cache";
  ASSERT_EQ(Wait(Spawn(RunArgs(cache, dir / "first"), dir / "log0")), 0) << ReadText(dir / "log0");
  // Take every entry's lock as another process rendering them would, and take the entries away.
  std::vector<std::unique_ptr<FileLock>> locks;
  std::map<fs::path, std::string> saved;
  for (const auto& e : fs::directory_iterator(cache)) {
    if (e.path().extension() == ".lock") locks.push_back(std::make_unique<FileLock>(e.path().string()));
    if (e.path().extension() == ".bin") saved[e.path()] = ReadText(e.path());
  }
  ASSERT_EQ(locks.size(), size_t(kFrames));
  for (const auto& [path, bytes] : saved) fs::remove(path);
  const pid_t waiter = Spawn(RunArgs(cache, dir / "waiter"), dir / "log1");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  // It cannot have finished: frame 0's reference is locked.
  EXPECT_EQ(waitpid(waiter, nullptr, WNOHANG), 0) << "the run did not wait for the lock";
  for (const auto& [path, bytes] : saved) std::ofstream(path, std::ios::binary) << bytes;  // "the holder wrote it"
  locks.clear();
  ASSERT_EQ(Wait(waiter), 0) << ReadText(dir / "log1");
  const std::vector<FrameRow> first = Rows(dir / "first"), waited = Rows(dir / "waiter");
  for (int f = 0; f < kFrames; ++f) {
    EXPECT_EQ(waited[size_t(f)].cached, 1.0) << "frame " << f << " was rendered again";
    EXPECT_EQ(waited[size_t(f)].values, first[size_t(f)].values);
  }
}

}  // namespace
}  // namespace restir
