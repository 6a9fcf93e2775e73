// The initial-sampling kernel (core/ris_kernel.h): its scalar twin reproduces the pipeline's original scalar
// RIS bit for bit, and every SIMD target this machine supports reproduces the scalar twin bit for bit
// (DESIGN §3), on random receivers, materials (diffuse, GGX and layered) and lights, including back-facing and
// switched-off lights, inactive pixels, M = 1, runs that are not a multiple of the vector width, and all-zero
// targets.
#include "core/ris_kernel.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/reservoir.h"
#include "core/rng.h"
#include "core/shading.h"
#include "core/simd.h"

#include "core/kernel_test_support.h"

namespace restir {
namespace {

class RisKernelTest : public test::SimdTargetTest {};

using test::RandomUnit;

std::vector<LightTriangle> RandomLights(std::mt19937& rng, int count, float offFraction) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<LightTriangle> lights;
  while (static_cast<int>(lights.size()) < count) {
    const Vec3 p0(u(rng) * 8 - 4, u(rng) * 4 - 1, u(rng) * 8 - 4);
    const float size = 0.01f + u(rng) * u(rng) * 2.0f;
    const Vec3 p1 = p0 + size * RandomUnit(rng), p2 = p0 + size * RandomUnit(rng);
    Vec3 radiance(u(rng) * 20, u(rng) * 20, u(rng) * 20);
    if (u(rng) < offFraction) radiance = Vec3(0.0f);
    LightTriangle t;
    if (MakeLightTriangle(p0, p1, p2, radiance, t)) lights.push_back(t);  // random facing: many face away
  }
  return lights;
}

struct PixelRun {
  std::vector<float> f[12];  // position, geometric normal, shading normal, wo
  std::vector<int32_t> material;
  std::vector<uint8_t> active;
  RisPixels View(uint32_t pixelBase) const {
    RisPixels p;
    for (int c = 0; c < 3; ++c) {
      p.position[c] = f[c].data();
      p.geometricNormal[c] = f[3 + c].data();
      p.shadingNormal[c] = f[6 + c].data();
      p.wo[c] = f[9 + c].data();
    }
    p.materialId = material.data();
    p.active = active.data();
    p.pixelBase = pixelBase;
    p.count = active.size();
    return p;
  }
};

PixelRun RandomPixels(std::mt19937& rng, size_t count, int materials, float activeFraction) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  PixelRun r;
  for (auto& v : r.f) v.resize(count);
  r.material.resize(count);
  r.active.resize(count);
  for (size_t k = 0; k < count; ++k) {
    const Vec3 p(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    const Vec3 ng = RandomUnit(rng);
    // Shading normal near the geometric one (sometimes exactly it), wo mostly in the upper hemisphere.
    Vec3 ns = u(rng) < 0.3f ? ng : glm::normalize(ng + 0.3f * RandomUnit(rng));
    Vec3 wo = glm::normalize(ng + 0.9f * RandomUnit(rng));
    if (u(rng) < 0.05f) wo = -wo;
    for (int c = 0; c < 3; ++c) {
      r.f[c][k] = p[c];
      r.f[3 + c][k] = ng[c];
      r.f[6 + c][k] = ns[c];
      r.f[9 + c][k] = wo[c];
    }
    r.material[k] = static_cast<int32_t>(rng() % static_cast<uint32_t>(materials));
    r.active[k] = u(rng) < activeFraction ? 1 : 0;
    if (!r.active[k]) r.material[k] = -1;  // as the G-buffer marks a miss: must never be read
  }
  return r;
}

std::vector<Bsdf> RandomMaterials(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Bsdf> m;
  for (float alpha : {1e-4f, 0.01f, 0.09f, 0.25f, 0.6f, 1.0f}) {
    Bsdf d;
    d.type = BsdfType::kDiffuse;
    d.albedo = Vec3(u(rng), u(rng), u(rng));
    m.push_back(d);
    Bsdf g;
    g.type = BsdfType::kGgx;
    g.albedo = Vec3(u(rng), u(rng), u(rng));
    g.alpha = alpha;
    m.push_back(g);
    // Layered as sim/ maps metallic-roughness: albedo (1 - s) baseColor, weight s, F0 in [0, 1]^3.
    Bsdf l;
    l.type = BsdfType::kLayered;
    l.specularWeight = u(rng);
    l.albedo = (1.0f - l.specularWeight) * Vec3(u(rng), u(rng), u(rng));
    l.specular = Vec3(u(rng), u(rng), u(rng));
    l.alpha = alpha;
    m.push_back(l);
  }
  return m;
}

struct Outputs {
  std::vector<int32_t> id;
  std::vector<float> f[12];
  explicit Outputs(size_t n) : id(n, -7) {
    for (auto& v : f) v.assign(n, -7.0f);
  }
  RisOutput View() {
    RisOutput o;
    o.lightId = id.data();
    for (int c = 0; c < 3; ++c) {
      o.position[c] = f[c].data();
      o.normal[c] = f[3 + c].data();
      o.radiance[c] = f[6 + c].data();
    }
    o.pdfArea = f[9].data();
    o.weightSum = f[10].data();
    o.targetPdf = f[11].data();
    return o;
  }
};

// Bitwise equality of every output of every pixel; names the first difference.
void ExpectBitIdentical(const Outputs& a, const Outputs& b, const std::string& what) {
  static const char* kNames[12] = {"pos.x", "pos.y", "pos.z", "n.x", "n.y", "n.z",
                                   "L.r",   "L.g",   "L.b",   "pdfArea", "weightSum", "targetPdf"};
  for (size_t k = 0; k < a.id.size(); ++k) {
    ASSERT_EQ(a.id[k], b.id[k]) << what << " pixel " << k << " lightId";
    for (int f = 0; f < 12; ++f) {
      uint32_t ba, bb;
      std::memcpy(&ba, &a.f[f][k], 4);
      std::memcpy(&bb, &b.f[f][k], 4);
      ASSERT_EQ(ba, bb) << what << " pixel " << k << " " << kNames[f] << ": " << a.f[f][k] << " vs " << b.f[f][k];
    }
  }
}

// The pipeline's initial pass as it was before the kernel (LightSampler::Sample on the AoS lights), per pixel.
Outputs LegacyScalar(const PixelRun& run, uint32_t pixelBase, const LightSampler& sampler,
                     const std::vector<Bsdf>& bsdfs, const RisParams& params) {
  Outputs o(run.active.size());
  for (size_t k = 0; k < run.active.size(); ++k) {
    Reservoir r{};  // always set below; {} for GCC -O1 flow analysis
    bool any = false;
    if (run.active[k] && !sampler.Empty()) {
      ShadingPoint sp;
      sp.position = Vec3(run.f[0][k], run.f[1][k], run.f[2][k]);
      sp.geometricNormal = Vec3(run.f[3][k], run.f[4][k], run.f[5][k]);
      sp.shadingNormal = Vec3(run.f[6][k], run.f[7][k], run.f[8][k]);
      sp.wo = Vec3(run.f[9][k], run.f[10][k], run.f[11][k]);
      sp.bsdf = bsdfs[static_cast<size_t>(run.material[k])];
      Sampler s(RngKey{params.seed, params.frame, pixelBase + static_cast<uint32_t>(k), params.pass});
      for (int j = 0; j < params.candidates; ++j) {
        const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next(), uSel = s.Next();
        const LightSample y = sampler.Sample(u0, u1, u2, u3);
        const float target = TargetFunction(UnshadowedContribution(sp, y));
        any |= StreamCandidate(r, y, target, RisWeight(target, y.pdfArea), uSel);
      }
    }
    if (!any) r.sample = LightSample{0, Vec3(0.0f), Vec3(0.0f), Vec3(0.0f), 0.0f};
    o.id[k] = static_cast<int32_t>(r.sample.lightId);
    for (int c = 0; c < 3; ++c) {
      o.f[c][k] = r.sample.position[c];
      o.f[3 + c][k] = r.sample.normal[c];
      o.f[6 + c][k] = r.sample.radiance[c];
    }
    o.f[9][k] = r.sample.pdfArea;
    o.f[10][k] = r.weightSum;
    o.f[11][k] = r.targetPdf;
  }
  return o;
}

// Runs the scalar twin, the legacy code and every supported SIMD target on one case; all must agree. Returns
// how many pixels selected a sample (so a test can check it exercised the selection path).
size_t CheckCase(const PixelRun& run, uint32_t pixelBase, const std::vector<LightTriangle>& lights,
               LightSelection selection, const std::vector<Bsdf>& bsdfs, const RisParams& params,
               const std::string& what) {
  const LightSampler sampler(lights, selection);
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const RisPixels px = run.View(pixelBase);
  Outputs twin(run.active.size());
  RisInitialSamplingScalar(px, sampler.Soa(), materials, params, twin.View());
  ExpectBitIdentical(LegacyScalar(run, pixelBase, sampler, bsdfs, params), twin, what + " legacy vs twin");
  for (SimdTarget t : SupportedSimdTargets()) {
    EXPECT_TRUE(SetSimdTarget(t));
    Outputs simd(run.active.size());
    RisInitialSampling(px, sampler.Soa(), materials, params, simd.View());
    ExpectBitIdentical(twin, simd, what + " twin vs " + SimdTargetName(t));
  }
  size_t selected = 0;
  for (size_t k = 0; k < run.active.size(); ++k) selected += twin.f[11][k] > 0.0f;
  return selected;
}

TEST_F(RisKernelTest, SupportedTargetsIncludeScalarAndDispatchFollowsTheChoice) {
  const std::vector<SimdTarget> targets = SupportedSimdTargets();
  ASSERT_FALSE(targets.empty());
  EXPECT_EQ(targets.front(), SimdTarget::kScalar);
  for (SimdTarget t : targets) {
    ASSERT_TRUE(SetSimdTarget(t));
    EXPECT_STREQ(ActiveSimdTargetName(), SimdTargetName(t));
  }
  ASSERT_TRUE(SetSimdTarget(SimdTarget::kAuto));
  EXPECT_EQ(ActiveSimdTarget(), targets.back());
  EXPECT_STREQ(RisKernelDispatchedTargetName(), test::ExpectedDispatchName(targets.back()));
}

TEST_F(RisKernelTest, ParseAndNameRoundTrip) {
  for (SimdTarget t : {SimdTarget::kAuto, SimdTarget::kScalar, SimdTarget::kSse4, SimdTarget::kAvx2,
                       SimdTarget::kAvx512})
    EXPECT_EQ(ParseSimdTarget(SimdTargetName(t)), t);
  EXPECT_FALSE(ParseSimdTarget("avx1024").has_value());
}

TEST_F(RisKernelTest, BitIdenticalAcrossTargetsOnRandomInputs) {
  std::mt19937 rng(20261122);
  const std::vector<Bsdf> bsdfs = RandomMaterials(rng);
  size_t selected = 0, active = 0, selectedGgx = 0, selectedLayered = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const std::vector<LightTriangle> lights = RandomLights(rng, 1 + static_cast<int>(rng() % 300), 0.2f);
    const size_t count = 1 + rng() % 203;  // rarely a multiple of the vector width: exercises the tail
    const PixelRun run = RandomPixels(rng, count, static_cast<int>(bsdfs.size()), 0.85f);
    RisParams params;
    params.seed = rng();
    params.frame = rng() % 1000;
    params.pass = static_cast<uint32_t>(RngPass::kInitial);
    params.candidates = trial % 4 == 0 ? 1 : (trial % 4 == 1 ? 32 : 1 + static_cast<int>(rng() % 40));
    const uint32_t base = rng() % 5000000;
    const LightSelection selection = trial % 3 == 2 ? LightSelection::kUniform : LightSelection::kPower;
    selected += CheckCase(run, base, lights, selection, bsdfs, params, "trial " + std::to_string(trial));
    for (size_t k = 0; k < count; ++k) active += run.active[k];
    // GGX receivers that selected something (the twin decides; the targets agree with it).
    const LightSampler sampler(lights, selection);
    Outputs o(count);
    RisInitialSamplingScalar(run.View(base), sampler.Soa(), MakeBsdfSoa(bsdfs), params, o.View());
    for (size_t k = 0; k < count; ++k) {
      if (!run.active[k] || !(o.f[11][k] > 0.0f)) continue;
      const BsdfType type = bsdfs[static_cast<size_t>(run.material[k])].type;
      selectedGgx += type == BsdfType::kGgx;
      selectedLayered += type == BsdfType::kLayered;
    }
  }
  // The cases exercised selection, on every BSDF: most active receivers see some light.
  EXPECT_GT(selected, active / 3);
  EXPECT_GT(selectedGgx, active / 10);
  EXPECT_GT(selectedLayered, active / 10);
}

TEST_F(RisKernelTest, AllZeroTargetsGiveEmptyReservoirs) {
  std::mt19937 rng(5);
  const std::vector<Bsdf> bsdfs = RandomMaterials(rng);
  // Lights face up at y = 3, receivers below them face down: every G is zero.
  std::vector<LightTriangle> lights;
  for (int i = 0; i < 20; ++i) {
    LightTriangle t;
    const float x = float(i) * 0.3f;
    ASSERT_TRUE(MakeLightTriangle(Vec3(x, 3, 0), Vec3(x, 3, 1), Vec3(x + 1, 3, 0), Vec3(5.0f), t));
    lights.push_back(t);
  }
  PixelRun run = RandomPixels(rng, 37, static_cast<int>(bsdfs.size()), 1.0f);
  for (size_t k = 0; k < 37; ++k) {
    run.f[1][k] = 0.0f;
    run.f[3][k] = run.f[6][k] = 0.0f, run.f[4][k] = run.f[7][k] = -1.0f, run.f[5][k] = run.f[8][k] = 0.0f;
  }
  RisParams params{1, 2, static_cast<uint32_t>(RngPass::kInitial), 16};
  CheckCase(run, 0, lights, LightSelection::kPower, bsdfs, params, "zero targets");
  const LightSampler sampler(lights, LightSelection::kPower);
  Outputs o(37);
  RisInitialSampling(run.View(0), sampler.Soa(), MakeBsdfSoa(bsdfs), params, o.View());
  for (size_t k = 0; k < 37; ++k) {
    EXPECT_EQ(o.f[10][k], 0.0f);
    EXPECT_EQ(o.f[11][k], 0.0f);
    EXPECT_EQ(o.id[k], 0);
  }
}

TEST_F(RisKernelTest, InactivePixelsAndEmptySamplersOutputEmptyReservoirs) {
  std::mt19937 rng(9);
  const std::vector<Bsdf> bsdfs = RandomMaterials(rng);
  const std::vector<LightTriangle> lights = RandomLights(rng, 72, 0.0f);
  const PixelRun run = RandomPixels(rng, 50, static_cast<int>(bsdfs.size()), 0.0f);  // nothing active
  RisParams params{3, 4, static_cast<uint32_t>(RngPass::kInitial), 32};
  CheckCase(run, 100, lights, LightSelection::kPower, bsdfs, params, "inactive");
  // Every light switched off: the sampler is empty, its SoA view too.
  const std::vector<LightTriangle> off = RandomLights(rng, 10, 1.0f);
  const PixelRun active = RandomPixels(rng, 21, static_cast<int>(bsdfs.size()), 1.0f);
  const LightSampler sampler(off, LightSelection::kPower);
  ASSERT_TRUE(sampler.Empty());
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    Outputs o(21);
    RisInitialSampling(active.View(0), sampler.Soa(), MakeBsdfSoa(bsdfs), params, o.View());
    for (size_t k = 0; k < 21; ++k) {
      EXPECT_EQ(o.id[k], 0);
      for (int f = 0; f < 12; ++f) EXPECT_EQ(o.f[f][k], 0.0f) << SimdTargetName(t);
    }
  }
}

TEST_F(RisKernelTest, TouchingAndGrazingLightsAgree) {
  // Receivers on the lights' own planes and at their vertices: distances below kMinLightDistance and cosines of
  // exactly zero take the guarded branches.
  std::mt19937 rng(11);
  const std::vector<Bsdf> bsdfs = RandomMaterials(rng);
  const std::vector<LightTriangle> lights = RandomLights(rng, 8, 0.0f);
  PixelRun run = RandomPixels(rng, 64, static_cast<int>(bsdfs.size()), 1.0f);
  for (size_t k = 0; k < 64; ++k) {
    const LightTriangle& t = lights[k % lights.size()];
    const Vec3 p = k % 2 ? t.p0 : t.p0 + 0.25f * t.e1 + 0.25f * t.e2;
    for (int c = 0; c < 3; ++c) run.f[c][k] = p[c];
  }
  RisParams params{7, 0, static_cast<uint32_t>(RngPass::kInitial), 32};
  CheckCase(run, 0, lights, LightSelection::kPower, bsdfs, params, "touching");
}

}  // namespace
}  // namespace restir
