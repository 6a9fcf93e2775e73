// The shadow-ray setup kernel (core/shadow_ray_kernel.h): its scalar form ShadowRaySetup is the formula
// sim/pipeline.cpp MakeShadowRay used before the move, and every SIMD target this machine supports reproduces the
// scalar twin bit for bit (DESIGN §3), NaN payloads canonicalised, on random queries mixed with the hard ones:
// the light point at (or a denormal away from) the receiver, coordinates whose squares overflow, normals along,
// against and exactly across the ray, zero and signed-zero normals, NaN / Inf / denormal inputs, and batch sizes
// around every vector width (tails, read from memory that faults one past the end).
#include "core/shadow_ray_kernel.h"

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

#include "core/shadow_ray.h"
#include "core/simd.h"

#include "core/kernel_test_support.h"

namespace restir {
namespace {

class ShadowRayKernel : public test::SimdTargetTest {};

using test::Bits;
using test::Canonical;
using test::GuardedArray;
using test::kInf;
using test::kNaN;


using test::RandomUnit;

// The kinds of query QuerySet mixes; each reaches a different corner of the formula.
enum Kind {
  kGeneric,
  kLightAtReceiver,   // d = 0 or a square that underflows: dir is NaN or infinite
  kHuge,              // squares overflow, eps is huge
  kNormalAgainstDir,  // side -1
  kNormalAcrossDir,   // dot(ng, dir) exactly +-0: side +1 by `>= 0`
  kZeroNormal,
  kNonFinite,         // one input component NaN (with payload), +-Inf, denormal or overflowing when squared
  kKinds
};

struct QuerySet {
  std::vector<float> f[9];  // position, geometric normal, light position (x y z each)
  std::vector<int> kind;
  size_t Size() const { return kind.size(); }
  ShadowRayInputs View() const { return Inputs(f[0].data(), f[1].data(), f[2].data(), f[3].data(), f[4].data(),
                                               f[5].data(), f[6].data(), f[7].data(), f[8].data(), Size()); }
  static ShadowRayInputs Inputs(const float* x0, const float* x1, const float* x2, const float* n0,
                                const float* n1, const float* n2, const float* y0, const float* y1,
                                const float* y2, size_t count) {
    ShadowRayInputs in;
    const float* p[9] = {x0, x1, x2, n0, n1, n2, y0, y1, y2};
    for (int c = 0; c < 3; ++c) {
      in.position[c] = p[c];
      in.geometricNormal[c] = p[3 + c];
      in.lightPosition[c] = p[6 + c];
    }
    in.count = count;
    return in;
  }
  Vec3 Field(int field, size_t k) const { return Vec3(f[3 * field][k], f[3 * field + 1][k], f[3 * field + 2][k]); }
  void Push(const Vec3& x, const Vec3& ng, const Vec3& y, int k) {
    const Vec3* v[3] = {&x, &ng, &y};
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) f[i * 3 + c].push_back((*v[i])[c]);
    kind.push_back(k);
  }
};

QuerySet RandomQueries(std::mt19937& rng, size_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  QuerySet s;
  for (size_t k = 0; k < count; ++k) {
    const int kind = static_cast<int>(rng() % kKinds);
    // A receiver in a room at one of several scene scales, the light mostly in front of it.
    const float scales[] = {1e-3f, 0.1f, 1.0f, 1.0f, 1.0f, 30.0f, 1e4f};
    const float scale = scales[rng() % 7];
    Vec3 x = scale * Vec3(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    Vec3 ng = RandomUnit(rng);
    if (u(rng) < 0.2f) ng = Vec3(0, u(rng) < 0.5f ? 1.0f : -1.0f, 0);  // axis-aligned: exact zeros in products
    if (u(rng) < 0.1f) x.x = u(rng) < 0.5f ? 0.0f : -0.0f;
    Vec3 y = x + scale * (0.1f + 6 * u(rng)) * glm::normalize(ng + 0.95f * RandomUnit(rng));
    switch (kind) {
      case kGeneric: break;
      case kLightAtReceiver: {
        const float offsets[] = {0.0f, 1e-30f, 1e-38f, 1e-44f, 1e-20f};
        y = x + offsets[rng() % 5] * RandomUnit(rng);
        break;
      }
      case kHuge: {
        // Around and beyond sqrt(FLT_MAX) = 1.8e19, up to FLT_MAX itself.
        const float big[] = {1e18f, 2e19f, 1e30f, 3e38f, std::numeric_limits<float>::max()};
        x = big[rng() % 5] * Vec3(u(rng) * 2 - 1, u(rng) * 2 - 1, u(rng) * 2 - 1);
        y = u(rng) < 0.5f ? big[rng() % 5] * Vec3(u(rng) * 2 - 1, u(rng) * 2 - 1, u(rng) * 2 - 1)
                          : Vec3(u(rng), u(rng), u(rng));
        break;
      }
      case kNormalAgainstDir:
        ng = u(rng) < 0.5f ? -glm::normalize(y - x) : glm::normalize(RandomUnit(rng) - 2.0f * glm::normalize(y - x));
        break;
      case kNormalAcrossDir: {
        // The light in the tangent plane of an axis-aligned normal: the dot is an exact +0 or -0.
        const int axis = static_cast<int>(rng() % 3);
        ng = Vec3(0.0f);
        ng[axis] = u(rng) < 0.5f ? 1.0f : -1.0f;
        y[axis] = x[axis];
        if (u(rng) < 0.3f) ng[(axis + 1) % 3] = -0.0f;
        break;
      }
      case kZeroNormal: ng = u(rng) < 0.7f ? Vec3(0.0f) : Vec3(-0.0f, 0.0f, -0.0f); break;
      case kNonFinite: {
        const float poison[] = {kNaN, std::bit_cast<float>(0xFFC0BEEFu), std::bit_cast<float>(0x7FC01234u),
                                kInf, -kInf, 1e-40f, -3e-39f, 3e20f};
        Vec3* fields[3] = {&x, &ng, &y};
        const int hits = 1 + static_cast<int>(rng() % 2);
        for (int h = 0; h < hits; ++h) (*fields[rng() % 3])[static_cast<int>(rng() % 3)] = poison[rng() % 8];
        break;
      }
      default: break;
    }
    s.Push(x, ng, y, kind);
  }
  return s;
}

struct Rays {
  std::vector<float> f[7];  // org, dir (x y z each), tmax
  explicit Rays(size_t n, float fill = -7.0f) {
    for (auto& v : f) v.assign(n, fill);
  }
  ShadowRayOutputs View() {
    ShadowRayOutputs out;
    for (int c = 0; c < 3; ++c) {
      out.org[c] = f[c].data();
      out.dir[c] = f[3 + c].data();
    }
    out.tmax = f[6].data();
    return out;
  }
};

// Bitwise equality of the first `count` rays; names the first difference and the query's kind.
void ExpectSameBits(const Rays& want, const Rays& got, size_t count, const QuerySet& queries,
                    const std::string& what) {
  static const char* kKindNames[kKinds] = {"generic",          "light at receiver", "huge",     "normal against dir",
                                           "normal across dir", "zero normal",       "non-finite"};
  static const char* kFieldNames[7] = {"org.x", "org.y", "org.z", "dir.x", "dir.y", "dir.z", "tmax"};
  for (size_t k = 0; k < count; ++k) {
    for (int f = 0; f < 7; ++f) {
      ASSERT_EQ(Bits(want.f[f][k]), Bits(got.f[f][k]))
          << what << " query " << k << " (" << kKindNames[queries.kind[k]] << ") " << kFieldNames[f] << ": "
          << want.f[f][k] << " vs " << got.f[f][k];
    }
  }
}

// sim/pipeline.cpp MakeShadowRay and sim/embree_scene.cpp OffsetRayOrigin as they were before the move, spelled
// out here so that a change to the core functions cannot pass unnoticed.
ShadowRaySegment OldMakeShadowRay(const Vec3& position, const Vec3& geometricNormal, const Vec3& lightPosition) {
  const Vec3 toLight = lightPosition - position;
  const float d = glm::length(toLight);
  ShadowRaySegment ray;
  ray.dir = toLight / d;
  const Vec3& p = position;
  const float scale = std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z)));
  const float eps = 1e-4f * (1.0f + scale);
  const float side = glm::dot(geometricNormal, ray.dir) >= 0.0f ? 1.0f : -1.0f;
  ray.org = p + (side * eps) * geometricNormal;
  ray.tmax = glm::length(lightPosition - ray.org) * (1.0f - 1e-3f);
  return ray;
}

// Bit for bit once NaN results are canonical: without that rule even two compilations of the same expression can
// give NaNs of opposite sign.
TEST_F(ShadowRayKernel, ScalarFunctionEqualsTheOldMakeShadowRayFormula) {
  std::mt19937 rng(515);
  const QuerySet q = RandomQueries(rng, 5000);
  size_t nan = 0, against = 0;
  for (size_t k = 0; k < q.Size(); ++k) {
    const Vec3 x = q.Field(0, k), ng = q.Field(1, k), y = q.Field(2, k);
    const ShadowRaySegment want = OldMakeShadowRay(x, ng, y);
    const ShadowRaySegment got = ShadowRaySetup(x, ng, y);
    const Vec3 offset = OffsetRayOrigin(x, ng, want.dir);
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(Bits(Canonical(want.org[c])), Bits(Canonical(got.org[c]))) << "query " << k << " org " << c;
      ASSERT_EQ(Bits(Canonical(want.dir[c])), Bits(Canonical(got.dir[c]))) << "query " << k << " dir " << c;
      ASSERT_EQ(Bits(Canonical(want.org[c])), Bits(Canonical(offset[c]))) << "query " << k << " offset " << c;
    }
    ASSERT_EQ(Bits(Canonical(want.tmax)), Bits(Canonical(got.tmax))) << "query " << k << " tmax";
    nan += std::isnan(got.tmax);
    against += glm::dot(ng, want.dir) < 0.0f;
  }
  EXPECT_GT(nan, 50u);
  EXPECT_GT(against, 500u);
}

// The twin is ShadowRaySetup per query with canonical NaNs, nothing more.
TEST_F(ShadowRayKernel, ScalarTwinIsShadowRaySetupPerQuery) {
  std::mt19937 rng(99);
  const QuerySet q = RandomQueries(rng, 2000);
  Rays twin(q.Size());
  SetupShadowRaysScalar(q.View(), twin.View());
  for (size_t k = 0; k < q.Size(); ++k) {
    const ShadowRaySegment r = ShadowRaySetup(q.Field(0, k), q.Field(1, k), q.Field(2, k));
    const float want[7] = {r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z, r.tmax};
    for (int f = 0; f < 7; ++f) ASSERT_EQ(Bits(Canonical(want[f])), Bits(twin.f[f][k])) << "query " << k;
  }
}

TEST_F(ShadowRayKernel, EveryTargetMatchesScalarTwinBitForBit) {
  std::mt19937 rng(20260611);
  const size_t n = 8195;  // a multiple of no vector width: ends in a tail on every target
  const QuerySet q = RandomQueries(rng, n);
  Rays twin(n);
  SetupShadowRaysScalar(q.View(), twin.View());

  // The mix reaches every outcome: finite rays offset to either side, NaN and infinite components, NaN in a
  // position component that std::max drops (so the other components of org stay finite), a zero offset.
  size_t finite = 0, offsetAgainst = 0, nanDir = 0, infTmax = 0, partlyNanOrg = 0, unmoved = 0;
  for (size_t k = 0; k < n; ++k) {
    const Vec3 x = q.Field(0, k), ng = q.Field(1, k);
    const Vec3 org(twin.f[0][k], twin.f[1][k], twin.f[2][k]);
    const Vec3 dir(twin.f[3][k], twin.f[4][k], twin.f[5][k]);
    finite += IsFinite(org) && IsFinite(dir) && std::isfinite(twin.f[6][k]);
    offsetAgainst += IsFinite(org) && glm::dot(org - x, ng) < 0.0f;
    nanDir += std::isnan(dir.x) || std::isnan(dir.y) || std::isnan(dir.z);
    infTmax += std::isinf(twin.f[6][k]);
    partlyNanOrg += IsFinite(ng) && IsFinite(q.Field(2, k)) && (std::isnan(x.y) || std::isnan(x.z)) &&
                    std::isfinite(org.x);
    unmoved += org == x && IsFinite(x);
  }
  EXPECT_GT(finite, n / 2);
  EXPECT_GT(offsetAgainst, n / 20);
  EXPECT_GT(nanDir, 100u);
  EXPECT_GT(infTmax, 10u);
  EXPECT_GT(partlyNanOrg, 10u);
  EXPECT_GT(unmoved, 50u);

  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    Rays got(n);
    SetupShadowRays(q.View(), got.View());
    ExpectSameBits(twin, got, n, q, SimdTargetName(t));
  }
}

// Batch sizes 0, 1, lanes - 1, lanes, lanes + 1 of every width (4, 8, 16 floats) and packets plus a tail: each
// target reads only the queries it is given (the inputs end at a guard page) and writes only their rays (a
// sentinel past the end survives), with the twin's bits.
TEST_F(ShadowRayKernel, TailsTouchOnlyTheirQueriesOnEveryTarget) {
  std::mt19937 rng(77);
  const float sentinel = std::bit_cast<float>(0x7FC0DEADu);
  for (size_t count : {0, 1, 2, 3, 4, 5, 7, 8, 9, 11, 15, 16, 17, 23, 31, 32, 33, 37, 47, 49}) {
    const QuerySet q = RandomQueries(rng, count);
    std::deque<GuardedArray<float>> fields;  // never moves its elements
    for (int f = 0; f < 9; ++f) {
      fields.emplace_back(count);
      std::copy(q.f[f].begin(), q.f[f].end(), fields.back().data());
    }
    const ShadowRayInputs view =
        QuerySet::Inputs(fields[0].data(), fields[1].data(), fields[2].data(), fields[3].data(), fields[4].data(),
                         fields[5].data(), fields[6].data(), fields[7].data(), fields[8].data(), count);

    Rays twin(count);
    SetupShadowRaysScalar(q.View(), twin.View());
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      const std::string what = std::string(SimdTargetName(t)) + " count " + std::to_string(count);
      Rays got(count + 32, sentinel);
      SetupShadowRays(view, got.View());
      ExpectSameBits(twin, got, count, q, what);
      for (size_t k = count; k < count + 32; ++k)
        for (int f = 0; f < 7; ++f) ASSERT_EQ(Bits(got.f[f][k]), Bits(sentinel)) << what << " wrote " << k;
    }
  }
  // An empty batch needs no arrays at all.
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    SetupShadowRays(ShadowRayInputs{}, ShadowRayOutputs{});
  }
}

}  // namespace
}  // namespace restir
