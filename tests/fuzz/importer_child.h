// For fuzz targets that reach ImportAsset (sim/assets/asset_isolation.cpp), whose child process is a fork of the
// fuzzer: the child inherits libFuzzer's signal handlers, its sanitizer death callback and its malloc hook,
// so a crash of Assimp in the child would be reported by libFuzzer as if the fuzzer had crashed, and would
// leave a crash- or oom- artifact, although the parent turns it into an InputError, which is the property
// under test. A fork handler undoes that in the child: the default action for the crash signals, no death
// callback, and stderr to /dev/null (Assimp's and the sanitizers' messages in the child are the third-party
// library's, not findings; set RESTIR_FUZZ_CHILD_STDERR=1 to see them). The child still ends with _exit, so
// no atexit handler (libFuzzer's final stats, LeakSanitizer) runs in it.
//
// libFuzzer's malloc hook (-malloc_limit_mb) cannot be removed; an allocation beyond it in the child would
// dump an oom- artifact. So the targets also cap one allocation at 1000 MB through AddressSanitizer
// (max_allocation_size_mb): beyond that the allocator reports and aborts first, which in the child is a crash
// the parent reports, and in the fuzzer itself a finding, as the malloc limit would have made it.
#pragma once

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>

extern "C" void __sanitizer_set_death_callback(void (*callback)(void));

namespace restir::fuzz {

inline void QuietImporterChild() {
  __sanitizer_set_death_callback(nullptr);
  for (int s :
       {SIGSEGV, SIGBUS, SIGABRT, SIGILL, SIGFPE, SIGALRM, SIGXFSZ, SIGINT, SIGTERM, SIGUSR1, SIGUSR2})
    ::signal(s, SIG_DFL);
  if (!std::getenv("RESTIR_FUZZ_CHILD_STDERR")) {
    const int fd = ::open("/dev/null", O_WRONLY);
    if (fd >= 0) {
      ::dup2(fd, 2);
      ::close(fd);
    }
  }
}

// Call once, from LLVMFuzzerInitialize.
inline void InstallImporterChildHandler() {
  ::pthread_atfork(nullptr, nullptr, QuietImporterChild);
}

}  // namespace restir::fuzz

// The sanitizers' defaults for these targets (ASAN_OPTIONS given at run time still override them). The leak
// suppression is OpenImageIO 2.4's: a failed ImageInput::open keeps its error string (31 bytes) in storage
// that is never freed (the stack is ImageInput::geterror); it is the library's, not ours, and would otherwise
// end every run that decodes a damaged texture.
#define RESTIR_FUZZ_SANITIZER_DEFAULTS                                \
  extern "C" const char* __asan_default_options() {                   \
    return "max_allocation_size_mb=1000:allocator_may_return_null=0"; \
  }                                                                   \
  extern "C" const char* __lsan_default_suppressions() {              \
    return "leak:OpenImageIO_v2_4::ImageInput::geterror\n";           \
  }
