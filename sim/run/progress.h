// The progress of `restir-sim run` on stderr: frames done, what the current frame is doing (the reference or which
// preset), elapsed time and an ETA from the frames finished in this session. On a terminal, one line redrawn in
// place; elsewhere (a batch job's log file, a pipe), one whole line every `logSeconds`, so that a Slurm job's
// stderr shows the run moving without filling the file.
#pragma once

#include <string>

#include "sim/util/clock.h"

namespace restir {

class ProgressBar {
 public:
  // Silent unless `enabled`. `logSeconds` is the interval between lines when stderr is not a terminal.
  ProgressBar(bool enabled, std::string name, int totalFrames, double logSeconds = 30.0);
  // `done` frames finished; `stage` says what runs now.
  void Show(int done, const std::string& stage);
  // One more frame finished in this session (the ETA's rate).
  void FrameDone() { ++sessionFrames_; }
  // Ends the line (a terminal) or, when a log line was written, writes the last one.
  void Finish();

 private:
  std::string Line(int done, const std::string& stage, bool bar) const;

  bool enabled_;
  bool terminal_;
  std::string name_;
  int totalFrames_;
  double logSeconds_;
  int sessionFrames_ = 0;
  int lastDone_ = 0;
  bool logged_ = false;  // a log line was written
  Clock::time_point start_;
  Clock::time_point lastLine_;
};

}  // namespace restir
