#include "sim/run/progress.h"

#include <unistd.h>

#include <cstdio>

namespace restir {

namespace {

std::string FormatDuration(double seconds) {
  const int s = static_cast<int>(seconds + 0.5);
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%d:%02d:%02d", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

double Seconds(Clock::time_point from, Clock::time_point to) { return std::chrono::duration<double>(to - from).count(); }

}  // namespace

ProgressBar::ProgressBar(bool enabled, std::string name, int totalFrames, double logSeconds)
    : enabled_(enabled), terminal_(::isatty(STDERR_FILENO) != 0), name_(std::move(name)), totalFrames_(totalFrames),
      logSeconds_(logSeconds), start_(Clock::now()), lastLine_(start_) {
  if (enabled_ && !terminal_ && logSeconds_ > 0.0) heartbeat_ = std::thread([this] { Heartbeat(); });
}

ProgressBar::~ProgressBar() { StopHeartbeat(); }

void ProgressBar::StopHeartbeat() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (heartbeat_.joinable()) heartbeat_.join();
}

void ProgressBar::Heartbeat() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    const Clock::time_point due =
        lastLine_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(logSeconds_));
    if (wake_.wait_until(lock, due, [this] { return stopping_; })) break;
    if (Seconds(lastLine_, Clock::now()) >= logSeconds_) LogLine(lastStage_);
  }
}

void ProgressBar::LogLine(const std::string& stage) {
  lastLine_ = Clock::now();
  logged_ = true;
  std::fprintf(stderr, "%s\n", Line(lastDone_, stage, false).c_str());
  std::fflush(stderr);
}

std::string ProgressBar::Line(int done, const std::string& stage, bool bar) const {
  constexpr int kBar = 24;
  const int filled = totalFrames_ > 0 ? done * kBar / totalFrames_ : kBar;
  const double elapsed = Seconds(start_, Clock::now());
  const int remaining = totalFrames_ - done;
  const std::string eta = sessionFrames_ > 0 ? FormatDuration(elapsed / sessionFrames_ * remaining) : "?";
  const std::string meter = bar ? " [" + std::string(filled, '#') + std::string(kBar - filled, '.') + "]" : "";
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%s%s %d/%d frames  %-28s elapsed %s  ETA %s", name_.c_str(), meter.c_str(), done,
                totalFrames_, stage.c_str(), FormatDuration(elapsed).c_str(), eta.c_str());
  return buf;
}

void ProgressBar::Show(int done, const std::string& stage) {
  if (!enabled_) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  lastDone_ = done;
  lastStage_ = stage;
  if (terminal_) {
    std::fprintf(stderr, "\r%s ", Line(done, stage, true).c_str());
    std::fflush(stderr);
  } else if (Seconds(lastLine_, Clock::now()) >= logSeconds_) {
    LogLine(stage);
  }
}

void ProgressBar::FrameDone() {
  const std::lock_guard<std::mutex> lock(mutex_);
  ++sessionFrames_;
}

void ProgressBar::Finish() {
  StopHeartbeat();
  if (!enabled_ || finished_) return;
  finished_ = true;
  if (terminal_) {
    std::fprintf(stderr, "\n");
  } else if (logged_) {  // a run shorter than one interval stays silent, as it was
    std::fprintf(stderr, "%s\n", Line(lastDone_, "finished", false).c_str());
  }
  std::fflush(stderr);
}

}  // namespace restir
