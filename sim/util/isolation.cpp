#include "sim/util/isolation.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>

#include "sim/util/text.h"

#if defined(__SANITIZE_ADDRESS__)
#define RESTIR_ISOLATION_NO_RLIMIT 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer)
#define RESTIR_ISOLATION_NO_RLIMIT 1
#endif
#endif

namespace restir {

namespace {

// The child's first byte: how its work ended.
constexpr char kDone = 'D', kRefused = 'R', kFailed = 'F';

// Writes all of `data` to fd; false on an error (the parent then sees a short message).
bool WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

[[noreturn]] void RunChild(int fd, const std::function<bool(std::string&)>& work, const IsolatedTool& tool,
                           const IsolationLimits& limits) {
#ifndef RESTIR_ISOLATION_NO_RLIMIT
  // A sanitizer reserves terabytes of shadow address space up front; the limit is only for plain builds.
  const rlimit as{limits.maxMemoryBytes, limits.maxMemoryBytes};
  setrlimit(RLIMIT_AS, &as);
#endif
  // The file gets one message, the parent's: what a library prints on its way down (glibc's "free(): invalid
  // pointer", a decoder's complaints after its reader already failed) would be a second. RESTIR_CHILD_STDERR=1
  // keeps the child's stderr, for debugging.
  if (!std::getenv("RESTIR_CHILD_STDERR")) {
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      ::dup2(null, 2);
      ::close(null);
    }
  }
  std::string message;
  try {
    std::string out;
    const bool done = work(out);
    message = (done ? kDone : kRefused) + out;
  } catch (const std::bad_alloc&) {
    message = kFailed + std::string(tool.name) + " ran out of memory (limit " +
              std::to_string(limits.maxMemoryBytes >> 20) + " MiB)";
  } catch (const std::exception& e) {
    message = kFailed + std::string(tool.name) + " failed (" + e.what() + ")";
  }
  const bool ok = WriteAll(fd, message.data(), message.size());
  ::close(fd);
  // _exit: no destructors or atexit handlers of the parent's state (TBB, Embree, gtest) run in the child.
  ::_exit(ok ? 0 : 1);
}

IsolatedResult Failed(std::string why) {
  IsolatedResult r;
  r.status = IsolatedResult::Status::kFailed;
  r.bytes = OneLine(why);
  return r;
}

}  // namespace

IsolatedResult RunIsolated(const std::function<bool(std::string& out)>& work, const IsolatedTool& tool,
                           const IsolationLimits& limits) {
  const std::string name = tool.name;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return Failed("cannot start " + name + " (pipe: " + std::strerror(errno) + ")");
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return Failed("cannot start " + name + " (fork: " + std::strerror(errno) + ")");
  }
  if (pid == 0) {
    ::close(fds[0]);
    RunChild(fds[1], work, tool, limits);
  }
  ::close(fds[1]);
  std::string bytes;
  bool timedOut = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(limits.timeoutSeconds);
  char buffer[1 << 16];
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) {
      timedOut = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min(left * 1000.0 + 1.0, 60000.0)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.append(buffer, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  if (timedOut) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timedOut)
    return Failed(name + " took longer than " + std::to_string(static_cast<int>(limits.timeoutSeconds)) +
                  " s on this file and was stopped");
  if (WIFSIGNALED(status))
    return Failed(name + " crashed on this file (signal " + std::to_string(WTERMSIG(status)) + ", " +
                  strsignal(WTERMSIG(status)) + "); the file is malformed or beyond what " + tool.library + " reads");
  const bool exitedCleanly = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (!bytes.empty() && (bytes[0] == kRefused || bytes[0] == kFailed)) {
    IsolatedResult r;
    r.status = bytes[0] == kRefused ? IsolatedResult::Status::kRefused : IsolatedResult::Status::kFailed;
    r.bytes = OneLine(bytes.substr(1));
    return r;
  }
  if (bytes.empty() || bytes[0] != kDone || !exitedCleanly)
    return Failed(name + " stopped without a result (exit status " +
                  std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  IsolatedResult r;
  r.status = IsolatedResult::Status::kDone;
  bytes.erase(0, 1);
  r.bytes = std::move(bytes);
  return r;
}

}  // namespace restir
