// libFuzzer target for the reference cache's reader (issue 14): any bytes given to DecodeReferenceCacheEntry must
// be refused or decode to finite, non-negative images that encode back to exactly those bytes (the format has one
// spelling per content, so anything else accepted would be a damaged entry taken for a good one). Run by
// scripts/fuzz.sh; seeded with tests/fuzz/cache_seeds/entry.bin, an entry for this key at 3x2.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_message.h"
#include "sim/reference/reference_cache.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  restir::ImageRgb mean, standardError;
  std::vector<float> lumaStandardError;
  std::string problem;
  restir::ReferenceAllocation allocation;
  if (!restir::DecodeReferenceCacheEntry(bytes, "fuzz0000fuzz0000", 3, 2, mean, standardError, lumaStandardError,
                                         problem, &allocation)) {
    if (!IsOneCleanLine(problem)) __builtin_trap();
    return 0;
  }
  for (const restir::ImageRgb* img : {&mean, &standardError})
    for (const restir::Vec3& p : img->pixels)
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(p[k]) || p[k] < 0.0f) __builtin_trap();
  for (float v : lumaStandardError)
    if (!std::isfinite(v) || v < 0.0f) __builtin_trap();
  if (!std::isfinite(allocation.meanSamplesPerPixel) || !(allocation.scale > 0.0 && allocation.scale <= 1.0))
    __builtin_trap();
  if (restir::EncodeReferenceCacheEntry("fuzz0000fuzz0000", mean, standardError, lumaStandardError, allocation) !=
      bytes)
    __builtin_trap();
  return 0;
}
