// Counter-based random numbers keyed by (seed, frame, pixel, pass, dimension) (DESIGN §3). No state, no
// stream: the same key always yields the same number, whatever thread or SIMD lane asks for it.
#pragma once

#include <cstdint>

namespace restir {

// Passes own disjoint dimension ranges by their pass id, so two passes never share a random number.
enum class RngPass : uint32_t {
  kInitial = 1,
  kTemporal = 2,
  kSpatial = 3,
  kShade = 4,
  kReference = 5,
  kReferencePilot = 6,
  // initial sampling's sun, environment and BSDF candidates (sim/estimator/passes/candidate_sources.h)
  kInitialSources = 7,
  // the reference pilot's per-pixel light probes (sim/reference/reference_learning.h PixelProbes)
  kReferenceProbe = 8,
  // the reference's indirect paths, and the pilot paths that set their counts (sim/reference/reference_paths.h)
  kReferencePaths = 9,
  kReferencePathsPilot = 10,
  // a preset frame's indirect paths (sim/reference/reference_paths.h IndirectImage)
  kIndirect = 11,
  kTest = 100,
};

struct RngKey {
  uint32_t seed = 0;   // run seed (--seed)
  uint32_t frame = 0;  // frame index
  uint32_t pixel = 0;  // linear pixel index y * width + x
  uint32_t pass = 0;   // RngPass, or any id a caller reserves
};

// PCG4D hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3)): four rounds of an LCG
// step mixed across the lanes. Integer-only, so SIMD twins reproduce it exactly.
inline void Pcg4d(uint32_t& x, uint32_t& y, uint32_t& z, uint32_t& w) {
  x = x * 1664525u + 1013904223u;
  y = y * 1664525u + 1013904223u;
  z = z * 1664525u + 1013904223u;
  w = w * 1664525u + 1013904223u;
  x += y * w;
  y += z * x;
  z += x * y;
  w += y * z;
  x ^= x >> 16;
  y ^= y >> 16;
  z ^= z >> 16;
  w ^= w >> 16;
  x += y * w;
  y += z * x;
  z += x * y;
  w += y * z;
}

// PCG4D of a key's words for one dimension. The dimension is folded into the pass word (pass in the top 12 bits,
// dimension in the low 20), then the seed is mixed into the frame word so that keys differing in any one field
// never collide before hashing.
inline void HashedKey(const RngKey& key, uint32_t dimension, uint32_t& x, uint32_t& y, uint32_t& z, uint32_t& w) {
  x = key.pixel;
  y = key.frame ^ (key.seed * 0x9E3779B9u);
  z = key.seed;
  w = (key.pass << 20) ^ (dimension & 0xFFFFFu);
  Pcg4d(x, y, z, w);
}

// 32 random bits for one dimension of a key.
inline uint32_t RandomBits(const RngKey& key, uint32_t dimension) {
  uint32_t x, y, z, w;
  HashedKey(key, dimension, x, y, z, w);
  return x ^ (w >> 7);
}

// Four 32-bit words from one hash: PCG4D's whole output (x, y, z, w) for dimension group q of a key, words 4q to
// 4q + 3 of its stream. A pass draws either RandomBits or RandomWords4, never both: the two hash the same input for
// dimension q.
inline void RandomWords4(const RngKey& key, uint32_t q, uint32_t (&out)[4]) {
  HashedKey(key, q, out[0], out[1], out[2], out[3]);
}

// Uniform float in [0, 1): the top 24 bits scaled exactly, so 1.0 is never returned.
inline float BitsToUnitFloat(uint32_t bits) { return static_cast<float>(bits >> 8) * 0x1.0p-24f; }

inline float UniformFloat(const RngKey& key, uint32_t dimension) {
  return BitsToUnitFloat(RandomBits(key, dimension));
}

// Convenience: a key plus a running dimension counter, for code that draws a fixed sequence of numbers.
class Sampler {
 public:
  explicit Sampler(const RngKey& key, uint32_t firstDimension = 0) : key_(key), dim_(firstDimension) {}
  float Next() { return UniformFloat(key_, dim_++); }
  uint32_t NextBits() { return RandomBits(key_, dim_++); }
  uint32_t Dimension() const { return dim_; }

 private:
  RngKey key_;
  uint32_t dim_;
};

}  // namespace restir
