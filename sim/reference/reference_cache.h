// The reference cache's file format (DESIGN §7, §10): one converged reference per file, ref-<key>.bin. An entry
// carries the key it answers and a checksum of its content, so a damaged, truncated or misplaced entry (another
// frame's copied over it) is recognised and rendered again instead of silently changing every error metric.
// Encoding and decoding are pure functions of bytes (no Embree, no file I/O), so the fuzz target can drive them.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "sim/util/image.h"

namespace restir {

// How an entry's samples were spent, kept with it so that a cached frame reports what a rendered one does.
struct ReferenceAllocation {
  double meanSamplesPerPixel = 0.0;  // over the pixels that took samples, the pilot's included
  // With an error target: the cap over the mean samples per pixel the target would have taken (1: the target was
  // affordable; below 1 the frame spent its cap as a fixed budget instead, and did not reach the target). 1 with a
  // fixed budget.
  double scale = 1.0;
};

// Layout, little-endian: "RSREF004" | key length (u32) | key bytes | width (i32) | height (i32) |
// mean samples per pixel (f64) | allocation scale (f64) | payload length (u64) | mean RGB floats, width x height |
// standard error RGB floats | luminance standard error floats | FNV-1a 64 of every byte before it (u64).
std::string EncodeReferenceCacheEntry(const std::string& key, const ImageRgb& mean, const ImageRgb& standardError,
                                      const std::vector<float>& lumaStandardError,
                                      const ReferenceAllocation& allocation = {});

// Decodes an entry expected to answer `key` at width x height. False with `problem` ("checksum mismatch",
// "written for another frame", "a non-finite value" ...) when the bytes are anything but such an entry; the images
// are then unspecified. Every value must be finite and non-negative (radiance and its standard error), the
// allocation's scale in (0, 1]. `allocation`, when given, receives how the samples were spent.
bool DecodeReferenceCacheEntry(const std::string& bytes, const std::string& key, int width, int height,
                               ImageRgb& mean, ImageRgb& standardError, std::vector<float>& lumaStandardError,
                               std::string& problem, ReferenceAllocation* allocation = nullptr);

// The exact size of an entry for `key` at width x height: the reader's size cap.
size_t ReferenceCacheEntrySize(const std::string& key, int width, int height);

}  // namespace restir
