// The progress of `restir-sim run` on stderr: frames done, what the current frame is doing (the reference or which
// preset), elapsed time and an ETA from the frames finished in this session. On a terminal, one line redrawn in
// place; elsewhere (a batch job's log file, a pipe), one whole line every `logSeconds`, so that a Slurm job's
// stderr shows the run moving without filling the file: at a stage's start when one is due, and from a thread of its
// own while a stage runs longer than that (a reference).
#pragma once

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include "sim/util/clock.h"

namespace restir {

class ProgressBar {
 public:
  // Silent unless `enabled`. `logSeconds` is the interval between lines when stderr is not a terminal.
  ProgressBar(bool enabled, std::string name, int totalFrames, double logSeconds = 30.0);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  // `done` frames finished; `stage` says what runs now.
  void Show(int done, const std::string& stage);
  // One more frame finished in this session (the ETA's rate).
  void FrameDone();
  // Ends the line (a terminal) or, when a log line was written, writes the last one.
  void Finish();

 private:
  std::string Line(int done, const std::string& stage, bool bar) const;
  void LogLine(const std::string& stage);  // with mutex_ held
  void Heartbeat();                        // the log thread: a line whenever one is due
  void StopHeartbeat();

  bool enabled_;
  bool terminal_;
  std::string name_;
  int totalFrames_;
  double logSeconds_;
  int sessionFrames_ = 0;
  int lastDone_ = 0;
  std::string lastStage_;  // what runs now, for the log thread's line
  bool logged_ = false;    // a log line was written
  bool finished_ = false;  // Finish ran
  Clock::time_point start_;
  Clock::time_point lastLine_;
  std::mutex mutex_;               // guards the fields above against the log thread
  std::condition_variable wake_;   // stops the log thread early
  bool stopping_ = false;
  std::thread heartbeat_;          // only where stderr is not a terminal and logSeconds > 0
};

}  // namespace restir
