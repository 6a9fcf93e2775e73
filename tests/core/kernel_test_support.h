// What the SIMD-kernel tests share: a fixture restoring the process-wide SIMD target, bit-level float helpers,
// random geometry, a grid of materials with poisoned entries and arrays that end at an inaccessible page.
#pragma once

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/bsdf.h"
#include "core/math.h"
#include "core/simd.h"

namespace restir::test {

// Restores the process-wide target after each test (tests force each target in turn).
class SimdTargetTest : public ::testing::Test {
 protected:
  void TearDown() override { SetSimdTarget(SimdTarget::kAuto); }
};

// Highway's name for the target each concrete SimdTarget forces ("scalar" for the twins), as a kernel's
// DispatchedTargetName reports it.
inline const char* ExpectedDispatchName(SimdTarget t) {
  switch (t) {
    case SimdTarget::kScalar: return "scalar";
    case SimdTarget::kSse4: return "SSE4";
    case SimdTarget::kAvx2: return "AVX2";
    case SimdTarget::kAvx512: return "AVX3";
    case SimdTarget::kAuto: break;
  }
  return "";
}

inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
inline constexpr float kInf = std::numeric_limits<float>::infinity();

inline uint32_t Bits(float v) { return std::bit_cast<uint32_t>(v); }

// The kernels' rule for NaN outputs (core/math.h): one canonical bit pattern, whatever payload the arithmetic
// carried.
inline float Canonical(float v) { return CanonicalNaN(v); }

// A uniformly distributed unit vector (normalised Gaussian triple).
inline Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (;;) {
    const Vec3 v(n(rng), n(rng), n(rng));
    const float l = glm::length(v);
    if (l > 1e-3f) return v / l;
  }
}

// Diffuse and GGX over the range of alpha the kernel must survive (0 and near-delta to wider than physical),
// F0 = 1, a black diffuse, and two poisoned entries (NaN alpha, infinite albedo); with `layered`, also kLayered
// over the same alphas, its two limits (s = 0: Lambert; s = 1 with no diffuse: GGX) and poisoned layered
// entries (NaN and infinite weight, infinite F0, NaN alpha). Without, no packet holds a layered lane, the case
// where GatherBsdfV skips the layered gathers.
inline std::vector<Bsdf> KernelMaterials(bool layered = true) {
  std::vector<Bsdf> m;
  m.push_back(Bsdf{BsdfType::kDiffuse, Vec3(0.8f, 0.5f, 0.2f), 0.25f});
  m.push_back(Bsdf{BsdfType::kDiffuse, Vec3(0.0f), 0.25f});
  for (float alpha : {0.0f, 1e-7f, 1e-4f, 1e-2f, 0.09f, 0.25f, 0.6f, 1.0f, 2.5f})
    m.push_back(Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), alpha});
  m.push_back(Bsdf{BsdfType::kGgx, Vec3(1.0f), 0.05f});
  m.push_back(Bsdf{BsdfType::kGgx, Vec3(0.5f), kNaN});
  m.push_back(Bsdf{BsdfType::kDiffuse, Vec3(kInf, 0.5f, 0.5f), 0.25f});
  if (!layered) return m;
  for (float alpha : {0.0f, 1e-7f, 1e-4f, 1e-2f, 0.09f, 0.25f, 0.6f, 1.0f, 2.5f})
    m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.3f, 0.2f, 0.1f), alpha, Vec3(0.04f), 0.5f});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.1f, 0.6f, 0.9f), 0.2f, Vec3(0.9f, 0.6f, 0.3f), 0.0f});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.0f), 0.05f, Vec3(1.0f, 0.8f, 0.5f), 1.0f});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.2f), 0.3f, Vec3(0.5f), kNaN});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.2f), 0.3f, Vec3(0.5f), kInf});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.2f), 0.3f, Vec3(kInf, 0.5f, 0.5f), 0.5f});
  m.push_back(Bsdf{BsdfType::kLayered, Vec3(0.2f), kNaN, Vec3(0.5f), 0.5f});
  return m;
}

// `count` elements ending exactly where a PROT_NONE page begins: reading one past the end faults.
template <typename T>
class GuardedArray {
 public:
  explicit GuardedArray(size_t count) {
    const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
    bytes_ = (count * sizeof(T) + page - 1) / page * page + page;
    base_ = static_cast<char*>(mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
    EXPECT_NE(base_, MAP_FAILED);
    EXPECT_EQ(mprotect(base_ + bytes_ - page, page, PROT_NONE), 0);
    data_ = reinterpret_cast<T*>(base_ + bytes_ - page) - count;
  }
  ~GuardedArray() { munmap(base_, bytes_); }
  GuardedArray(const GuardedArray&) = delete;
  GuardedArray& operator=(const GuardedArray&) = delete;
  T* data() { return data_; }

 private:
  size_t bytes_ = 0;
  char* base_ = nullptr;
  T* data_ = nullptr;
};

}  // namespace restir::test
