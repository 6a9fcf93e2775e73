// Linear RGB float images and the 64-bit hash each frame records (DESIGN §3).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"
#include "sim/util/hash.h"

namespace restir {

struct ImageRgb {
  int width = 0;
  int height = 0;
  std::vector<Vec3> pixels;  // row-major, y down

  ImageRgb() = default;
  ImageRgb(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h, Vec3(0.0f)) {}
  size_t Size() const { return pixels.size(); }
};

// FNV-1a over the raw bits of the pixels: equal hashes mean bit-identical images.
uint64_t HashImage(const ImageRgb& image);

}  // namespace restir
