// The target-evaluation kernel (core/target_kernel.h): its scalar twin is TargetFunction(UnshadowedContribution)
// of the pair's ShadingPoint, and every SIMD target this machine supports reproduces the twin bit for bit
// (DESIGN §3), NaN payloads included, on random pairs (diffuse, GGX and layered materials) mixed with the guarded
// and degenerate cases: lights behind the receiver, receivers behind the light, touching points, grazing and
// exactly tangent directions, mirror configurations on near-delta GGX, wo below the surface, zero and infinite
// radiance, NaN / Inf / denormal inputs, and batch sizes around every vector width (tails, read from memory that
// faults one past the end).
#include "core/target_kernel.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/shading.h"
#include "core/simd.h"

#include "core/kernel_test_support.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace target_kernel_test {

class TargetKernel : public test::SimdTargetTest {};

using test::Bits;
using test::Canonical;
using test::GuardedArray;
using test::kInf;
using test::kNaN;

using test::KernelMaterials;
using test::RandomUnit;

// The kinds of pair PairSet mixes; each exercises a branch of ConnectToLight / EvalBsdf.
enum Kind {
  kGeneric,
  kLightBehindReceiver,
  kReceiverBehindLight,
  kTouching,
  kGrazing,
  kMirror,
  kWoBelowSurface,
  kEyeAtReceiver,
  kZeroOrInfiniteRadiance,
  kNonFinite,
  kKinds
};

// Pairs as TargetPairs wants them. Fields: eye, position, geometric normal, shading normal, light position, light
// normal, radiance (3 arrays each, in TargetPairs order).
struct PairSet {
  std::vector<float> f[21];
  std::vector<int32_t> material;
  std::vector<int> kind;
  size_t Size() const { return material.size(); }
  TargetPairs View() const {
    const float* fields[kTargetPairFields];
    for (int k = 0; k < kTargetPairFields; ++k) fields[k] = f[k].data();
    return MakeTargetPairs(fields, material.data(), Size());
  }
  void Push(const Vec3& eye, const Vec3& x, const Vec3& ng, const Vec3& ns, const Vec3& y, const Vec3& ny,
            const Vec3& le, int32_t m, int k) {
    const Vec3* v[7] = {&eye, &x, &ng, &ns, &y, &ny, &le};
    for (int i = 0; i < 7; ++i)
      for (int c = 0; c < 3; ++c) f[i * 3 + c].push_back((*v[i])[c]);
    material.push_back(m);
    kind.push_back(k);
  }
};

PairSet RandomPairs(std::mt19937& rng, size_t count, int materials) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  PairSet s;
  for (size_t k = 0; k < count; ++k) {
    const int kind = static_cast<int>(rng() % kKinds);
    const int32_t m = static_cast<int32_t>(rng() % static_cast<uint32_t>(materials));
    // A generic configuration: receiver in a room, viewer and light mostly in front of it.
    Vec3 x(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    Vec3 ng = RandomUnit(rng);
    if (u(rng) < 0.2f) ng = Vec3(0, 1, 0);  // axis-aligned floors make exact zeros reachable
    Vec3 ns = u(rng) < 0.3f ? ng : glm::normalize(ng + 0.3f * RandomUnit(rng));
    Vec3 eye = x + (0.5f + 8 * u(rng)) * glm::normalize(ng + 0.9f * RandomUnit(rng));
    Vec3 y = x + (0.1f + 6 * u(rng)) * glm::normalize(ns + 0.95f * RandomUnit(rng));
    Vec3 ny = RandomUnit(rng);
    if (glm::dot(ny, y - x) > 0 && u(rng) < 0.8f) ny = -ny;  // mostly facing the receiver
    Vec3 le(u(rng) * 20, u(rng) * 20, u(rng) * 20);
    switch (kind) {
      case kGeneric: break;
      case kLightBehindReceiver: y = x - (0.1f + 3 * u(rng)) * glm::normalize(ng + 0.5f * RandomUnit(rng)); break;
      case kReceiverBehindLight: ny = glm::normalize(y - x); break;
      case kTouching: {
        // At, just inside and around kMinLightDistance.
        const float scales[] = {0.0f, 1e-8f, 3e-7f, 1e-6f, 1.1e-6f, 1e-5f};
        y = x + scales[rng() % 6] * RandomUnit(rng);
        if (u(rng) < 0.2f) y = x;
        break;
      }
      case kGrazing: {
        // The light in (or a rounding error off) the tangent plane of the shading or geometric normal.
        const Vec3 axis = u(rng) < 0.5f ? ns : ng;
        Vec3 t = glm::cross(axis, RandomUnit(rng));
        t = glm::normalize(t);
        const float lift[] = {0.0f, 1e-7f, -1e-7f, 1e-4f, 1e-2f};
        y = x + (0.5f + 3 * u(rng)) * t + lift[rng() % 5] * axis;
        if (u(rng) < 0.3f) eye = x + 4.0f * glm::normalize(t + lift[rng() % 5] * axis);  // grazing view
        if (u(rng) < 0.3f) ny = -glm::normalize(y - x + lift[rng() % 5] * RandomUnit(rng));  // grazing emission
        break;
      }
      case kMirror: {
        // Light along the mirror direction of wo: the near-delta GGX lobes peak (D up to ~1/(pi alpha^2)).
        const Vec3 wo = glm::normalize(eye - x);
        const Vec3 r = 2.0f * glm::dot(ns, wo) * ns - wo;
        y = x + (0.2f + 3 * u(rng)) * r;
        ny = -r;
        break;
      }
      case kWoBelowSurface: eye = x - (0.5f + 5 * u(rng)) * glm::normalize(ns + 0.5f * RandomUnit(rng)); break;
      case kEyeAtReceiver: eye = u(rng) < 0.5f ? x : x + 1e-30f * RandomUnit(rng); break;
      case kZeroOrInfiniteRadiance: {
        const int which = static_cast<int>(rng() % 3);
        le = which == 0 ? Vec3(0.0f) : (which == 1 ? Vec3(kInf, 1, 1) : Vec3(0, 0, 1e38f));
        break;
      }
      case kNonFinite: {
        // One component of one field poisoned: NaNs with and without payload or sign, +-Inf, denormals, or a
        // value whose square overflows.
        const float poison[] = {kNaN, std::bit_cast<float>(0xFFC0BEEFu), std::bit_cast<float>(0x7FC01234u),
                                kInf, -kInf, 1e-40f, -3e-39f, 3e20f};
        Vec3* fields[7] = {&eye, &x, &ng, &ns, &y, &ny, &le};
        (*fields[rng() % 7])[static_cast<int>(rng() % 3)] = poison[rng() % 8];
        break;
      }
      default: break;
    }
    s.Push(eye, x, ng, ns, y, ny, le, m, kind);
  }
  return s;
}

struct Results {
  std::vector<float> target, rgb[3];
  explicit Results(size_t n, float fill = -7.0f) : target(n, fill) {
    for (auto& v : rgb) v.assign(n, fill);
  }
  TargetResults View(bool withRgb) {
    TargetResults r;
    r.target = target.data();
    if (withRgb)
      for (int c = 0; c < 3; ++c) r.contribution[c] = rgb[c].data();
    return r;
  }
};

// Bitwise equality of the first `count` entries; names the first difference and the pair's kind.
void ExpectSameBits(const Results& want, const Results& got, size_t count, bool rgb, const PairSet& pairs,
                    const std::string& what) {
  static const char* kKindNames[kKinds] = {"generic", "light behind receiver", "receiver behind light", "touching",
                                           "grazing", "mirror", "wo below surface", "eye at receiver",
                                           "zero/inf radiance", "non-finite"};
  for (size_t k = 0; k < count; ++k) {
    const std::string where = what + " pair " + std::to_string(k) + " (" + kKindNames[pairs.kind[k]] + ")";
    ASSERT_EQ(Bits(want.target[k]), Bits(got.target[k]))
        << where << " target: " << want.target[k] << " vs " << got.target[k];
    if (!rgb) continue;
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(Bits(want.rgb[c][k]), Bits(got.rgb[c][k]))
          << where << " contribution[" << c << "]: " << want.rgb[c][k] << " vs " << got.rgb[c][k];
  }
}

// The kernel's wo is GLM's normalize expression, not v / length(v): the two differ in the last bit for some v,
// so the kernel must use the one the twin gets from glm::normalize.
TEST_F(TargetKernel, GlmNormalizeIsProductWithReciprocalSqrt) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  int differsFromDivision = 0;
  for (int i = 0; i < 10000; ++i) {
    const Vec3 v(u(rng), u(rng), u(rng));
    const Vec3 n = glm::normalize(v);
    const float inv = 1.0f / std::sqrt((v.x * v.x + v.y * v.y) + v.z * v.z);
    const Vec3 divided = v / glm::length(v);
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(Bits(n[c]), Bits(v[c] * inv)) << "v = " << v.x << " " << v.y << " " << v.z;
      differsFromDivision += Bits(n[c]) != Bits(divided[c]);
    }
  }
  EXPECT_GT(differsFromDivision, 100);
}


// Bit for bit once NaN results are canonical (core/target_kernel.h): without that rule even this test's own
// compilation of the same expression can give a NaN of the other sign.
TEST_F(TargetKernel, ScalarTwinEqualsTargetFunctionOfUnshadowedContribution) {
  std::mt19937 rng(4242);
  const std::vector<Bsdf> bsdfs = KernelMaterials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const PairSet pairs = RandomPairs(rng, 3000, static_cast<int>(bsdfs.size()));
  Results twin(pairs.Size());
  EvaluateTargetsScalar(pairs.View(), materials, twin.View(true));
  Results direct(pairs.Size());
  for (size_t k = 0; k < pairs.Size(); ++k) {
    auto v = [&](int field) { return Vec3(pairs.f[field][k], pairs.f[field + 1][k], pairs.f[field + 2][k]); };
    ShadingPoint sp;
    sp.position = v(3);
    sp.geometricNormal = v(6);
    sp.shadingNormal = v(9);
    sp.wo = glm::normalize(v(0) - sp.position);
    sp.bsdf = bsdfs[static_cast<size_t>(pairs.material[k])];
    LightSample y;
    y.position = v(12);
    y.normal = v(15);
    y.radiance = v(18);
    const Vec3 f = UnshadowedContribution(sp, y);
    direct.target[k] = Canonical(TargetFunction(f));
    for (int c = 0; c < 3; ++c) direct.rgb[c][k] = Canonical(f[c]);
  }
  ExpectSameBits(direct, twin, pairs.Size(), true, pairs, "direct vs twin");
  size_t nan = 0;
  for (float t : twin.target) nan += std::isnan(t);
  EXPECT_GT(nan, 10u);  // the canonical-NaN rule was exercised
}

// Every supported target against the twin on 4099 random pairs over KernelMaterials(layered).
void ExpectEveryTargetMatchesTwin(bool layered) {
  std::mt19937 rng(20260611);
  const std::vector<Bsdf> bsdfs = KernelMaterials(layered);
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const size_t n = 4099;  // a multiple of no vector width: ends in a tail on every target
  const PairSet pairs = RandomPairs(rng, n, static_cast<int>(bsdfs.size()));
  Results twin(n);
  EvaluateTargetsScalar(pairs.View(), materials, twin.View(true));

  // The case mix reaches every outcome: positive targets (diffuse, GGX and layered), exact zeros, NaN and
  // infinities.
  size_t positive = 0, positiveGgx = 0, positiveLayered = 0, zero = 0, nan = 0, inf = 0;
  for (size_t k = 0; k < n; ++k) {
    const float t = twin.target[k];
    const BsdfType type = bsdfs[static_cast<size_t>(pairs.material[k])].type;
    positive += t > 0.0f;
    positiveGgx += t > 0.0f && type == BsdfType::kGgx;
    positiveLayered += t > 0.0f && type == BsdfType::kLayered;
    zero += t == 0.0f;
    nan += std::isnan(t);
    inf += std::isinf(t);
  }
  EXPECT_GT(positive, n / 4);
  EXPECT_GT(positiveGgx, layered ? n / 16 : n / 8);
  if (layered) {
    EXPECT_GT(positiveLayered, n / 8);
  }
  EXPECT_GT(zero, n / 4);
  EXPECT_GT(nan, 10u);
  EXPECT_GT(inf, 0u);

  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    for (bool rgb : {true, false}) {
      Results got(n);
      EvaluateTargets(pairs.View(), materials, got.View(rgb));
      ExpectSameBits(twin, got, n, rgb, pairs,
                     std::string(SimdTargetName(t)) + (rgb ? " rgb" : " target only") +
                         (layered ? "" : " (no layered)"));
      if (!rgb) {
        for (int c = 0; c < 3; ++c) {
          for (size_t k = 0; k < n; ++k) ASSERT_EQ(got.rgb[c][k], -7.0f) << SimdTargetName(t) << " wrote rgb";
        }
      }
    }
  }
}

TEST_F(TargetKernel, EveryTargetMatchesScalarTwinBitForBit) {
  ExpectEveryTargetMatchesTwin(true);
  ExpectEveryTargetMatchesTwin(false);
}

// Batch sizes 0, 1, lanes - 1, lanes, lanes + 1 of every width (4, 8, 16 floats) and two packets plus a tail:
// each target reads only the pairs it is given (the inputs end at a guard page) and writes only their results
// (a sentinel past the end survives), with the twin's bits.
TEST_F(TargetKernel, TailsTouchOnlyTheirPairsOnEveryTarget) {
  std::mt19937 rng(77);
  const std::vector<Bsdf> bsdfs = KernelMaterials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const float sentinel = std::bit_cast<float>(0x7FC0DEADu);
  for (size_t count : {0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 33, 37}) {
    const PairSet pairs = RandomPairs(rng, count, static_cast<int>(bsdfs.size()));
    std::deque<GuardedArray<float>> fields;  // never moves its elements
    for (int f = 0; f < 21; ++f) {
      fields.emplace_back(count);
      std::copy(pairs.f[f].begin(), pairs.f[f].end(), fields.back().data());
    }
    GuardedArray<int32_t> material(count);
    std::copy(pairs.material.begin(), pairs.material.end(), material.data());
    const float* fieldPointers[kTargetPairFields];
    for (int f = 0; f < kTargetPairFields; ++f) fieldPointers[f] = fields[f].data();
    const TargetPairs view = MakeTargetPairs(fieldPointers, material.data(), count);

    Results twin(count);
    EvaluateTargetsScalar(pairs.View(), materials, twin.View(true));
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      for (bool rgb : {true, false}) {
        const std::string what = std::string(SimdTargetName(t)) + " count " + std::to_string(count);
        Results got(count + 32, sentinel);
        EvaluateTargets(view, materials, got.View(rgb));
        ExpectSameBits(twin, got, count, rgb, pairs, what);
        for (size_t k = count; k < count + 32; ++k) {
          ASSERT_EQ(Bits(got.target[k]), Bits(sentinel)) << what << " wrote target " << k;
          for (int c = 0; c < 3; ++c) ASSERT_EQ(Bits(got.rgb[c][k]), Bits(sentinel)) << what << " wrote rgb " << k;
        }
        if (!rgb) {
          for (size_t k = 0; k < count; ++k) {
            for (int c = 0; c < 3; ++c) ASSERT_EQ(Bits(got.rgb[c][k]), Bits(sentinel)) << what << " wrote rgb";
          }
        }
      }
    }
  }
  // An empty batch needs no arrays at all.
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    EvaluateTargets(TargetPairs{}, materials, TargetResults{});
  }
}

}  // namespace target_kernel_test
}  // namespace restir
