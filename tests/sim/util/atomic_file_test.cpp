// Writing outputs (sim/util/atomic_file.h): whole or not at all, failures naming the final file and the cause, and
// temporaries that are ours by construction: a private locked directory, cleaned only when its owner is gone.
#include "sim/util/atomic_file.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace restir {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

size_t Entries(const fs::path& dir) {
  size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) ++n, (void)e;
  return n;
}

TEST(AtomicFile, WritesAndReplacesLeavingOnlyTheFile) {
  const fs::path dir = FreshDir("restir-atomic-replace");
  {
    const TemporaryRoot root(dir.string());
    const std::string path = (dir / "sub" / "a.txt").string();
    WriteFileAtomic(path, "first");
    WriteFileAtomic(path, "second");
    EXPECT_EQ(ReadAll(path), "second");
  }
  // The private directory went with its root: only sub/ and the file remain.
  EXPECT_EQ(Entries(dir), 2u);
}

// A write that fails half-way (here: the file size limit, as a full disk would) leaves the previous version and
// no temporary, and says which file and why. Run in a child process, which alone gets the limit.
TEST(AtomicFile, FailedWriteKeepsThePreviousVersionAndNamesFileAndCause) {
  const fs::path dir = FreshDir("restir-atomic-full");
  const fs::path path = dir / "frame.png";
  {
    const TemporaryRoot root(dir.string());
    WriteFileAtomic(path.string(), "good");
  }
  int pipefd[2];
  ASSERT_EQ(::pipe(pipefd), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(pipefd[0]);
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    std::string message = "no error";
    try {
      const TemporaryRoot root(dir.string());
      WriteFileAtomic(path.string(), std::string(100000, 'x'));
    } catch (const OutputError& e) {
      message = e.what();
    }
    (void)!::write(pipefd[1], message.data(), message.size());
    ::_exit(0);
  }
  ::close(pipefd[1]);
  std::string message;
  char buf[512];
  for (ssize_t n; (n = ::read(pipefd[0], buf, sizeof(buf))) > 0;) message.append(buf, static_cast<size_t>(n));
  ::close(pipefd[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_EQ(message, path.string() + ": error: cannot write (File too large)");
  EXPECT_EQ(ReadAll(path), "good");
  EXPECT_EQ(Entries(dir), 1u);
}

TEST(AtomicFile, RefusesADirectoryThatIsAFile) {
  const fs::path dir = FreshDir("restir-atomic-notdir");
  std::ofstream(dir / "file") << "x";
  try {
    CheckWritableDirectory((dir / "file").string(), "output directory");
    ADD_FAILURE() << "accepted a file as a directory";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "file").string() + ": error: output directory is not writable", 0),
              0u)
        << e.what();
  }
  try {
    WriteFileAtomic((dir / "file" / "a.txt").string(), "x");
    ADD_FAILURE() << "wrote under a file";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "file" / "a.txt").string() + ": error: cannot write", 0), 0u)
        << e.what();
  }
}

// Cleaning removes the areas of owners that are gone and nothing else: not a live owner's (its lock is held),
// not a user's files that look like temporaries, not anything outside .restir-sim-tmp.
TEST(AtomicFile, StaleCleaningRemovesOnlyDeadOwnersAreas) {
  const fs::path dir = FreshDir("restir-atomic-stale");
  const fs::path base = dir / ".restir-sim-tmp";
  fs::create_directories(base / "dead-1");
  std::ofstream(base / "dead-1.lock") << "";
  std::ofstream(base / "dead-1" / "0-metrics.csv") << "partial";
  fs::create_directories(base / "live-2");
  std::ofstream(base / "live-2" / "0-frame.exr") << "in progress";
  const int live = ::open((base / "live-2.lock").c_str(), O_WRONLY | O_CREAT, 0644);
  ASSERT_GE(live, 0);
  // flock locks belong to the open file description: a second open of the same file in this process conflicts
  // with it exactly as another process's would.
  ASSERT_EQ(::flock(live, LOCK_EX | LOCK_NB), 0);
  std::ofstream(dir / "thesis.tmp2024.tex") << "mine";
  std::ofstream(dir / "frame.tmp123.exr") << "also mine";
  fs::create_directories(dir / "sub" / ".restir-sim-tmp" / "x");
  RemoveStaleTemporaryAreas(dir.string());
  EXPECT_FALSE(fs::exists(base / "dead-1"));
  EXPECT_FALSE(fs::exists(base / "dead-1.lock"));
  EXPECT_TRUE(fs::exists(base / "live-2" / "0-frame.exr"));
  EXPECT_TRUE(fs::exists(base / "live-2.lock"));
  EXPECT_EQ(ReadAll(dir / "thesis.tmp2024.tex"), "mine");
  EXPECT_EQ(ReadAll(dir / "frame.tmp123.exr"), "also mine");
  EXPECT_TRUE(fs::exists(dir / "sub" / ".restir-sim-tmp" / "x"));
  ::close(live);
  RemoveStaleTemporaryAreas(dir.string());  // its owner is gone now
  EXPECT_FALSE(fs::exists(base));
}

}  // namespace
}  // namespace restir
