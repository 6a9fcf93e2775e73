// The progress line of `restir-sim run` on stderr (a terminal only): frames done, what the current frame is doing
// (the reference or which preset), elapsed time and an ETA from the frames finished in this session.
#pragma once

#include <string>

#include "sim/util/clock.h"

namespace restir {

class ProgressBar {
 public:
  // Silent unless `enabled` and stderr is a terminal.
  ProgressBar(bool enabled, std::string name, int totalFrames);
  // `done` frames finished; `stage` says what runs now.
  void Show(int done, const std::string& stage);
  // One more frame finished in this session (the ETA's rate).
  void FrameDone() { ++sessionFrames_; }
  // Ends the line.
  void Finish();

 private:
  bool enabled_;
  std::string name_;
  int totalFrames_;
  int sessionFrames_ = 0;
  Clock::time_point start_;
};

}  // namespace restir
