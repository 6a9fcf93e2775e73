#include "sim/util/image.h"

namespace restir {

uint64_t HashImage(const ImageRgb& image) {
  uint64_t h = Fnv1a(&image.width, sizeof(image.width));
  h = Fnv1a(&image.height, sizeof(image.height), h);
  return Fnv1a(image.pixels.data(), image.pixels.size() * sizeof(Vec3), h);
}

}  // namespace restir
