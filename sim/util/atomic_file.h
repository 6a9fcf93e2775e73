// Every file the simulator writes goes through WriteFileAtomic (DESIGN §10): the whole content is written to a
// temporary, checked to the last byte (every write and the close), and only then renamed onto its final name, so
// a reader never sees a half-written file, and a failure (a full disk) leaves the previous version intact and
// names the final file and the cause.
//
// Temporaries are ours by construction: they live in a private directory, <root>/.restir-sim-tmp/<owner>/, that
// the process holds locked (flock on <owner>/lock) while it runs and removes when it ends. A process killed
// mid-write leaves its directory behind; RemoveStaleTemporaryAreas(root) removes exactly those whose lock is
// free, so nothing outside .restir-sim-tmp is ever removed and no running process loses a temporary.
#pragma once

#include <string>

#include "sim/util/input_error.h"

namespace restir {

// A write that failed (exit status 2 like bad input: the user can act on it). The message names the final file
// and the cause, e.g. "out/metrics.csv: error: cannot write (No space left on device)".
class OutputError : public InputError {
 public:
  using InputError::InputError;
};

// Temporaries of files under `root` go to <root>/.restir-sim-tmp/<owner>/ for the life of this object (the
// deepest registered root containing a file wins); without one, a file's own directory is its root. Registering
// a root also removes its stale areas. Not thread-safe against concurrent registration; writes may be concurrent.
class TemporaryRoot {
 public:
  explicit TemporaryRoot(const std::string& root);
  ~TemporaryRoot();
  TemporaryRoot(const TemporaryRoot&) = delete;
  TemporaryRoot& operator=(const TemporaryRoot&) = delete;

 private:
  std::string root_;
};

// Removes <root>/.restir-sim-tmp/<owner>/ directories whose owner is gone (its lock is free). Touches nothing else.
void RemoveStaleTemporaryAreas(const std::string& root);

// Writes `bytes` to `path` atomically, creating parent directories. Throws OutputError on any failure.
void WriteFileAtomic(const std::string& path, const std::string& bytes);

// The same for a file written in pieces (one too big to hold whole in memory): it appears under its name only when
// Commit() succeeds; destroyed uncommitted (an error, an interrupted run), it leaves nothing. Throws OutputError.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  void Write(const std::string& bytes);
  void Commit();

 private:
  [[noreturn]] void Fail(int error);
  std::string path_;        // the final name
  std::string tmp_;         // the temporary written until Commit
  int fd_ = -1;             // the temporary, open until Commit
  bool committed_ = false;  // renamed onto path_
};

// An exclusive advisory lock (flock) on the file `path` (created if needed), held for the object's life and released
// by the kernel if the process dies, so a crashed holder never blocks the others. Blocks until it is granted. Where
// the file system cannot lock (Held() false: cannot create the file, or ENOLCK on a network file system without a
// lock manager), the caller goes on unlocked and must stay correct without it. The file is left in place: removing
// it would let a third process lock a new file while the second still waits on the old one.
class FileLock {
 public:
  explicit FileLock(const std::string& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  bool Held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;  // the lock file, open (and locked) while held
};

// Throws InputError naming `dir` and `what` it is (e.g. "output directory") unless a file can be created in it
// (creating it if needed).
void CheckWritableDirectory(const std::string& dir, const std::string& what);

}  // namespace restir
