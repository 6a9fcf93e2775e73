// libFuzzer target for the reader of a sweep job's relative-error frames (issue 19), which the merge reads from
// jobs that may have run anywhere: any bytes given to the header or frame decoder must be refused with a one-line
// reason, or decode to finite values that encode back to exactly those bytes (one spelling per content, so
// anything else accepted would be damage taken for data). Run by scripts/fuzz.sh; seeded with
// tests/fuzz/relative_error_seeds/ (a header for 2x1 and 3 frames, and one frame of 6 values).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_message.h"
#include "sim/metrics/relative_error_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  std::string problem;
  if (restir::DecodeRelativeErrorHeader(bytes, 2, 1, 3, problem)) {
    if (restir::EncodeRelativeErrorHeader(2, 1, 3) != bytes) __builtin_trap();
  } else if (!IsOneCleanLine(problem)) {
    __builtin_trap();
  }
  problem.clear();
  std::vector<float> values;
  if (!restir::DecodeRelativeErrorFrame(bytes, 6, values, problem)) {
    if (!IsOneCleanLine(problem)) __builtin_trap();
    return 0;
  }
  for (float v : values)
    if (!std::isfinite(v)) __builtin_trap();
  if (restir::EncodeRelativeErrorFrame(values) != bytes) __builtin_trap();
  return 0;
}
