// The BSDF-draw kernel (core/bsdf_draw_kernel.h): every SIMD target this machine supports reproduces the scalar
// twin bit for bit (DESIGN §3), NaN payloads canonicalised, on random receivers (diffuse, GGX from mirror to rough,
// layered with both pure ends, black, poisoned; tilted, grazing, far from the origin) and batch sizes around every
// vector width. What the twin computes is checked against an answer it does not compute: its throughput f cos θ /
// p is an unbiased estimate of the BSDF's directional albedo ∫ f cos θ dω, computed here by a midpoint quadrature
// over the hemisphere in double (t-test); and its rays start on the sampled direction's side of the surface.
#include "core/bsdf_draw_kernel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/kernel_test_support.h"
#include "core/sampling.h"
#include "core/simd.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace bsdf_draw_kernel_test {

class BsdfDrawKernel : public test::SimdTargetTest {};

using test::Bits;
using test::GuardedArray;
using test::kInf;
using test::RandomUnit;

struct Outputs {
  explicit Outputs(size_t n) : draw(n) {
    for (auto& f : fields) f = std::make_unique<GuardedArray<float>>(n);
  }
  std::unique_ptr<GuardedArray<float>> fields[10];
  GuardedArray<uint32_t> draw;
  BsdfDrawOutputs View() {
    BsdfDrawOutputs o;
    for (int c = 0; c < 3; ++c) {
      o.org[c] = fields[c]->data();
      o.dir[c] = fields[3 + c]->data();
      o.weight[c] = fields[6 + c]->data();
    }
    o.pdf = fields[9]->data();
    o.draw = draw.data();
    return o;
  }
};

TEST_F(BsdfDrawKernel, EveryTargetMatchesScalarTwinBitForBit) {
  std::mt19937 rng(20261128);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::vector<Bsdf> bsdfs = test::KernelMaterials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  const std::vector<size_t> drawCounts{0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 48, 64, 65, 100, 1000};
  size_t compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    LightDrawReceiver r;
    const float far = trial % 4 == 0 ? 1000.0f : 1.0f;
    r.position = far * Vec3(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    r.geometricNormal = trial % 5 == 0 ? Vec3(0, 0, trial % 10 == 0 ? -1.0f : 1.0f) : RandomUnit(rng);
    r.shadingNormal =
        trial % 3 == 0 ? r.geometricNormal : glm::normalize(r.geometricNormal + 0.3f * RandomUnit(rng));
    r.wo = glm::normalize(r.geometricNormal * (trial % 7 == 0   ? -0.2f
                                               : trial % 6 == 0 ? 0.001f
                                                                : 1.0f) +
                          0.8f * RandomUnit(rng));
    r.errorScale = far * 6.0f;
    r.materialId = static_cast<int32_t>(trial % bsdfs.size());
    const size_t n = drawCounts[static_cast<size_t>(trial) % drawCounts.size()];
    GuardedArray<float> u0(n), u1(n);
    for (size_t k = 0; k < n; ++k) {
      u0.data()[k] = k % 9 == 0 ? 0.0f : k % 9 == 1 ? 0x1.fffffep-1f : u(rng);
      u1.data()[k] = k % 11 == 0 ? 0.0f : k % 11 == 1 ? 0x1.fffffep-1f : k % 11 == 2 ? 0.25f : u(rng);
    }
    const BsdfDraws draws{u0.data(), u1.data(), n};
    Outputs twin(n);
    const size_t counted = DrawBsdfSamplesScalar(r, materials, draws, twin.View());
    for (size_t e = 1; e < counted; ++e) ASSERT_LT(twin.draw.data()[e - 1], twin.draw.data()[e]);
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      EXPECT_STREQ(BsdfDrawKernelDispatchedTargetName(), test::ExpectedDispatchName(t));
      Outputs got(n);
      ASSERT_EQ(DrawBsdfSamples(r, materials, draws, got.View()), counted) << SimdTargetName(t) << " trial " << trial;
      for (size_t e = 0; e < counted; ++e) {
        ASSERT_EQ(got.draw.data()[e], twin.draw.data()[e]) << SimdTargetName(t) << " trial " << trial;
        for (int f = 0; f < 10; ++f)
          ASSERT_EQ(Bits(got.fields[f]->data()[e]), Bits(twin.fields[f]->data()[e]))
              << SimdTargetName(t) << " trial " << trial << " entry " << e << " field " << f;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 50000u);
}

// ∫ f(wo, wi) cos θi dωi over the hemisphere by the midpoint rule in (cos θ, φ), in double from EvalBsdf's float
// values: the directional albedo the throughput estimates.
Vec3 DirectionalAlbedo(const Bsdf& bsdf, const Vec3& n, const Vec3& wo) {
  Vec3 t, b;
  OrthonormalBasis(n, t, b);
  constexpr int kTheta = 2048, kPhi = 512;
  glm::dvec3 sum(0.0);
  for (int i = 0; i < kTheta; ++i) {
    // cos θ = 1 - ((i + 1/2) / kTheta)²: denser near the normal, where a narrow lobe sits; dω = sin θ dθ dφ =
    // d(cos θ) dφ and d(cos θ) = 2 s ds.
    const double s = (i + 0.5) / kTheta;
    const double cosTheta = 1.0 - s * s, sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    const double dCos = 2.0 * s / kTheta;
    for (int j = 0; j < kPhi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / kPhi;
      const Vec3 wi = glm::normalize(Vec3(float(sinTheta * std::cos(phi))) * t +
                                     Vec3(float(sinTheta * std::sin(phi))) * b + Vec3(float(cosTheta)) * n);
      sum += glm::dvec3(EvalBsdf(bsdf, n, wo, wi)) * cosTheta * dCos * (2.0 * M_PI / kPhi);
    }
  }
  return Vec3(sum);
}

TEST_F(BsdfDrawKernel, ThroughputIsAnUnbiasedEstimateOfTheDirectionalAlbedo) {
  struct Case {
    const char* name;
    Bsdf bsdf;
    float cosO;  // the viewer's angle
  };
  const std::vector<Case> cases{
      {"diffuse", Bsdf{BsdfType::kDiffuse, Vec3(0.8f, 0.5f, 0.2f), 0.25f}, 0.7f},
      {"rough GGX", Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 0.5f}, 0.8f},
      {"GGX at a grazing view", Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 0.3f}, 0.15f},
      {"layered", Bsdf{BsdfType::kLayered, Vec3(0.3f, 0.2f, 0.1f), 0.3f, Vec3(0.04f), 0.5f}, 0.6f},
  };
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  constexpr size_t kDraws = 1 << 18;
  for (const Case& c : cases) {
    const BsdfSoa materials = MakeBsdfSoa({c.bsdf});
    LightDrawReceiver r;
    // A tilted receiver 300 m from the origin.
    r.position = Vec3(300.0f, -20.0f, 150.0f);
    r.geometricNormal = r.shadingNormal = glm::normalize(Vec3(0.3f, 1.0f, -0.2f));
    Vec3 t, b;
    OrthonormalBasis(r.shadingNormal, t, b);
    r.wo = glm::normalize(c.cosO * r.shadingNormal + std::sqrt(1.0f - c.cosO * c.cosO) * t);
    r.errorScale = 300.0f;
    std::vector<float> u0(kDraws), u1(kDraws);
    for (size_t k = 0; k < kDraws; ++k) u0[k] = uniform(rng), u1[k] = uniform(rng);
    Outputs o(kDraws);
    const size_t counted = DrawBsdfSamples(r, materials, BsdfDraws{u0.data(), u1.data(), kDraws}, o.View());
    const Vec3 albedo = DirectionalAlbedo(c.bsdf, r.shadingNormal, r.wo);
    for (int ch = 0; ch < 3; ++ch) {
      double sum = 0.0, sumSq = 0.0;
      for (size_t e = 0; e < counted; ++e) {  // the draws that do not count add 0
        const double w = o.fields[6 + ch]->data()[e];
        sum += w;
        sumSq += w * w;
      }
      const double mean = sum / kDraws;
      const double sd = std::sqrt(std::max(0.0, (sumSq - sum * mean) / (kDraws - 1)));
      // t-test per case and channel: |t| < 4.6, a false failure once in 2.4e5 per test, 5e-5 over the 12 here;
      // the quadrature's own error (under 1e-4 relative at this resolution) far below the test's resolution.
      const double tStat = (mean - albedo[ch]) / (sd / std::sqrt(double(kDraws)) + 1e-4 * albedo[ch]);
      EXPECT_LT(std::fabs(tStat), 4.6) << c.name << " channel " << ch << ": mean " << mean << " albedo " << albedo[ch];
    }
    // Rays leave on the direction's side: from the receiver, offset along the geometric normal towards wi.
    for (size_t e = 0; e < counted; e += 97) {
      const Vec3 org(o.fields[0]->data()[e], o.fields[1]->data()[e], o.fields[2]->data()[e]);
      const Vec3 dir(o.fields[3]->data()[e], o.fields[4]->data()[e], o.fields[5]->data()[e]);
      EXPECT_NEAR(glm::length(dir), 1.0f, 1e-5f);
      EXPECT_GT(glm::dot(dir, r.geometricNormal), 0.0f);
      EXPECT_GE(glm::dot(org - r.position, r.geometricNormal), 0.0f);
      EXPECT_LT(glm::length(org - r.position), 1e-2f);
    }
  }
}

// The sine and cosine the samplers share (core/sampling.h SinCos2Pi), against std::sin and std::cos in double:
// within 2e-7 over every float in [0, 1) the 24-bit uniforms take, every 97th of them.
TEST(SinCos2Pi, MatchesTheLibraryToFloatPrecision) {
  double worst = 0.0;
  for (uint32_t bits = 0; bits < (1u << 24); bits += 97) {
    const float u = BitsToUnitFloat(bits << 8);
    float s, c;
    SinCos2Pi(u, s, c);
    const double angle = 2.0 * M_PI * double(u);
    worst = std::max({worst, std::fabs(s - std::sin(angle)), std::fabs(c - std::cos(angle))});
  }
  EXPECT_LT(worst, 2e-7);
  RecordProperty("worst_absolute_error", std::to_string(worst));
}

}  // namespace bsdf_draw_kernel_test
}  // namespace restir
