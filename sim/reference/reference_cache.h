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

// Layout, little-endian: "RSREF003" | key length (u32) | key bytes | width (i32) | height (i32) |
// payload length (u64) | mean RGB floats, width x height | standard error RGB floats | luminance standard error
// floats | FNV-1a 64 of every byte before it (u64).
std::string EncodeReferenceCacheEntry(const std::string& key, const ImageRgb& mean, const ImageRgb& standardError,
                                      const std::vector<float>& lumaStandardError);

// Decodes an entry expected to answer `key` at width x height. False with `problem` ("checksum mismatch",
// "written for another frame", "a non-finite value" ...) when the bytes are anything but such an entry; the images
// are then unspecified. Every value must be finite and non-negative (radiance and its standard error).
bool DecodeReferenceCacheEntry(const std::string& bytes, const std::string& key, int width, int height,
                               ImageRgb& mean, ImageRgb& standardError, std::vector<float>& lumaStandardError,
                               std::string& problem);

// The exact size of an entry for `key` at width x height: the reader's size cap.
size_t ReferenceCacheEntrySize(const std::string& key, int width, int height);

}  // namespace restir
