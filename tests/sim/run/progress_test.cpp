// sim/run/progress.h where stderr is not a terminal (here a file): a stage that runs longer than the interval gets
// its lines from the log thread while it runs, not only when the next stage starts; a short run prints nothing.
#include "sim/run/progress.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

namespace restir {
namespace {

// What `body` writes to stderr, caught in a file.
template <class F>
std::string CaptureStderr(F body) {
  const std::string path = ::testing::TempDir() + "/restir-progress-" + std::to_string(::getpid()) + ".txt";
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  FILE* file = std::fopen(path.c_str(), "w");
  EXPECT_TRUE(file);
  if (!file) return {};
  ::dup2(::fileno(file), STDERR_FILENO);
  body();
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::fclose(file);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  std::remove(path.c_str());
  return text.str();
}

size_t Lines(const std::string& text, const std::string& with) {
  size_t n = 0;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) n += line.find(with) != std::string::npos;
  return n;
}

TEST(ProgressBar, AStageLongerThanTheIntervalGetsLinesWhileItRuns) {
  const std::string text = CaptureStderr([] {
    ProgressBar bar(true, "seq", 4, 0.2);
    bar.Show(0, "reference");  // due only 0.2 s from now: the stage's start prints nothing
    std::this_thread::sleep_for(std::chrono::milliseconds(1000));
    bar.Show(1, "done");
    bar.Finish();
  });
  // Five intervals pass while "reference" runs: at least one of its lines even on a loaded machine (a thread
  // starved for 0.8 s), at most one per interval and one more for rounding.
  EXPECT_GE(Lines(text, "seq 0/4 frames  reference"), 1u) << text;
  EXPECT_LE(Lines(text, "reference"), 6u) << text;
  EXPECT_EQ(Lines(text, "seq 1/4 frames  finished"), 1u) << text;
}

TEST(ProgressBar, ARunShorterThanTheIntervalOrDisabledPrintsNothing) {
  EXPECT_EQ(CaptureStderr([] {
              ProgressBar bar(true, "seq", 2, 30.0);
              bar.Show(0, "reference");
              bar.Show(2, "done");
              bar.Finish();
            }),
            "");
  EXPECT_EQ(CaptureStderr([] {
              ProgressBar bar(false, "seq", 2, 0.05);
              bar.Show(0, "reference");
              std::this_thread::sleep_for(std::chrono::milliseconds(200));
              bar.Finish();
            }),
            "");
}

}  // namespace
}  // namespace restir
