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
      logSeconds_(logSeconds), start_(Clock::now()), lastLine_(start_) {}

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
  lastDone_ = done;
  if (terminal_) {
    std::fprintf(stderr, "\r%s ", Line(done, stage, true).c_str());
  } else {
    const Clock::time_point now = Clock::now();
    if (Seconds(lastLine_, now) < logSeconds_) return;
    lastLine_ = now;
    logged_ = true;
    std::fprintf(stderr, "%s\n", Line(done, stage, false).c_str());
  }
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  if (!enabled_) return;
  if (terminal_) {
    std::fprintf(stderr, "\n");
  } else if (logged_) {  // a run shorter than one interval stays silent, as it was
    std::fprintf(stderr, "%s\n", Line(lastDone_, "finished", false).c_str());
  }
  std::fflush(stderr);
}

}  // namespace restir
