// The light-draw kernel (core/light_draw_kernel.h): every SIMD target this machine supports reproduces the
// scalar twin bit for bit (DESIGN §3), NaN payloads canonicalised, on random receivers (diffuse, GGX,
// layered, a black and a poisoned material; tilted, grazing and far from the origin) and light sets (1 to 300
// triangles: tiny, huge, behind the receiver, switched off), cdfs with zero steps, plateaus and a huge
// dynamic range, uniforms at the cdf's own boundaries and at the edges of [0, 1), with and without the MIS
// weight against the BSDF's density (GGX from mirror to rough, layered with both pure ends), and batch sizes
// around every vector width (tails, read and written next to memory that faults). What the twin computes is checked
// against closed forms: its term is an unbiased estimate of Lambert's unshadowed reflected radiance
// (t-tests), its rays run from the receiver to the drawn point, and it lists exactly the draws that count.
#include "core/light_draw_kernel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/kernel_test_support.h"
#include "core/light.h"
#include "core/polygon_irradiance.h"
#include "core/sampling.h"
#include "core/shading.h"
#include "core/simd.h"

namespace restir {
namespace {

class LightDrawKernel : public test::SimdTargetTest {};

using test::Bits;
using test::GuardedArray;
using test::kInf;
using test::kNaN;
using test::RandomUnit;

std::vector<Bsdf> Materials() {
  return {Bsdf{BsdfType::kDiffuse, Vec3(0.8f, 0.5f, 0.2f), 0.25f},
          Bsdf{BsdfType::kDiffuse, Vec3(0.0f), 0.25f},
          Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 1e-4f},
          Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 0.3f},
          Bsdf{BsdfType::kGgx, Vec3(0.9f, 0.6f, 0.3f), 0.0f},
          Bsdf{BsdfType::kLayered, Vec3(0.3f, 0.2f, 0.1f), 0.2f, Vec3(0.04f), 0.5f},
          Bsdf{BsdfType::kLayered, Vec3(0.3f, 0.2f, 0.1f), 0.2f, Vec3(0.04f), 0.0f},
          Bsdf{BsdfType::kLayered, Vec3(0.0f), 0.05f, Vec3(1.0f, 0.8f, 0.5f), 1.0f},
          Bsdf{BsdfType::kDiffuse, Vec3(kInf, 0.5f, 0.5f), 0.25f}};
}

// Lights and their records, the cdf over them, as the reference hands them to the kernel.
struct LightSet {
  std::vector<LightTriangle> triangles;
  struct alignas(64) Record {
    float v[kLightDrawRecordFloats];
  };
  std::vector<Record> records;
  std::vector<float> errorScale;
  std::vector<float> cdf;
  LightDrawLights View() const {
    LightDrawLights l;
    l.records = records.data()->v;
    l.errorScale = errorScale.data();
    l.count = triangles.size();
    return l;
  }
};

LightSet RandomLights(std::mt19937& rng, const Vec3& x, const Vec3& n, size_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  LightSet s;
  while (s.triangles.size() < count) {
    // Mostly above the receiver, some behind it; sizes from a millimetre to tens of metres.
    const float size = std::pow(10.0f, -3.0f + 4.5f * u(rng));
    const float distance = std::pow(10.0f, -2.0f + 3.0f * u(rng));
    const Vec3 c = x + distance * glm::normalize((u(rng) < 0.8f ? n : -n) + 1.2f * RandomUnit(rng));
    const Vec3 a = RandomUnit(rng), b = RandomUnit(rng);
    Vec3 radiance(u(rng) * 30, u(rng) * 30, u(rng) * 30);
    if (u(rng) < 0.1f) radiance = Vec3(0.0f);  // switched off
    LightTriangle t;
    if (!MakeLightTriangle(c, c + size * a, c + size * b, radiance, t)) continue;
    if (glm::dot(t.normal, x - c) < 0 && u(rng) < 0.8f)
      MakeLightTriangle(c, c + size * b, c + size * a, radiance, t);
    s.triangles.push_back(t);
  }
  s.records.resize(count);
  double running = 0.0;
  std::vector<double> w(count);
  for (size_t l = 0; l < count; ++l) {
    WriteLightDrawRecord(s.triangles[l], s.records[l].v);
    s.errorScale.push_back(s.triangles[l].errorScale);
    // Zero steps, plateaus and weights over twelve decades.
    w[l] = u(rng) < 0.2f ? 0.0 : std::pow(10.0, -6.0 + 12.0 * u(rng));
  }
  if (w[count - 1] == 0.0 && count == 1) w[0] = 1.0;
  double total = 0.0;
  for (double v : w) total += v;
  if (total == 0.0) w[0] = total = 1.0;
  for (size_t l = 0; l < count; ++l) {
    running += w[l];
    s.cdf.push_back(static_cast<float>(running / total));
  }
  return s;
}

// The uniforms of `count` draws: random, plus the cdf's own boundaries (u total = cdf[l] exactly, and one
// float either side), 0 and the largest float below 1.
std::vector<float> Uniforms(std::mt19937& rng, const std::vector<float>& cdf, size_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v(count);
  for (float& x : v) {
    const int kind = static_cast<int>(rng() % 8);
    if (kind == 0) {
      x = 0.0f;
    } else if (kind == 1) {
      x = 0x1.fffffep-1f;
    } else if (kind == 2) {
      const float b = cdf[rng() % cdf.size()] / cdf.back();
      const int side = static_cast<int>(rng() % 3);
      x = side == 0 ? b : side == 1 ? std::nextafter(b, 0.0f) : std::nextafter(b, 1.0f);
      x = std::min(x, 0x1.fffffep-1f);
    } else {
      x = u(rng);
    }
  }
  return v;
}

struct Outputs {
  explicit Outputs(size_t n) : draw(n) {
    for (auto& f : fields) f = std::make_unique<GuardedArray<float>>(n);
  }
  std::unique_ptr<GuardedArray<float>> fields[10];
  GuardedArray<uint32_t> draw;
  LightDrawOutputs View() {
    LightDrawOutputs o;
    for (int c = 0; c < 3; ++c) {
      o.term[c] = fields[c]->data();
      o.org[c] = fields[3 + c]->data();
      o.dir[c] = fields[6 + c]->data();
    }
    o.tmax = fields[9]->data();
    o.draw = draw.data();
    return o;
  }
};

TEST_F(LightDrawKernel, EveryTargetMatchesScalarTwinBitForBit) {
  std::mt19937 rng(20261125);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::vector<Bsdf> bsdfs = Materials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  // Around the cdf search's window (8 entries) and its coarse strides (16 entries of 8 up to 128 lights, then
  // doubling), and past the reference's per-pixel limit of 4096.
  const std::vector<size_t> lightCounts{1, 2, 3, 5, 7, 8, 9, 16, 17, 72, 127, 128, 129, 300, 1000, 5000};
  const std::vector<size_t> drawCounts{0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 48, 64, 65, 100};
  size_t compared = 0, traced = 0;
  for (int trial = 0; trial < 320; ++trial) {
    LightDrawReceiver r;
    const float far = trial % 4 == 0 ? 1000.0f : 1.0f;  // far from the origin: large error scales
    r.position = far * Vec3(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    r.geometricNormal = trial % 5 == 0 ? Vec3(0, 1, 0) : RandomUnit(rng);
    r.shadingNormal =
        trial % 3 == 0 ? r.geometricNormal : glm::normalize(r.geometricNormal + 0.3f * RandomUnit(rng));
    // Mostly in front, sometimes grazing or below the surface.
    r.wo = glm::normalize(r.geometricNormal * (trial % 7 == 0   ? -0.2f
                                               : trial % 6 == 0 ? 0.001f
                                                                : 1.0f) +
                          0.8f * RandomUnit(rng));
    r.errorScale = far * 6.0f;
    r.materialId = static_cast<int32_t>(rng() % bsdfs.size());
    r.bsdfMis = trial % 3 != 0;  // the MIS weight against PdfBsdf, on every material
    const LightSet lights =
        RandomLights(rng, r.position, r.shadingNormal, lightCounts[trial % lightCounts.size()]);
    const size_t n = drawCounts[(trial / lightCounts.size() + trial) % drawCounts.size()];
    GuardedArray<float> u0(n), u1(n), u2(n);
    const std::vector<float> sel = Uniforms(rng, lights.cdf, n);
    for (size_t k = 0; k < n; ++k) {
      u0.data()[k] = sel[k];
      u1.data()[k] = k % 9 == 0 ? 0.0f : k % 9 == 1 ? 0x1.fffffep-1f : u(rng);
      u2.data()[k] = k % 11 == 0 ? 0.0f : u(rng);
    }
    LightDraws draws{u0.data(), u1.data(), u2.data(), n};
    Outputs twin(n);
    const size_t counted = DrawLightSamplesScalar(r, materials, lights.View(), lights.cdf.data(), draws, twin.View());
    traced += counted;
    for (size_t e = 1; e < counted; ++e) ASSERT_LT(twin.draw.data()[e - 1], twin.draw.data()[e]);  // in draw order
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      EXPECT_STREQ(LightDrawKernelDispatchedTargetName(), test::ExpectedDispatchName(t));
      Outputs got(n);
      ASSERT_EQ(DrawLightSamples(r, materials, lights.View(), lights.cdf.data(), draws, got.View()), counted)
          << SimdTargetName(t) << " trial " << trial;
      for (size_t e = 0; e < counted; ++e) {
        ASSERT_EQ(got.draw.data()[e], twin.draw.data()[e]) << SimdTargetName(t) << " trial " << trial << " entry " << e;
        for (int f = 0; f < 10; ++f)
          ASSERT_EQ(Bits(got.fields[f]->data()[e]), Bits(twin.fields[f]->data()[e]))
              << SimdTargetName(t) << " trial " << trial << " entry " << e << " field " << f;
        ++compared;
      }
    }
  }
  // The trials must reach both outcomes in quantity, or the comparison proves little.
  EXPECT_GT(traced, 1000u);
  EXPECT_GT(compared, 10000u);
}

// LightCentroidTargets: every target reproduces its twin bit for bit over the same receivers, materials and light
// sets as the draws (tails around every vector width), and the twin is TargetFunction(UnshadowedContribution) at
// each light's centroid, computed here from the triangles.
TEST_F(LightDrawKernel, CentroidTargetsMatchTheirTwinAndTheCoreFunctions) {
  std::mt19937 rng(20261126);
  const std::vector<Bsdf> bsdfs = Materials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  size_t compared = 0, positive = 0;
  for (int trial = 0; trial < 200; ++trial) {
    LightDrawReceiver r;
    const float far = trial % 4 == 0 ? 1000.0f : 1.0f;
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    r.position = far * Vec3(u(rng) * 10 - 5, u(rng) * 4 - 2, u(rng) * 10 - 5);
    r.geometricNormal = RandomUnit(rng);
    r.shadingNormal = trial % 3 == 0 ? r.geometricNormal : glm::normalize(r.geometricNormal + 0.3f * RandomUnit(rng));
    r.wo = glm::normalize(r.geometricNormal * (trial % 7 == 0 ? -0.2f : 1.0f) + 0.8f * RandomUnit(rng));
    r.errorScale = far * 6.0f;
    r.materialId = static_cast<int32_t>(rng() % bsdfs.size());
    const LightSet lights = RandomLights(rng, r.position, r.shadingNormal, 1 + rng() % 140);
    const size_t n = lights.triangles.size();
    GuardedArray<float> twin(n);
    LightCentroidTargetsScalar(r, materials, lights.View(), twin.data());
    ShadingPoint sp;
    sp.position = r.position;
    sp.geometricNormal = r.geometricNormal;
    sp.shadingNormal = r.shadingNormal;
    sp.wo = r.wo;
    sp.bsdf = bsdfs[static_cast<size_t>(r.materialId)];
    for (size_t l = 0; l < n; ++l) {
      const LightTriangle& t = lights.triangles[l];
      LightSample c;
      c.position = t.p0 + (t.e1 + t.e2) * (1.0f / 3.0f);
      c.normal = t.normal;
      c.radiance = t.radiance;
      const float expected = TargetFunction(UnshadowedContribution(sp, c));
      if (std::isnan(expected)) {
        EXPECT_TRUE(std::isnan(twin.data()[l]));
      } else {
        ASSERT_EQ(Bits(twin.data()[l]), Bits(expected)) << "trial " << trial << " light " << l;
      }
      positive += expected > 0.0f ? 1 : 0;
    }
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      GuardedArray<float> got(n);
      LightCentroidTargets(r, materials, lights.View(), got.data());
      for (size_t l = 0; l < n; ++l)
        ASSERT_EQ(Bits(got.data()[l]), Bits(twin.data()[l])) << SimdTargetName(t) << " trial " << trial << " light " << l;
      compared += n;
    }
  }
  EXPECT_GT(positive, 1000u);
  EXPECT_GT(compared, 10000u);
}

// A receiver under a quad light (two triangles) whose cdf does not follow the triangles' areas: E[term] =
// albedo / π · E, E by Lambert's polygon formula (core/polygon_irradiance.h) on the quad clipped to the
// receiver's hemisphere, where the contribution is zero: the pmf and area density must cancel whatever the
// cdf.
struct QuadCase {
  const char* name;
  Vec3 x, n;          // receiver
  Vec3 centre, u, v;  // the quad: centre ± u ± v
  float split;        // probability of the first triangle
};

TEST_F(LightDrawKernel, TermIsAnUnbiasedEstimateOfLambertsReflectedRadiance) {
  const Vec3 up(0, 1, 0);
  const Vec3 tilt = glm::normalize(Vec3(0.5f, 1.0f, -0.3f));
  const std::vector<QuadCase> cases{
      {"overhead", Vec3(0), up, Vec3(0, 2, 0), Vec3(0.5f, 0, 0), Vec3(0, 0, 0.5f), 0.5f},
      {"uneven cdf", Vec3(0), up, Vec3(0.3f, 1.5f, 0.2f), Vec3(0.8f, 0, 0), Vec3(0, 0, 0.2f), 0.9f},
      {"tilted receiver", Vec3(0), tilt, Vec3(0.5f, 2, 0), Vec3(0.5f, 0, 0), Vec3(0, 0, 0.5f), 0.3f},
      {"grazing light", Vec3(0), up, Vec3(3, 0.4f, 0), Vec3(0, 0.3f, 0), Vec3(0, 0, 0.3f), 0.5f},
      {"far from origin", Vec3(1000, 50, -1000), up, Vec3(1000, 52, -1000), Vec3(0.5f, 0, 0),
       Vec3(0, 0, 0.5f), 0.6f},
      {"tiny light", Vec3(0), up, Vec3(0, 0.05f, 0), Vec3(0.001f, 0, 0), Vec3(0, 0, 0.001f), 0.5f},
      {"huge light", Vec3(0), up, Vec3(0, 50, 0), Vec3(100, 0, 0), Vec3(0, 0, 100), 0.4f},
      {"close, large, crossing the horizon", Vec3(0), tilt, Vec3(0, 0.3f, 0), Vec3(2, 0, 0), Vec3(0, 0, 2),
       0.5f},
  };
  const Bsdf diffuse{BsdfType::kDiffuse, Vec3(0.7f, 0.5f, 0.3f), 0.25f};
  const BsdfSoa materials = MakeBsdfSoa({diffuse});
  const Vec3 radiance(4.0f, 2.0f, 1.0f);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  constexpr size_t kDraws = 1 << 18;
  for (const QuadCase& c : cases) {
    const Vec3 q[4] = {c.centre - c.u - c.v, c.centre + c.u - c.v, c.centre + c.u + c.v,
                       c.centre - c.u + c.v};
    LightSet lights;
    lights.triangles.resize(2);
    // Wound to face the receiver.
    const bool flip = glm::dot(glm::cross(q[1] - q[0], q[2] - q[0]), c.x - c.centre) < 0;
    ASSERT_TRUE(flip ? MakeLightTriangle(q[0], q[2], q[1], radiance, lights.triangles[0])
                     : MakeLightTriangle(q[0], q[1], q[2], radiance, lights.triangles[0]));
    ASSERT_TRUE(flip ? MakeLightTriangle(q[0], q[3], q[2], radiance, lights.triangles[1])
                     : MakeLightTriangle(q[0], q[2], q[3], radiance, lights.triangles[1]));
    lights.records.resize(2);
    for (int l = 0; l < 2; ++l) {
      WriteLightDrawRecord(lights.triangles[l], lights.records[l].v);
      lights.errorScale.push_back(lights.triangles[l].errorScale);
    }
    lights.cdf = {c.split, 1.0f};
    LightDrawReceiver r;
    r.position = c.x;
    r.geometricNormal = r.shadingNormal = c.n;
    r.wo = c.n;
    r.errorScale = std::max({std::fabs(c.x.x), std::fabs(c.x.y), std::fabs(c.x.z)});
    std::vector<float> u0(kDraws), u1(kDraws), u2(kDraws);
    for (size_t k = 0; k < kDraws; ++k) u0[k] = uniform(rng), u1[k] = uniform(rng), u2[k] = uniform(rng);
    Outputs o(kDraws);
    const size_t counted = DrawLightSamples(r, materials, lights.View(), lights.cdf.data(),
                                            LightDraws{u0.data(), u1.data(), u2.data(), kDraws}, o.View());
    Vec3 clipped[5];
    const size_t kept = ClipPolygonToHemisphere(c.x, c.n, q, 4, clipped);
    ASSERT_GE(kept, 3u) << c.name;
    const double e = PolygonIrradiance(c.x, c.n, std::vector<Vec3>(clipped, clipped + kept), 1.0);
    for (int ch = 0; ch < 3; ++ch) {
      double sum = 0.0, sumSq = 0.0;
      for (size_t e = 0; e < counted; ++e) {  // the draws that do not count add 0
        const double t = o.fields[ch]->data()[e];
        sum += t;
        sumSq += t * t;
      }
      const double mean = sum / kDraws;
      const double sd = std::sqrt(std::max(0.0, (sumSq - sum * mean) / (kDraws - 1)));
      const double exact = diffuse.albedo[ch] / M_PI * radiance[ch] * e;
      // t-test per case and channel: |t| < 4.6, a false failure once in 2.4e5 per test, 5e-5 over the 24
      // here.
      const double tStat = (mean - exact) / (sd / std::sqrt(double(kDraws)));
      EXPECT_LT(std::fabs(tStat), 4.6)
          << c.name << " channel " << ch << ": mean " << mean << " exact " << exact;
      EXPECT_GT(exact, 0.0) << c.name;
    }
  }
}

TEST_F(LightDrawKernel, RaysRunFromTheReceiverToTheDrawnPoint) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const BsdfSoa materials = MakeBsdfSoa({Bsdf{BsdfType::kDiffuse, Vec3(0.5f), 0.25f}});
  size_t checked = 0;
  for (int trial = 0; trial < 60; ++trial) {
    LightDrawReceiver r;
    const float scale = trial % 3 == 0 ? 1000.0f : 1.0f;
    r.position = scale * Vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f);
    r.geometricNormal = r.shadingNormal = RandomUnit(rng);
    r.wo = r.geometricNormal;
    r.errorScale = std::max({std::fabs(r.position.x), std::fabs(r.position.y), std::fabs(r.position.z)});
    const LightSet lights = RandomLights(rng, r.position, r.shadingNormal, 1 + trial % 20);
    const size_t n = 64;
    std::vector<float> u0(n), u1(n), u2(n);
    for (size_t k = 0; k < n; ++k) u0[k] = u(rng), u1[k] = u(rng), u2[k] = u(rng);
    Outputs o(n);
    const size_t counted = DrawLightSamples(r, materials, lights.View(), lights.cdf.data(),
                                            LightDraws{u0.data(), u1.data(), u2.data(), n}, o.View());
    for (size_t e = 0; e < counted; ++e) {
      const size_t k = o.draw.data()[e];
      ASSERT_LT(k, n);
      const Vec3 org(o.fields[3]->data()[e], o.fields[4]->data()[e], o.fields[5]->data()[e]);
      const Vec3 dir(o.fields[6]->data()[e], o.fields[7]->data()[e], o.fields[8]->data()[e]);
      const float tmax = o.fields[9]->data()[e];
      // The drawn point, recomputed from the uniforms: the light is the one SampleCdf picks.
      const LightTriangle& t = lights.triangles[SampleCdf(lights.cdf.data(), lights.cdf.size(), u0[k])];
      const Vec3 y = SampleTrianglePoint(t, u1[k], u2[k]);
      const float tolerance = 1e-4f * (1.0f + scale);
      EXPECT_NEAR(glm::length(dir), 1.0f, 1e-5f);
      EXPECT_LT(glm::length(org - r.position), tolerance);
      EXPECT_LT(glm::length(org + tmax * dir - y), tolerance + 1e-4f * glm::length(y - r.position));
      EXPECT_LE(tmax, glm::length(y - r.position) * (1.0f + 1e-5f) + tolerance);
      ++checked;
    }
    // The list holds exactly the draws that count: f nonzero and p positive, from the core functions.
    ShadingPoint sp;
    sp.position = r.position;
    sp.geometricNormal = sp.shadingNormal = r.geometricNormal;
    sp.wo = r.wo;
    sp.bsdf = materials.At(0);
    size_t e = 0;
    for (size_t k = 0; k < n; ++k) {
      const uint32_t id = SampleCdf(lights.cdf.data(), lights.cdf.size(), u0[k]);
      LightSample y;
      y.position = SampleTrianglePoint(lights.triangles[id], u1[k], u2[k]);
      y.normal = lights.triangles[id].normal;
      y.radiance = lights.triangles[id].radiance;
      const Vec3 f = UnshadowedContribution(sp, y);
      const bool counts = (f.x > 0 || f.y > 0 || f.z > 0) && CdfPmf(lights.cdf.data(), lights.cdf.size(), id) > 0;
      const bool listed = e < counted && o.draw.data()[e] == k;
      EXPECT_EQ(listed, counts) << "trial " << trial << " draw " << k;
      e += listed ? 1 : 0;
    }
    EXPECT_EQ(e, counted);
  }
  EXPECT_GT(checked, 500u);
}

}  // namespace
}  // namespace restir
