// sim/util/isolation.h: whatever the work in the child does (returns, refuses, crashes, hangs, runs out of memory,
// exits without a word, prints on stderr), the parent gets one result and one line, and carries on.
#include "sim/util/isolation.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <thread>

namespace restir {
namespace {

using Status = IsolatedResult::Status;
#if defined(__SANITIZE_ADDRESS__)
// AddressSanitizer catches SIGSEGV, SIGBUS and SIGFPE itself, prints its report and exits with status 1.
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
const IsolatedTool kTool{"the test's worker", "the test"};

IsolatedResult RunChild(const std::function<bool(std::string&)>& work, double timeoutSeconds = 60.0) {
  return RunIsolated(work, kTool, IsolationLimits{timeoutSeconds, uint64_t(12) << 30});
}

TEST(Isolation, DoneCarriesTheWorksBytesWholePastThePipesBuffer) {
  // 48 MiB + 3 bytes of a pattern with every byte value, zeros included: many pipe buffers, an odd tail.
  std::string expected(size_t(48) << 20 | 3, '\0');
  for (size_t i = 0; i < expected.size(); ++i) expected[i] = static_cast<char>((i * 2654435761u) >> 13);
  const IsolatedResult r = RunChild([&](std::string& out) {
    out = expected;
    return true;
  });
  ASSERT_EQ(r.status, Status::kDone) << r.bytes.substr(0, 200);
  EXPECT_TRUE(r.bytes == expected) << r.bytes.size() << " bytes, expected " << expected.size();
  // An empty result is a result too.
  const IsolatedResult empty = RunChild([](std::string& out) {
    out.clear();
    return true;
  });
  EXPECT_EQ(empty.status, Status::kDone);
  EXPECT_EQ(empty.bytes, "");
}

TEST(Isolation, RefusalIsTheWorksOwnMessageOnOneLine) {
  const IsolatedResult r = RunChild([](std::string& out) {
    out = "bad.png: error: not an image\nsecond line";
    return false;
  });
  EXPECT_EQ(r.status, Status::kRefused);
  EXPECT_EQ(r.bytes.find('\n'), std::string::npos) << r.bytes;
  EXPECT_EQ(r.bytes.rfind("bad.png: error: not an image", 0), 0u) << r.bytes;
}

TEST(Isolation, CrashesAreReportedWithTheirSignalAndTheParentCarriesOn) {
  for (const int signal : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGKILL}) {
    const IsolatedResult r = RunChild([signal](std::string&) -> bool {
      std::raise(signal);
      return true;
    });
    EXPECT_EQ(r.status, Status::kFailed) << signal;
    EXPECT_EQ(r.bytes.find('\n'), std::string::npos) << r.bytes;
    if (kSanitized && signal != SIGABRT && signal != SIGKILL) {
      EXPECT_NE(r.bytes.find("stopped without a result (exit status 1)"), std::string::npos) << r.bytes;
      continue;
    }
    EXPECT_NE(r.bytes.find("the test's worker crashed on this file (signal " + std::to_string(signal) + ", "),
              std::string::npos)
        << r.bytes;
    EXPECT_NE(r.bytes.find("beyond what the test reads"), std::string::npos) << r.bytes;
  }
  // A crash after part of a result was sent is still a crash, not a short result.
  const IsolatedResult partial = RunChild([](std::string& out) -> bool {
    const std::string big(size_t(1) << 20, 'x');
    out = big;
    std::abort();
  });
  EXPECT_EQ(partial.status, Status::kFailed);
}

TEST(Isolation, AHangIsStoppedAtTheDeadline) {
  const auto t0 = std::chrono::steady_clock::now();
  const IsolatedResult r = RunChild(
      [](std::string&) {
        std::this_thread::sleep_for(std::chrono::seconds(120));
        return true;
      },
      1.0);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.status, Status::kFailed);
  EXPECT_NE(r.bytes.find("took longer than 1 s on this file and was stopped"), std::string::npos) << r.bytes;
  EXPECT_GE(seconds, 1.0);
  EXPECT_LT(seconds, 30.0);
}

TEST(Isolation, OutOfMemoryAndOtherExceptionsAreNamed) {
  const IsolatedResult oom = RunChild([](std::string&) -> bool { throw std::bad_alloc(); });
  EXPECT_EQ(oom.status, Status::kFailed);
  EXPECT_NE(oom.bytes.find("the test's worker ran out of memory (limit 12288 MiB)"), std::string::npos) << oom.bytes;
  const IsolatedResult other = RunChild([](std::string&) -> bool { throw std::runtime_error("odd\nstate"); });
  EXPECT_EQ(other.status, Status::kFailed);
  EXPECT_NE(other.bytes.find("the test's worker failed (odd"), std::string::npos) << other.bytes;
  EXPECT_EQ(other.bytes.find('\n'), std::string::npos) << other.bytes;
}

TEST(Isolation, AnExitWithoutAResultIsAFailureNamingTheStatus) {
  for (const int code : {0, 3}) {
    const IsolatedResult r = RunChild([code](std::string&) -> bool { ::_exit(code); });
    EXPECT_EQ(r.status, Status::kFailed);
    EXPECT_NE(r.bytes.find("stopped without a result (exit status " + std::to_string(code) + ")"), std::string::npos)
        << r.bytes;
  }
}

// What a library prints on its way down in the child must not become a second message in the parent's stderr.
TEST(Isolation, TheChildsStderrDoesNotReachTheParents) {
  if (std::getenv("RESTIR_CHILD_STDERR")) GTEST_SKIP() << "RESTIR_CHILD_STDERR keeps the child's stderr";
  std::fflush(stderr);
  std::FILE* captured = std::tmpfile();
  ASSERT_NE(captured, nullptr);
  const int saved = ::dup(2);
  ::dup2(::fileno(captured), 2);
  const IsolatedResult r = RunChild([](std::string&) -> bool {
    std::fputs("free(): invalid pointer\n", stderr);
    std::fflush(stderr);
    std::abort();
  });
  std::fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  std::fseek(captured, 0, SEEK_END);
  const long written = std::ftell(captured);
  std::fclose(captured);
  EXPECT_EQ(r.status, Status::kFailed);
  EXPECT_EQ(written, 0) << "the child's stderr reached the parent's";
}

}  // namespace
}  // namespace restir
