// The shadow-ray setup kernel (core/shadow_ray_kernel.h): every SIMD target this machine supports reproduces the
// scalar twin, core/shadow_ray.h ShadowRaySetup per query, bit for bit (DESIGN §3), NaN payloads canonicalised,
// on random queries mixed with the hard ones: the light point at (or a denormal away from) the receiver,
// coordinates whose squares overflow, receiver and emitter normals along, against and exactly across the
// segment (grazing emission), zero and signed-zero normals, zero, huge and non-finite error scales, NaN / Inf /
// denormal inputs, and batch sizes around every vector width (tails, read from memory that faults one past the
// end). What the rule computes is tested in tests/core/shadow_ray_test.cpp.
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
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace shadow_ray_kernel_test {

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
  kGrazingEmission,   // the emitter's normal exactly across the segment, or nearly
  kOddErrorScale,     // error scales of zero, huge, denormal or non-finite
  kKinds
};

constexpr int kFields = 14;  // position, geometric normal, light position, light normal (x y z each), two scales

struct QuerySet {
  std::vector<float> f[kFields];
  std::vector<int> kind;
  size_t Size() const { return kind.size(); }
  ShadowRayInputs View() const {
    const float* p[kFields];
    for (int i = 0; i < kFields; ++i) p[i] = f[i].data();
    return Inputs(p, Size());
  }
  static ShadowRayInputs Inputs(const float* const (&p)[kFields], size_t count) {
    ShadowRayInputs in;
    for (int c = 0; c < 3; ++c) {
      in.position[c] = p[c];
      in.geometricNormal[c] = p[3 + c];
      in.lightPosition[c] = p[6 + c];
      in.lightNormal[c] = p[9 + c];
    }
    in.errorScale = p[12];
    in.lightErrorScale = p[13];
    in.count = count;
    return in;
  }
  // Field 0 x, 1 ng, 2 y, 3 ny.
  Vec3 Field(int field, size_t k) const { return Vec3(f[3 * field][k], f[3 * field + 1][k], f[3 * field + 2][k]); }
  float ErrorScale(size_t k) const { return f[12][k]; }
  float LightErrorScale(size_t k) const { return f[13][k]; }
  ShadowRaySegment Setup(size_t k) const {
    return ShadowRaySetup(Field(0, k), Field(1, k), ErrorScale(k), Field(2, k), Field(3, k), LightErrorScale(k));
  }
  void Push(const Vec3& x, const Vec3& ng, float ex, const Vec3& y, const Vec3& ny, float ey, int k) {
    const Vec3* v[4] = {&x, &ng, &y, &ny};
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) f[i * 3 + c].push_back((*v[i])[c]);
    f[12].push_back(ex);
    f[13].push_back(ey);
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
    // The emitter mostly faces the receiver; its error scale is its coordinates' magnitude, as the light list's.
    Vec3 ny = glm::normalize(glm::normalize(x - y) + 0.9f * RandomUnit(rng));
    auto maxAbs = [](const Vec3& p) { return std::max(std::fabs(p.x), std::max(std::fabs(p.y), std::fabs(p.z))); };
    float ex = maxAbs(x) * (1.0f + u(rng)), ey = maxAbs(y) * (1.0f + u(rng));
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
        Vec3* fields[4] = {&x, &ng, &y, &ny};
        const int hits = 1 + static_cast<int>(rng() % 2);
        for (int h = 0; h < hits; ++h) (*fields[rng() % 4])[static_cast<int>(rng() % 3)] = poison[rng() % 8];
        break;
      }
      case kGrazingEmission: {
        // ny in the plane perpendicular to the segment: exactly for an axis-aligned one, else within rounding.
        const Vec3 w = glm::normalize(y - x);
        ny = u(rng) < 0.5f ? glm::normalize(glm::cross(w, RandomUnit(rng))) : glm::normalize(glm::cross(w, ng));
        if (u(rng) < 0.3f) {  // the segment along one axis, ny along another
          const int axis = static_cast<int>(rng() % 3);
          y[(axis + 1) % 3] = x[(axis + 1) % 3];
          y[(axis + 2) % 3] = x[(axis + 2) % 3];
          ny = Vec3(0.0f);
          ny[(axis + 1) % 3] = u(rng) < 0.5f ? 1.0f : -1.0f;
        }
        break;
      }
      case kOddErrorScale: {
        const float odd[] = {0.0f, -0.0f, 1e-40f, 3e38f, kInf, kNaN, std::bit_cast<float>(0xFFC0BEEFu), 1e6f};
        (u(rng) < 0.5f ? ex : ey) = odd[rng() % 8];
        break;
      }
      default: break;
    }
    s.Push(x, ng, ex, y, ny, ey, kind);
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
  static const char* kKindNames[kKinds] = {"generic",          "light at receiver", "huge",
                                           "normal against dir", "normal across dir", "zero normal",
                                           "non-finite",         "grazing emission",  "odd error scale"};
  static const char* kFieldNames[7] = {"org.x", "org.y", "org.z", "dir.x", "dir.y", "dir.z", "tmax"};
  for (size_t k = 0; k < count; ++k) {
    for (int f = 0; f < 7; ++f) {
      ASSERT_EQ(Bits(want.f[f][k]), Bits(got.f[f][k]))
          << what << " query " << k << " (" << kKindNames[queries.kind[k]] << ") " << kFieldNames[f] << ": "
          << want.f[f][k] << " vs " << got.f[f][k];
    }
  }
}

// The twin is ShadowRaySetup per query with canonical NaNs, nothing more.
TEST_F(ShadowRayKernel, ScalarTwinIsShadowRaySetupPerQuery) {
  std::mt19937 rng(99);
  const QuerySet q = RandomQueries(rng, 2000);
  Rays twin(q.Size());
  SetupShadowRaysScalar(q.View(), twin.View());
  for (size_t k = 0; k < q.Size(); ++k) {
    const ShadowRaySegment r = q.Setup(k);
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

  // The mix reaches every outcome: finite rays offset to either side, NaN and infinite components, NaN in one
  // component of x only (the others of org stay finite), an origin the offset does not move (a zero scale, or an
  // offset below x's float spacing).
  size_t finite = 0, offsetAgainst = 0, nanDir = 0, infTmax = 0, partlyNanOrg = 0, unmoved = 0;
  for (size_t k = 0; k < n; ++k) {
    const Vec3 x = q.Field(0, k), ng = q.Field(1, k);
    const Vec3 org(twin.f[0][k], twin.f[1][k], twin.f[2][k]);
    const Vec3 dir(twin.f[3][k], twin.f[4][k], twin.f[5][k]);
    finite += IsFinite(org) && IsFinite(dir) && std::isfinite(twin.f[6][k]);
    offsetAgainst += IsFinite(org) && glm::dot(org - x, ng) < 0.0f;
    nanDir += std::isnan(dir.x) || std::isnan(dir.y) || std::isnan(dir.z);
    infTmax += std::isinf(twin.f[6][k]);
    partlyNanOrg += std::isnan(x.y) && std::isfinite(org.x);
    unmoved += org == x && IsFinite(x);
  }
  EXPECT_GT(finite, n / 2);
  EXPECT_GT(offsetAgainst, n / 20);
  EXPECT_GT(nanDir, 100u);
  EXPECT_GT(infTmax, 10u);
  EXPECT_GT(partlyNanOrg, 5u);
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
    const float* p[kFields];
    for (int f = 0; f < kFields; ++f) {
      fields.emplace_back(count);
      std::copy(q.f[f].begin(), q.f[f].end(), fields.back().data());
      p[f] = fields.back().data();
    }
    const ShadowRayInputs view = QuerySet::Inputs(p, count);

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

}  // namespace shadow_ray_kernel_test
}  // namespace restir
