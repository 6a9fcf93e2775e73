#include "sim/util/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <vector>

namespace restir {

namespace fs = std::filesystem;

namespace {

constexpr const char* kAreaDirectory = ".restir-sim-tmp";

std::string Cause(int error) { return std::strerror(error); }

// flock's errors that mean "this file system cannot lock", not "someone holds it".
bool CannotLock(int error) { return error == ENOLCK || error == ENOSYS || error == EOPNOTSUPP || error == EINVAL; }

// Why an area could not be made: the system's error and what was being created.
struct AreaError {
  int error;
  std::string path;
};

// One process's private directory of temporaries under a root: <root>/.restir-sim-tmp/<owner>/, with the lock
// <owner>.lock beside it held for as long as the directory is in use. The lock is taken before the directory
// exists, so a cleaner that can take it knows the owner is gone.
class Area {
 public:
  explicit Area(std::string root) : root_(std::move(root)) {}
  ~Area() { Release(); }

  // A fresh path in the area for a file that will become `finalName`; creates the area on first use, and again
  // if someone removed it meanwhile (a test's remove_all, a user cleaning up). Throws AreaError.
  std::string NewPath(const std::string& finalName) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::error_code ec;
    if (!dir_.empty() && !fs::is_directory(dir_, ec)) Release();
    if (dir_.empty()) Create();
    return (fs::path(dir_) / (std::to_string(counter_++) + "-" + fs::path(finalName).filename().string())).string();
  }

  const std::string& Root() const { return root_; }

  void Release() {
    if (dir_.empty()) return;
    std::error_code ec;
    fs::remove_all(dir_, ec);
    fs::remove(lockPath_, ec);
    ::close(lockFd_);
    fs::remove(fs::path(root_) / kAreaDirectory, ec);  // only when empty: other processes may have areas there
    dir_.clear();
  }

 private:
  void Create() {
    const fs::path base = fs::path(root_) / kAreaDirectory;
    char host[128] = "host";
    ::gethostname(host, sizeof(host) - 1);
    const auto nonce = std::chrono::steady_clock::now().time_since_epoch().count();
    const std::string owner = std::string(host) + "-" + std::to_string(::getpid()) + "-" + std::to_string(nonce);
    // Another process's RemoveStaleTemporaryAreas removes `base` whenever it finds it empty, which can happen
    // between our steps: start again.
    for (int attempt = 0;; ++attempt) {
      try {
        CreateOnce(base, owner);
        return;
      } catch (const AreaError& e) {
        if (e.error != ENOENT || attempt >= 16) throw;
      }
    }
  }

  // The lock is taken under a name no cleaner looks at (<owner>.lock.new) and renamed to <owner>.lock only once
  // held and once the directory exists, so a cleaner never sees a lock that is free because its owner has not
  // taken it yet.
  void CreateOnce(const fs::path& base, const std::string& owner) {
    std::error_code ec;
    fs::create_directories(base, ec);
    if (ec) throw AreaError{ec.value(), base.string()};
    const std::string pending = (base / (owner + ".lock.new")).string();
    lockPath_ = (base / (owner + ".lock")).string();
    dir_ = (base / owner).string();
    auto fail = [&](int error, const std::string& what) {
      if (lockFd_ >= 0) ::close(lockFd_);
      lockFd_ = -1;
      fs::remove(pending, ec);
      fs::remove(dir_, ec);
      dir_.clear();
      throw AreaError{error, what};
    };
    lockFd_ = ::open(pending.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (lockFd_ < 0) fail(errno, pending);
    // A file system that cannot lock (ENOLCK: NFS without a lock manager) leaves the area unlocked: cleaners
    // cannot lock it either, so they leave it alone, and this process removes it when it ends.
    if (::flock(lockFd_, LOCK_EX | LOCK_NB) != 0 && !CannotLock(errno)) fail(errno, pending);
    if (::mkdir(dir_.c_str(), 0755) != 0) fail(errno, dir_);
    if (::rename(pending.c_str(), lockPath_.c_str()) != 0) fail(errno, lockPath_);
  }

  std::string root_;
  std::mutex mutex_;
  std::string dir_;       // empty until first use
  std::string lockPath_;
  int lockFd_ = -1;       // holds the area's lock while the area exists
  uint64_t counter_ = 0;  // numbers the temporaries
};

// The areas of this process: registered roots first (innermost last), then the fallback areas of directories
// written to outside any registered root, which last until the process ends.
struct Areas {
  std::mutex mutex;
  std::vector<std::unique_ptr<Area>> registered;
  std::vector<std::unique_ptr<Area>> fallback;
  static Areas& Get() {
    static Areas areas;
    return areas;
  }
  Area& For(const fs::path& file) {
    std::lock_guard<std::mutex> lock(mutex);
    const fs::path dir = fs::absolute(file).parent_path().lexically_normal();
    Area* best = nullptr;
    size_t bestLength = 0;
    for (const auto& a : registered) {
      const fs::path root = fs::absolute(a->Root()).lexically_normal();
      const auto mismatch = std::mismatch(root.begin(), root.end(), dir.begin(), dir.end());
      const size_t length = root.string().size();
      if (mismatch.first == root.end() && length >= bestLength) best = a.get(), bestLength = length;
    }
    if (best) return *best;
    for (const auto& a : fallback)
      if (fs::path(a->Root()) == dir) return *a;
    fallback.push_back(std::make_unique<Area>(dir.string()));
    return *fallback.back();
  }
};

}  // namespace

TemporaryRoot::TemporaryRoot(const std::string& root) : root_(root) {
  RemoveStaleTemporaryAreas(root);
  Areas& areas = Areas::Get();
  std::lock_guard<std::mutex> lock(areas.mutex);
  areas.registered.push_back(std::make_unique<Area>(root));
}

TemporaryRoot::~TemporaryRoot() {
  Areas& areas = Areas::Get();
  std::lock_guard<std::mutex> lock(areas.mutex);
  for (auto it = areas.registered.rbegin(); it != areas.registered.rend(); ++it)
    if ((*it)->Root() == root_) {
      areas.registered.erase(std::next(it).base());
      return;
    }
}

void RemoveStaleTemporaryAreas(const std::string& root) {
  const fs::path base = fs::path(root) / kAreaDirectory;
  std::error_code ec;
  if (!fs::is_directory(base, ec)) return;
  std::vector<fs::path> locks;
  for (auto it = fs::directory_iterator(base, ec); !ec && it != fs::directory_iterator(); it.increment(ec))
    if (it->path().extension() == ".lock" && it->is_regular_file(ec)) locks.push_back(it->path());
  for (const fs::path& lockPath : locks) {
    // Read-write: on NFS flock is a POSIX write lock, which needs a descriptor open for writing.
    const int fd = ::open(lockPath.c_str(), O_RDWR | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {  // its owner is gone
      fs::path dir = lockPath;
      dir.replace_extension();
      fs::remove_all(dir, ec);
      fs::remove(lockPath, ec);
    }
    ::close(fd);
  }
  fs::remove(base, ec);  // only when empty
}

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(std::move(path)) {
  const fs::path target(path_);
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw OutputError(path_ + ": error: cannot write (cannot create its directory: " + ec.message() + ")");
  }
  try {
    tmp_ = Areas::Get().For(target).NewPath(path_);
  } catch (const AreaError& e) {
    throw OutputError(path_ + ": error: cannot write (" + Cause(e.error) + ": cannot create " + e.path + ")");
  }
  fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0) Fail(errno);
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !tmp_.empty()) {
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
}

void AtomicFileWriter::Fail(int error) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  std::error_code ec;
  fs::remove(tmp_, ec);
  tmp_.clear();
  throw OutputError(path_ + ": error: cannot write (" + Cause(error) + ")");
}

void AtomicFileWriter::Write(const std::string& bytes) {
  if (fd_ < 0) throw OutputError(path_ + ": error: cannot write (already failed or committed)");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) Fail(n < 0 ? errno : EIO);
    done += static_cast<size_t>(n);
  }
}

void AtomicFileWriter::Commit() {
  if (fd_ < 0) throw OutputError(path_ + ": error: cannot write (already failed or committed)");
  // A network file system may only report a failed write when the file is closed.
  const int closed = ::close(fd_);
  fd_ = -1;
  if (closed != 0) Fail(errno);
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) Fail(errno);
  committed_ = true;
}

void WriteFileAtomic(const std::string& path, const std::string& bytes) {
  AtomicFileWriter w(path);
  w.Write(bytes);
  w.Commit();
}

FileLock::FileLock(const std::string& path) {
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd_ < 0) return;
  int r;
  do {
    r = ::flock(fd_, LOCK_EX);
  } while (r != 0 && errno == EINTR);
  if (r != 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the lock
}

void CheckWritableDirectory(const std::string& dir, const std::string& what) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": error: " + what + " is not writable (" + ec.message() + ")");
  // A file in the area the directory's outputs will be written through, removed again at once.
  std::string probe;
  try {
    probe = Areas::Get().For(fs::path(dir) / "probe").NewPath(dir);
  } catch (const AreaError& e) {
    throw InputError(dir + ": error: " + what + " is not writable (" + Cause(e.error) + ")");
  }
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw InputError(dir + ": error: " + what + " is not writable (" + Cause(errno) + ")");
  ::close(fd);
  fs::remove(probe, ec);
}

}  // namespace restir
