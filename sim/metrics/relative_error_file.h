// A sweep job's relative-error frames (sim/metrics/seed_ensemble.h, docs/sweep-format.md): every frame's per-pixel
// error in relmse's units, for the seed-ensemble split of the merge. The jobs may run on other machines, so the file
// is input like any other (DESIGN §10): sized, checked per frame by a checksum, every value finite. Encoding and
// decoding are pure functions of bytes, so the fuzz target can drive them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/util/image.h"

namespace restir {

// Layout, little-endian: "RSRELE01" | width i32 | height i32 | frames i32 | then per frame: 3·w·h floats and the
// FNV-1a 64 of their bytes.
constexpr size_t kRelativeErrorHeaderSize = 8 + 3 * 4;
std::string EncodeRelativeErrorHeader(int width, int height, int frames);
// One frame's block: its values and their checksum.
std::string EncodeRelativeErrorFrame(const std::vector<float>& values);
// False with `problem` unless `bytes` is a header for width × height × frames.
bool DecodeRelativeErrorHeader(const std::string& bytes, int width, int height, int frames, std::string& problem);
// False with `problem` unless `bytes` is one frame's block of `count` finite values; fills `values`.
bool DecodeRelativeErrorFrame(const std::string& bytes, size_t count, std::vector<float>& values, std::string& problem);
// The whole file's size for width × height × frames.
uint64_t RelativeErrorFileSize(int width, int height, int frames);

// Reads one job's file frame by frame. Throws InputError naming the file when it is not such a file.
class RelativeErrorFile {
 public:
  RelativeErrorFile(const std::string& path, int width, int height, int frames);
  ~RelativeErrorFile();
  RelativeErrorFile(const RelativeErrorFile&) = delete;
  RelativeErrorFile& operator=(const RelativeErrorFile&) = delete;
  // Frame k (0-based within the file). Throws InputError on a damaged block.
  void ReadFrame(int k, std::vector<float>& values) const;

 private:
  std::string path_;  // for messages
  int fd_ = -1;       // the file, open for the object's life
  size_t count_ = 0;  // values per frame
};

}  // namespace restir
