// Output files written on one background thread while the run goes on (issue 16: README command 1 spent a third of
// its wall time encoding frame EXRs and PNGs on the frame loop's thread while the other core waited).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace restir {

// A queue of jobs (each writes its own files, e.g. through WriteFileAtomic) run in submission order on one thread.
// At most `maxQueued` jobs wait besides the one running, so the memory the jobs hold stays bounded: Submit blocks
// until there is room. The first job that throws stops the queue (later jobs are dropped unrun), and its exception
// is rethrown by the next Submit, Drain or Check on the submitting thread, so a failed write still ends the run with its
// message. The destructor waits for the running job and drops the rest without rethrowing (it runs while an
// exception unwinds); call Drain first wherever the files must exist.
class BackgroundWriter {
 public:
  explicit BackgroundWriter(size_t maxQueued);
  ~BackgroundWriter();
  BackgroundWriter(const BackgroundWriter&) = delete;
  BackgroundWriter& operator=(const BackgroundWriter&) = delete;

  void Submit(std::function<void()> job);
  // Returns when every submitted job has finished; rethrows the first failure.
  void Drain();
  // Rethrows the first failure if a job has failed already; does not wait.
  void Check();

 private:
  void Run();
  void RethrowLocked(std::unique_lock<std::mutex>& lock);

  const size_t maxQueued_;
  std::mutex mutex_;
  std::condition_variable changed_;  // a job was queued or finished, or the writer is stopping
  std::deque<std::function<void()>> queue_;
  bool running_ = false;  // a job is being run (outside the lock)
  bool stopping_ = false;
  std::exception_ptr failure_;
  std::thread thread_;  // last: started once the members above exist
};

}  // namespace restir
