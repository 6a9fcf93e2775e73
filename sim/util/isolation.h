// Third-party parsers fed the user's files (Assimp for assets, OpenImageIO's decoders for textures and environment
// maps) run in a forked child process: a crash, a hang or a runaway allocation in them must become one message
// about the file, never a dead simulator (DESIGN §10). The child does the work, sends its bytes through a pipe and
// exits; the parent reads them with a deadline and checks how the child ended.
//
// A forked child has only the thread that forked. Work that would hand tasks to a pool the parent started (TBB,
// OpenEXR's, OpenImageIO's) would wait forever on threads the child does not have: the work must run on the
// calling thread (sim/assets/texture.cpp pauses OpenEXR's pool for the fork).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace restir {

struct IsolationLimits {
  double timeoutSeconds = 60.0;                  // wall time before the child is stopped (Assimp's PLY reader can spin)
  uint64_t maxMemoryBytes = uint64_t(12) << 30;  // the child's address space (not under sanitizers)
};

// Who the child is, for the messages about how it ended.
struct IsolatedTool {
  const char* name;     // "the importer", "the image decoder"
  const char* library;  // what it runs, named when it crashes: "Assimp 5.2", "OpenImageIO"
};

struct IsolatedResult {
  enum class Status : uint8_t {
    kDone,     // the work finished: `bytes` is its result
    kRefused,  // the work refused the file: `bytes` is its own one-line message
    kFailed,   // the child crashed, hung, ran out of memory or said nothing: `bytes` says which (one line, no path)
  };
  Status status = Status::kFailed;
  std::string bytes;
};

// Runs `work` in a forked child. It returns true with its result in `out`, or false with a one-line message in
// `out`; an exception escaping it is a kFailed result naming the exception.
IsolatedResult RunIsolated(const std::function<bool(std::string& out)>& work, const IsolatedTool& tool,
                           const IsolationLimits& limits);

}  // namespace restir
