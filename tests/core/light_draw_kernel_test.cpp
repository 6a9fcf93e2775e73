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
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace light_draw_kernel_test {

class LightDrawKernel : public test::SimdTargetTest {};

using test::Bits;
using test::GuardedArray;
using test::kInf;
using test::kNaN;
using test::RandomUnit;

// Lights, their groups (core/light.h: quads cut in two are one) and records, the cdf over the groups, as the
// reference hands them to the kernel.
struct LightSet {
  std::vector<LightTriangle> triangles;
  LightGroups groups;
  struct alignas(64) Record {
    float v[kLightDrawRecordFloats];
  };
  std::vector<Record> records;
  std::vector<float> errorScale;
  std::vector<float> cdf;  // per group
  LightDrawLights View() const {
    LightDrawLights l;
    l.records = records.data()->v;
    l.errorScale = errorScale.data();
    l.count = triangles.size();
    l.groupFirst = groups.first.data();
    l.groupSplit = groups.split.data();
    l.groups = groups.first.size();
    return l;
  }
  // Records and the cdf from the triangles and the groups' weights (zero steps allowed, the last positive).
  void Finish(std::vector<double> w) {
    groups = MakeLightGroups(triangles);
    records.resize(triangles.size());
    for (size_t l = 0; l < triangles.size(); ++l) {
      WriteLightDrawRecord(triangles[l], groups.invArea[l], records[l].v);
      errorScale.push_back(triangles[l].errorScale);
    }
    w.resize(groups.first.size(), 0.0);
    double total = 0.0;
    for (double v : w) total += v;
    if (total == 0.0) w[0] = total = 1.0;
    double running = 0.0;
    for (double v : w) cdf.push_back(static_cast<float>((running += v) / total));
  }
};

// `count` emitters (a quad, two triangles of one group, in one of four), mostly facing the receiver.
LightSet RandomLights(std::mt19937& rng, const Vec3& x, const Vec3& n, size_t count) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  LightSet s;
  std::vector<double> w;
  while (w.size() < count) {
    // Mostly above the receiver, some behind it; sizes from a millimetre to tens of metres.
    const float size = std::pow(10.0f, -3.0f + 4.5f * u(rng));
    const float distance = std::pow(10.0f, -2.0f + 3.0f * u(rng));
    const Vec3 c = x + distance * glm::normalize((u(rng) < 0.8f ? n : -n) + 1.2f * RandomUnit(rng));
    Vec3 a = size * RandomUnit(rng), b = size * RandomUnit(rng);
    if (glm::dot(glm::cross(a, b), x - c) < 0 && u(rng) < 0.8f) std::swap(a, b);
    Vec3 radiance(u(rng) * 30, u(rng) * 30, u(rng) * 30);
    if (u(rng) < 0.1f) radiance = Vec3(0.0f);  // switched off
    LightTriangle t0, t1;
    if (u(rng) < 0.25f) {
      const Vec3 q[4] = {c - a - b, c + a - b, c + a + b, c - a + b};
      if (!MakeLightTriangle(q[0], q[1], q[2], radiance, t0) || !MakeLightTriangle(q[0], q[2], q[3], radiance, t1))
        continue;
      s.triangles.push_back(t0);
      s.triangles.push_back(t1);
    } else {
      if (!MakeLightTriangle(c, c + a, c + b, radiance, t0)) continue;
      s.triangles.push_back(t0);
    }
    // Zero steps, plateaus and weights over twelve decades.
    w.push_back(u(rng) < 0.2f ? 0.0 : std::pow(10.0, -6.0 + 12.0 * u(rng)));
  }
  s.Finish(w);
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
    } else if (kind == 2 || kind == 3) {
      // A group's boundary, or (kind 3) the boundary between a quad's triangles: its step times a split.
      const size_t g = rng() % cdf.size();
      const float before = g ? cdf[g - 1] : 0.0f;
      const float b = kind == 2 ? cdf[g] / cdf.back() : (before + 0.5f * (cdf[g] - before)) / cdf.back();
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
  const std::vector<Bsdf> bsdfs = test::KernelMaterials();
  const BsdfSoa materials = MakeBsdfSoa(bsdfs);
  // Around the cdf search's window (8 entries) and its coarse strides (16 entries of 8 up to 128 lights, then
  // doubling), past 4096 (many_rooms has 5280 light triangles, 2640 groups) and at the reference's per-pixel limit
  // of 32768.
  const std::vector<size_t> lightCounts{1, 2, 3, 5, 7, 8, 9, 16, 17, 72, 127, 128, 129, 300, 1000, 5000, 32768};
  const std::vector<size_t> drawCounts{0, 1, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 48, 64, 65, 100};
  size_t compared = 0, traced = 0;
  for (int trial = 0; trial < 360; ++trial) {
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
      for (size_t k = 0; k < n; ++k)  // every draw's term
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(Bits(got.fields[c]->data()[k]), Bits(twin.fields[c]->data()[k]))
              << SimdTargetName(t) << " trial " << trial << " draw " << k << " channel " << c;
      for (size_t e = 0; e < counted; ++e) {  // the rays of those that count
        ASSERT_EQ(got.draw.data()[e], twin.draw.data()[e]) << SimdTargetName(t) << " trial " << trial << " entry " << e;
        for (int f = 3; f < 10; ++f)
          ASSERT_EQ(Bits(got.fields[f]->data()[e]), Bits(twin.fields[f]->data()[e]))
              << SimdTargetName(t) << " trial " << trial << " entry " << e << " field " << f;
        ++compared;
      }
    }
  }
  // The trials must reach both outcomes in quantity, or the comparison proves little: every target compares every
  // traced draw (how many targets depends on the machine: three without AVX-512).
  EXPECT_GT(traced, 2500u);
  EXPECT_EQ(compared, traced * SupportedSimdTargets().size());
}

// A receiver under a quad light (two triangles, one group split by area) that the cdf selects with probability
// `split`, beside a triangle facing away that takes the rest: E[term] = albedo / π · E, E by Lambert's polygon
// formula (core/polygon_irradiance.h) on the quad clipped to the receiver's hemisphere, where the contribution is
// zero: the pmf and area density must cancel whatever the cdf; and likewise with the quad's triangles given
// different radiances, so that each is a group of its own and the cdf does not follow their areas.
struct QuadCase {
  const char* name;
  Vec3 x, n;          // receiver
  Vec3 centre, u, v;  // the quad: centre ± u ± v, its far edge (+v) scaled by `taper`
  float split;        // probability of the quad (or of its first triangle)
  float taper = 1.0f;  // below 1, a trapezoid: its two triangles' areas differ, and so does the split by area
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
      {"trapezoid", Vec3(0), up, Vec3(0.2f, 1.2f, 0), Vec3(0.6f, 0, 0), Vec3(0, 0, 0.4f), 0.5f, 0.15f},
      {"tilted trapezoid, crossing the horizon", Vec3(0), tilt, Vec3(0.5f, 0.4f, 0), Vec3(1.5f, 0, 0.2f),
       Vec3(0, 0.3f, 1.2f), 0.7f, 0.3f},
  };
  const Bsdf diffuse{BsdfType::kDiffuse, Vec3(0.7f, 0.5f, 0.3f), 0.25f};
  const BsdfSoa materials = MakeBsdfSoa({diffuse});
  const Vec3 radiance(4.0f, 2.0f, 1.0f);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  constexpr size_t kDraws = 1 << 18;
  for (const bool grouped : {true, false})
  for (const QuadCase& c : cases) {
    const Vec3 q[4] = {c.centre - c.u - c.v, c.centre + c.u - c.v, c.centre + c.taper * c.u + c.v,
                       c.centre - c.taper * c.u + c.v};
    LightSet lights;
    lights.triangles.resize(grouped ? 3 : 2);
    // Wound to face the receiver; ungrouped, the second triangle a hair brighter (not one quad's any more).
    const Vec3 second = grouped ? radiance : radiance * 1.0001f;
    // Cut as quad lights are, A B C and A C D, with the corners taken the other way round where that faces it.
    const bool flip = glm::dot(glm::cross(q[1] - q[0], q[2] - q[0]), c.x - c.centre) < 0;
    ASSERT_TRUE(flip ? MakeLightTriangle(q[0], q[3], q[2], radiance, lights.triangles[0])
                     : MakeLightTriangle(q[0], q[1], q[2], radiance, lights.triangles[0]));
    ASSERT_TRUE(flip ? MakeLightTriangle(q[0], q[2], q[1], second, lights.triangles[1])
                     : MakeLightTriangle(q[0], q[2], q[3], second, lights.triangles[1]));
    if (grouped) {  // behind the receiver, facing away
      ASSERT_TRUE(MakeLightTriangle(c.x - c.n, c.x - c.n + c.u, c.x - c.n + c.v, radiance, lights.triangles[2]));
    }
    lights.Finish({c.split, 1.0 - c.split});
    ASSERT_EQ(lights.groups.first.size(), 2u) << c.name;
    // A trapezoid's halves differ: a split taken the wrong way round would bias it.
    if (grouped && c.taper != 1.0f) { EXPECT_GT(std::fabs(lights.groups.split[0] - 0.5f), 0.1f) << c.name; }
    LightDrawReceiver r;
    r.position = c.x;
    r.geometricNormal = r.shadingNormal = c.n;
    r.wo = c.n;
    r.errorScale = std::max({std::fabs(c.x.x), std::fabs(c.x.y), std::fabs(c.x.z)});
    std::vector<float> u0(kDraws), u1(kDraws), u2(kDraws);
    for (size_t k = 0; k < kDraws; ++k) u0[k] = uniform(rng), u1[k] = uniform(rng), u2[k] = uniform(rng);
    Outputs o(kDraws);
    DrawLightSamples(r, materials, lights.View(), lights.cdf.data(),
                     LightDraws{u0.data(), u1.data(), u2.data(), kDraws}, o.View());
    // Each triangle's irradiance by Lambert's formula on its clipped polygon (the two together are the quad's).
    double e[2];
    for (int l = 0; l < 2; ++l) {
      const LightTriangle& t = lights.triangles[l];
      const Vec3 tri[3] = {t.p0, t.p0 + t.e1, t.p0 + t.e2};
      Vec3 clipped[4];
      const size_t kept = ClipPolygonToHemisphere(c.x, c.n, tri, 3, clipped);
      e[l] = kept >= 3 ? PolygonIrradiance(c.x, c.n, std::vector<Vec3>(clipped, clipped + kept), 1.0) : 0.0;
    }
    ASSERT_GT(e[0] + e[1], 0.0) << c.name;
    for (int ch = 0; ch < 3; ++ch) {
      double sum = 0.0, sumSq = 0.0;
      for (size_t k = 0; k < kDraws; ++k) {  // the draws that do not count have a term of 0
        const double t = o.fields[ch]->data()[k];
        sum += t;
        sumSq += t * t;
      }
      const double mean = sum / kDraws;
      const double sd = std::sqrt(std::max(0.0, (sumSq - sum * mean) / (kDraws - 1)));
      const double exact = diffuse.albedo[ch] / M_PI * (radiance[ch] * e[0] + second[ch] * e[1]);
      // t-test per case, grouping and channel: |t| < 4.8, a false failure once in 6.3e5 per test, 9.5e-5 over
      // the 60 here.
      const double tStat = (mean - exact) / (sd / std::sqrt(double(kDraws)));
      EXPECT_LT(std::fabs(tStat), 4.8)
          << c.name << (grouped ? " grouped" : " ungrouped") << " channel " << ch << ": mean " << mean << " exact "
          << exact;
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
      // The drawn point, recomputed from the uniforms: the light is the one SampleSplitCdf picks.
      const LightTriangle& t = lights.triangles[SampleSplitCdf(lights.cdf.data(), lights.cdf.size(),
                                                               lights.groups.first.data(), lights.groups.split.data(),
                                                               u0[k])];
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
      const uint32_t id = SampleSplitCdf(lights.cdf.data(), lights.cdf.size(), lights.groups.first.data(),
                                         lights.groups.split.data(), u0[k]);
      LightSample y;
      y.position = SampleTrianglePoint(lights.triangles[id], u1[k], u2[k]);
      y.normal = lights.triangles[id].normal;
      y.radiance = lights.triangles[id].radiance;
      const Vec3 f = ContributionAlong(sp, y.radiance,
                                       ConnectToLightOnPlane(sp, y.position, y.normal, lights.triangles[id].p0));
      const bool counts = (f.x > 0 || f.y > 0 || f.z > 0) &&
                          CdfPmf(lights.cdf.data(), lights.cdf.size(), lights.groups.groupOf[id]) > 0;
      const bool listed = e < counted && o.draw.data()[e] == k;
      EXPECT_EQ(listed, counts) << "trial " << trial << " draw " << k;
      e += listed ? 1 : 0;
    }
    EXPECT_EQ(e, counted);
  }
  EXPECT_GT(checked, 500u);
}

// Issue 40: far from the origin a sampled light point rounds up to half a float spacing off its triangle's plane,
// and the emitter's cosine taken from that point put receivers just behind the plane in front of it (a floor 27 µm
// behind a 1 cm emitter at 1000 m got light). The kernel takes the cosine from the plane through the exact vertex
// (core/shading.h ConnectToLightOnPlane). A 1 cm triangle tilted off every axis, at 0, 1 km and 10 km from the
// origin (near it, 0.1 mm stands for the spacing); receivers 5 cm beside it at signed distances from its plane of a
// fraction to a few float spacings of the coordinates there (measured in double from the receiver's float position
// and the float vertices), on every target and the twin: a receiver behind the plane gets exactly nothing and no
// ray; one in front gets, draw by draw, the integrand at the same barycentric point computed in double, to 1e-3
// plus what the point's own rounding moves (4 spacings / d), where the cosine from the rounded point erred by up to
// half a spacing over h: 17% and more at h <= 3 spacings.
TEST_F(LightDrawKernel, ReceiversBesideAFarEmittersPlaneGetLightOnlyInFrontOfIt) {
  using D3 = glm::dvec3;
  const BsdfSoa materials = MakeBsdfSoa({Bsdf{BsdfType::kDiffuse, Vec3(0.5f), 0.25f}});
  const D3 axis = glm::normalize(D3(1.0, 0.6, -0.8));
  const D3 a = 0.01 * glm::normalize(D3(0.3, -0.7, 0.2)), b0 = 0.01 * glm::normalize(D3(-0.5, 0.1, 0.9));
  std::mt19937 rng(4002);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  constexpr size_t kDraws = 64;
  std::vector<float> u0(kDraws), u1(kDraws), u2(kDraws);
  for (size_t k = 0; k < kDraws; ++k) u0[k] = u(rng), u1[k] = u(rng), u2[k] = u(rng);
  int behind = 0, inFront = 0;
  for (double distance : {0.0, 1000.0, 10000.0}) {
    LightSet lights;
    const Vec3 p0(axis * distance);
    LightTriangle t;
    ASSERT_TRUE(MakeLightTriangle(p0, Vec3(D3(p0) + a), Vec3(D3(p0) + b0), Vec3(10.0f), t));
    lights.triangles.push_back(t);
    lights.Finish({1.0});
    // The plane in double through the float vertices, and the float spacing of the coordinates there.
    const D3 v0(t.p0), e1(t.e1), e2(t.e2);
    const D3 n = glm::normalize(glm::cross(e1, e2));
    const D3 beside = glm::normalize(glm::cross(n, D3(0.2, 0.9, 0.4)));
    const double rounding = std::ldexp(1.0, std::ilogb(distance + 0.06) - 23);  // float spacing there
    const double spacing = distance > 0.0 ? rounding : 1e-4;
    for (double m : {-3.0, -1.5, -0.7, -0.3, 0.3, 0.7, 1.5, 3.0}) {
      LightDrawReceiver r;
      r.position = Vec3(v0 + 0.4 * e1 + 0.3 * e2 + 0.05 * beside + m * spacing * n);
      const double h = glm::dot(n, D3(r.position) - v0);  // the receiver's true signed distance
      if (h == 0.0) continue;
      r.geometricNormal = r.shadingNormal = Vec3(glm::normalize(-beside + 0.3 * glm::sign(h) * n));
      r.wo = r.geometricNormal;
      r.errorScale = static_cast<float>(distance + 1.0);
      (h < 0.0 ? behind : inFront) += 1;
      std::vector<SimdTarget> targets = SupportedSimdTargets();
      for (size_t pass = 0; pass <= targets.size(); ++pass) {
        const bool twin = pass == targets.size();
        if (!twin) { ASSERT_TRUE(SetSimdTarget(targets[pass])); }
        const char* name = twin ? "twin" : SimdTargetName(targets[pass]);
        Outputs o(kDraws);
        const LightDraws draws{u0.data(), u1.data(), u2.data(), kDraws};
        const size_t counted =
            twin ? DrawLightSamplesScalar(r, materials, lights.View(), lights.cdf.data(), draws, o.View())
                 : DrawLightSamples(r, materials, lights.View(), lights.cdf.data(), draws, o.View());
        if (h < 0.0) { EXPECT_EQ(counted, 0u) << name << " at " << distance << " m, " << h << " m behind"; }
        for (size_t k = 0; k < kDraws; ++k) {
          // The integrand over its density in double at the draw's barycentric point.
          const double su = std::sqrt(double(u1[k]));
          const D3 y = v0 + (1.0 - su) * e1 + double(u2[k]) * su * e2;
          const D3 d = y - D3(r.position);
          const double d2 = glm::dot(d, d), cosY = glm::dot(n, D3(r.position) - y) / std::sqrt(d2);
          const double cosX = glm::dot(D3(r.shadingNormal), d) / std::sqrt(d2);
          const double area = 0.5 * glm::length(glm::cross(e1, e2));
          const double want =
              cosY > 0.0 && cosX > 0.0 ? 10.0 * (0.5 / M_PI) * cosX * cosY / d2 * area : 0.0;
          const double got = o.fields[0]->data()[k];
          if (h < 0.0) {
            EXPECT_EQ(got, 0.0) << name << " at " << distance << " m, " << h << " m behind, draw " << k;
          } else {
            // The drawn point itself is rounded by up to half a spacing in every direction: that moves d and cos θx
            // by up to ~spacing / d (6e-4 at 1 km, 1e-2 at 10 km), and the cosine of the old code by ~spacing / h.
            EXPECT_NEAR(got, want, (1e-3 + 4.0 * rounding / std::sqrt(d2)) * want) << name << " at " << distance << " m, " << h << " m in front, draw " << k;
          }
        }
      }
      SetSimdTarget(SimdTarget::kAuto);
    }
  }
  EXPECT_GE(behind, 10);
  EXPECT_GE(inFront, 10);
}

}  // namespace light_draw_kernel_test
}  // namespace restir
