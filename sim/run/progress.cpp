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

}  // namespace

ProgressBar::ProgressBar(bool enabled, std::string name, int totalFrames)
    : enabled_(enabled && ::isatty(STDERR_FILENO)), name_(std::move(name)), totalFrames_(totalFrames),
      start_(Clock::now()) {}

void ProgressBar::Show(int done, const std::string& stage) {
  if (!enabled_) return;
  constexpr int kBar = 24;
  const int filled = totalFrames_ > 0 ? done * kBar / totalFrames_ : kBar;
  const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  const int remaining = totalFrames_ - done;
  const std::string eta = sessionFrames_ > 0 ? FormatDuration(elapsed / sessionFrames_ * remaining) : "?";
  std::fprintf(stderr, "\r%s [%s%s] %d/%d frames  %-28s elapsed %s  ETA %s ", name_.c_str(),
               std::string(filled, '#').c_str(), std::string(kBar - filled, '.').c_str(), done, totalFrames_,
               stage.c_str(), FormatDuration(elapsed).c_str(), eta.c_str());
  std::fflush(stderr);
}

void ProgressBar::Finish() {
  if (enabled_) std::fprintf(stderr, "\n");
}

}  // namespace restir
