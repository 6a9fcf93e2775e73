// ImportAsset: the importer in a child process. Assimp 5.2 and the image decoders are large C++ parsers fed
// third-party files; a crash, a hang or a runaway allocation in them must become one message about the file, not
// a dead simulator (DESIGN §10). The child imports, serialises the result (sim/asset_bytes.cpp) into a pipe and
// exits; the parent reads with a deadline, checks how the child ended, and validates what it got.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "sim/asset_import.h"
#include "sim/sequence.h"  // InputError
#include "sim/text.h"

#if defined(__SANITIZE_ADDRESS__)
#define RESTIR_ASSET_NO_RLIMIT 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer)
#define RESTIR_ASSET_NO_RLIMIT 1
#endif
#endif

namespace restir {

namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(OneLine(path + ": error: " + what));
}

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

// The child: import, then one tag byte ('A' asset, 'E' error message) and the payload.
[[noreturn]] void RunChild(int fd, const std::string& path, const AssetLimits& limits) {
#ifndef RESTIR_ASSET_NO_RLIMIT
  // A sanitizer reserves terabytes of shadow address space up front; the limit is only for plain builds.
  const rlimit as{limits.maxMemoryBytes, limits.maxMemoryBytes};
  setrlimit(RLIMIT_AS, &as);
#endif
  std::string message;
  try {
    message = 'A' + SerializeAsset(ImportAssetGeometry(path, limits));
  } catch (const InputError& e) {
    message = std::string("E") + e.what();
  } catch (const std::bad_alloc&) {
    message = "E" + path + ": error: the importer ran out of memory (limit " +
              std::to_string(limits.maxMemoryBytes >> 20) + " MiB)";
  } catch (const std::exception& e) {
    message = "E" + path + ": error: cannot import the asset (" + e.what() + ")";
  }
  const bool ok = WriteAll(fd, message.data(), message.size());
  ::close(fd);
  // _exit: no destructors or atexit handlers of the parent's state (TBB, Embree, gtest) run in the child.
  ::_exit(ok ? 0 : 1);
}

}  // namespace

ImportedAsset ImportAsset(const std::string& path, const AssetLimits& limits) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) Fail(path, std::string("cannot start the importer (pipe: ") + std::strerror(errno) + ")");
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    Fail(path, std::string("cannot start the importer (fork: ") + std::strerror(errno) + ")");
  }
  if (pid == 0) {
    ::close(fds[0]);
    RunChild(fds[1], path, limits);
  }
  ::close(fds[1]);
  std::string bytes;
  bool timedOut = false;
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(limits.timeoutSeconds);
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
    Fail(path, "the importer took longer than " + std::to_string(static_cast<int>(limits.timeoutSeconds)) +
                   " s on this file and was stopped");
  if (WIFSIGNALED(status))
    Fail(path, "the importer crashed on this file (signal " + std::to_string(WTERMSIG(status)) + ", " +
                   strsignal(WTERMSIG(status)) + "); the file is malformed or beyond what Assimp 5.2 reads");
  if (!bytes.empty() && bytes[0] == 'E') throw InputError(OneLine(bytes.substr(1)));
  if (bytes.empty() || bytes[0] != 'A' || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    Fail(path, "the importer stopped without a result (exit status " +
                   std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")");
  ImportedAsset asset = DeserializeAsset(bytes.substr(1), path);
  try {
    DecodeAssetTextures(asset);
  } catch (const InputError& e) {
    throw InputError(OneLine(std::string(e.what()) + " (a texture of " + path + ")"));
  }
  ValidateAsset(asset, path, limits);
  return asset;
}

}  // namespace restir
