// Independent tests of core/sky.h (issue 18), written from the header's comments (the specification) and from
// mathematics computed here in double, never from core/sky.cpp. The lat-long layout, the texel solid angles,
// the texel probabilities, the cone of the sun and the rotation R(ρ) about +Y are all recomputed below.
//
// Monte Carlo tests are statistical (DESIGN §11): a fixed seed (RngKey with RngPass::kTest), Pearson χ²
// against an exact χ² quantile (regularised incomplete gamma, below), and a stated false-failure rate per
// test, split by Bonferroni over the test's family of χ² assertions. Each χ² figure is printed as "[chi2]
// ..." with its bound.
#include "core/sky.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/bsdf.h"
#include "core/rng.h"
#include "core/shading.h"
#include "stats.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace sky_test {

constexpr double kPiD = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------------------------
// Exact χ² quantiles: Q(k/2, x/2), the regularised upper incomplete gamma (series below a + 1, Lentz's
// continued fraction above; Numerical Recipes §6.2), inverted by bisection.
double UpperIncompleteGammaQ(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double lnFront = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, del = 1.0 / a, sum = del;
    for (int n = 0; n < 10000000; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::fabs(del) < std::fabs(sum) * 1e-16) break;
    }
    return 1.0 - sum * std::exp(lnFront);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 10000000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-16) break;
  }
  return std::exp(lnFront) * h;
}

// The x with P(χ²_k > x) = tail.
double ChiSquareCriticalExact(int k, double tail) {
  double lo = 0.0, hi = k + 60.0 * std::sqrt(2.0 * k + 1.0) + 200.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (UpperIncompleteGammaQ(0.5 * k, 0.5 * mid) > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Pearson χ² (stats.h pooling of bins expected below 5) against the exact bound at `tail`; prints the figure.
void ExpectChiSquare(const std::string& what, const std::vector<double>& observed,
                     const std::vector<double>& expected, double tail) {
  const test::ChiSquareResult r = test::ChiSquare(observed, expected);
  ASSERT_GE(r.dof, 1) << what;
  const double bound = ChiSquareCriticalExact(r.dof, tail);
  std::printf("[chi2] %-62s %12.2f  dof %6d  bound %10.2f (tail %.1e)\n", what.c_str(), r.statistic, r.dof,
              bound, tail);
  EXPECT_LT(r.statistic, bound) << what << " dof " << r.dof;
}

// ---------------------------------------------------------------------------------------------------------------
// The lat-long layout of the header, recomputed: column c spans longitudes [π - 2π(c+1)/W, π - 2πc/W], row r
// spans latitudes [π/2 - π(r+1)/H, π/2 - πr/H]; longitude = atan2(x, z), latitude = asin(y) (here atan2(y,
// |xz|)).
double LongitudeHigh(int c, int w) {
  return kPiD - 2.0 * kPiD * c / w;
}
double LongitudeLow(int c, int w) {
  return kPiD - 2.0 * kPiD * (c + 1) / w;
}
double LatitudeTop(int r, int h) {
  return 0.5 * kPiD - kPiD * r / h;
}
double LatitudeBottom(int r, int h) {
  return 0.5 * kPiD - kPiD * (r + 1) / h;
}
// sin λ_top - sin λ_bottom as 2 cos(mid) sin(half): no cancellation at the poles.
double SinLatitudeSpan(int r, int h) {
  const double t = LatitudeTop(r, h), b = LatitudeBottom(r, h);
  return 2.0 * std::cos(0.5 * (t + b)) * std::sin(0.5 * (t - b));
}
double MyTexelSolidAngle(int w, int h, int r) {
  return 2.0 * kPiD / w * SinLatitudeSpan(r, h);
}

struct DVec3 {
  double x, y, z;
};
DVec3 D(const Vec3& v) {
  return {v.x, v.y, v.z};
}
Vec3 F(const DVec3& v) {
  return Vec3(static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z));
}
double Dot(const DVec3& a, const DVec3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
double Length(const DVec3& a) {
  return std::sqrt(Dot(a, a));
}
DVec3 Normalize(const DVec3& a) {
  const double l = Length(a);
  return {a.x / l, a.y / l, a.z / l};
}
DVec3 Cross(const DVec3& a, const DVec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
DVec3 Sub(const DVec3& a, const DVec3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}

DVec3 DirectionFromLongLat(double phi, double lambda) {
  return {std::cos(lambda) * std::sin(phi), std::sin(lambda), std::cos(lambda) * std::cos(phi)};
}
// Direction from longitude and sin latitude.
DVec3 DirectionFromLongSin(double phi, double s) {
  const double c = std::sqrt(std::max(0.0, 1.0 - s * s));
  return {c * std::sin(phi), s, c * std::cos(phi)};
}

// Where a direction falls in the layout: continuous texel coordinates u in [0, W], v in [0, H].
struct MapCoords {
  double u, v;
  int column, row;
};
MapCoords MyMapCoords(const DVec3& dir, int w, int h) {
  const double phi = std::atan2(dir.x, dir.z);
  const double lambda = std::atan2(dir.y, std::hypot(dir.x, dir.z));
  MapCoords m;
  m.u = (kPiD - phi) / (2.0 * kPiD) * w;
  m.v = (0.5 * kPiD - lambda) / kPiD * h;
  m.column = std::clamp(static_cast<int>(std::floor(m.u)), 0, w - 1);
  m.row = std::clamp(static_cast<int>(std::floor(m.v)), 0, h - 1);
  return m;
}
// Distance, in texels, from the nearest texel edge (small: the texel is ambiguous to rounding).
double EdgeDistance(const MapCoords& m) {
  const double fu = m.u - std::floor(m.u), fv = m.v - std::floor(m.v);
  return std::min(std::min(fu, 1.0 - fu), std::min(fv, 1.0 - fv));
}

double LuminanceD(const Vec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// P(texel) = luminance × solid angle / Σ, in double, and Σ itself.
struct Expected {
  std::vector<double> probability;  // per texel, row-major
  double sum = 0.0;                 // Σ luminance × Ω = ∫ Y(L) dω
};
Expected MyTexelProbabilities(const EnvironmentMap& map) {
  Expected e;
  e.probability.resize(map.texels.size());
  for (int r = 0; r < map.height; ++r)
    for (int c = 0; c < map.width; ++c) {
      const size_t i = static_cast<size_t>(r) * map.width + c;
      e.probability[i] = LuminanceD(map.texels[i]) * MyTexelSolidAngle(map.width, map.height, r);
      e.sum += e.probability[i];
    }
  for (double& p : e.probability) p /= e.sum;
  return e;
}

// ---------------------------------------------------------------------------------------------------------------
// The maps of the grid.
Vec3 RandomColour(uint32_t seed, uint32_t i, float decades) {
  const RngKey key{seed, 0, i, static_cast<uint32_t>(RngPass::kTest)};
  const float scale = std::pow(10.0f, decades * UniformFloat(key, 3));
  return scale *
         Vec3(0.05f + UniformFloat(key, 0), 0.05f + UniformFloat(key, 1), 0.05f + UniformFloat(key, 2));
}

EnvironmentMap RandomMap(int w, int h, uint32_t seed, float decades) {
  EnvironmentMap m;
  m.width = w;
  m.height = h;
  m.texels.resize(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < m.texels.size(); ++i)
    m.texels[i] = RandomColour(seed, static_cast<uint32_t>(i), decades);
  return m;
}

// 512×256: a dim background and one texel at the +Y pole and the seam (row 0, the last column) bright enough
// to take about half the probability: Ω there is 9.2e-7 sr against 4π for the background.
constexpr int kBrightColumn = 511;
constexpr int kBrightRow = 0;
EnvironmentMap BrightTexelMap() {
  EnvironmentMap m = RandomMap(512, 256, 31, 0.0f);
  for (Vec3& t : m.texels) t *= 0.01f;
  m.texels[static_cast<size_t>(kBrightRow) * 512 + kBrightColumn] = Vec3(1.2e5f, 1.4e5f, 1.0e5f);
  return m;
}

// 16×8 with black rows (both poles and one in between) and a few single black texels.
EnvironmentMap ZeroRowsMap() {
  EnvironmentMap m = RandomMap(16, 8, 41, 1.0f);
  for (int r : {0, 3, 7})
    for (int c = 0; c < 16; ++c) m.texels[static_cast<size_t>(r) * 16 + c] = Vec3(0.0f);
  for (int i : {1 * 16 + 0, 1 * 16 + 15, 4 * 16 + 7, 5 * 16 + 8})
    m.texels[static_cast<size_t>(i)] = Vec3(0.0f);
  return m;
}

struct NamedMap {
  std::string name;
  EnvironmentMap map;
};
std::vector<NamedMap> MapGrid() {
  std::vector<NamedMap> g;
  g.push_back({"1x1 constant", RandomMap(1, 1, 11, 0.0f)});
  g.push_back({"2x1", RandomMap(2, 1, 12, 1.0f)});
  g.push_back({"7x3 random", RandomMap(7, 3, 13, 2.0f)});
  g.push_back({"3x40 random", RandomMap(3, 40, 14, 2.0f)});
  g.push_back({"64x32 random (3 decades)", RandomMap(64, 32, 15, 3.0f)});
  g.push_back({"512x256 bright pole texel", BrightTexelMap()});
  g.push_back({"16x8 zero rows", ZeroRowsMap()});
  return g;
}

RngKey Key(uint32_t seed, uint32_t i) {
  return RngKey{seed, 0, i, static_cast<uint32_t>(RngPass::kTest)};
}

// ---------------------------------------------------------------------------------------------------------------
// Layout and solid angles.

TEST(EnvironmentTexelSolidAngle, MatchesOwnFormulaAndSumsToFourPi) {
  for (auto [w, h] :
       std::vector<std::pair<int, int>>{{1, 1}, {2, 1}, {7, 3}, {3, 40}, {64, 32}, {512, 256}}) {
    EnvironmentMap m;
    m.width = w;
    m.height = h;
    m.texels.assign(static_cast<size_t>(w) * h, Vec3(1.0f));
    double total = 0.0;
    for (int r = 0; r < h; ++r) {
      const double mine = MyTexelSolidAngle(w, h, r);
      EXPECT_NEAR(EnvironmentTexelSolidAngle(m, r), mine, 1e-12 * mine) << w << "x" << h << " row " << r;
      total += w * EnvironmentTexelSolidAngle(m, r);
    }
    EXPECT_NEAR(total, 4.0 * kPiD, 1e-12) << w << "x" << h;
  }
}

// Every texel centre (in longitude and latitude) falls in its own texel, and Radiance returns that texel.
TEST(EnvironmentSampler, RadianceAtTexelCentresIsThatTexel) {
  for (const NamedMap& nm : MapGrid()) {
    const EnvironmentMap& m = nm.map;
    const EnvironmentSampler s(m);
    for (int r = 0; r < m.height; ++r)
      for (int c = 0; c < m.width; ++c) {
        const double phi = 0.5 * (LongitudeHigh(c, m.width) + LongitudeLow(c, m.width));
        const double lambda = 0.5 * (LatitudeTop(r, m.height) + LatitudeBottom(r, m.height));
        const Vec3 d = F(DirectionFromLongLat(phi, lambda));
        int col = -1, row = -1;
        EnvironmentTexelOf(m, d, col, row);
        ASSERT_EQ(col, c) << nm.name << " row " << r;
        ASSERT_EQ(row, r) << nm.name << " column " << c;
        const Vec3 t = m.texels[static_cast<size_t>(r) * m.width + c];
        const Vec3 L = s.Radiance(d);
        ASSERT_EQ(L.x, t.x) << nm.name << " texel " << c << "," << r;
        ASSERT_EQ(L.y, t.y);
        ASSERT_EQ(L.z, t.z);
      }
  }
}

// The named directions of the layout on a 7×5 map, where each lies inside a texel: +Y row 0 (longitude
// atan2(0, 0) = 0, column W/2), -Y the last row, +Z (longitude 0) column W/2 = 3 on the equator row H/2 = 2,
// +X (longitude +π/2) column W/4 = 1, -X (longitude -π/2) column 5, and the seam at -Z: longitude +π (x = +0)
// is column 0, -π (x = -0) the last column; just either side of it, column 0 for x > 0 and the last for x <
// 0.
TEST(EnvironmentSampler, RadianceOfNamedDirectionsPolesAndSeam) {
  const EnvironmentMap m = RandomMap(7, 5, 51, 1.0f);
  const EnvironmentSampler s(m);
  struct Case {
    const char* name;
    Vec3 d;
    int column, row;
  };
  const float e = 1e-4f;
  const std::vector<Case> cases{
      {"+Y", Vec3(0, 1, 0), 3, 0},
      {"-Y", Vec3(0, -1, 0), 3, 4},
      {"+Z", Vec3(0, 0, 1), 3, 2},
      {"+X", Vec3(1, 0, 0), 1, 2},
      {"-X", Vec3(-1, 0, 0), 5, 2},
      {"-Z (x=+0, longitude +pi)", Vec3(0.0f, 0.0f, -1.0f), 0, 2},
      {"-Z (x=-0, longitude -pi)", Vec3(-0.0f, 0.0f, -1.0f), 6, 2},
      {"-Z then x>0", glm::normalize(Vec3(e, 0.0f, -1.0f)), 0, 2},
      {"-Z then x<0", glm::normalize(Vec3(-e, 0.0f, -1.0f)), 6, 2},
      {"near +Y, x>0 z<0 (seam, top row)", glm::normalize(Vec3(1e-5f, 1.0f, -1e-2f)), 0, 0},
      {"near +Y, x<0 z<0 (seam, top row)", glm::normalize(Vec3(-1e-5f, 1.0f, -1e-2f)), 6, 0},
      {"near -Y, +X", glm::normalize(Vec3(e, -1.0f, 0.0f)), 1, 4},
      {"near +Y, -X", glm::normalize(Vec3(-e, 1.0f, 0.0f)), 5, 0},
  };
  for (const Case& k : cases) {
    int col = -1, row = -1;
    EnvironmentTexelOf(m, k.d, col, row);
    EXPECT_EQ(col, k.column) << k.name;
    EXPECT_EQ(row, k.row) << k.name;
    const Vec3 t = m.texels[static_cast<size_t>(k.row) * m.width + k.column];
    const Vec3 L = s.Radiance(k.d);
    EXPECT_TRUE(L == t) << k.name << ": got (" << L.x << "," << L.y << "," << L.z << ") want (" << t.x << ","
                        << t.y << "," << t.z << ")";
  }
}

// The brief's named columns on an even 8×4 map, where +Z (longitude 0, u = 4) and +X (longitude π/2, u = 2)
// lie exactly on column edges: the floor of the layout coordinate gives W/2 and W/4. (Edge ownership is not
// stated by the header; this pins the floor convention that the clamped "texel a direction falls in"
// suggests.)
TEST(EnvironmentSampler, NamedDirectionsOnEvenMapEdgesTakeTheFloor) {
  const EnvironmentMap m = RandomMap(8, 4, 52, 1.0f);
  int col = -1, row = -1;
  EnvironmentTexelOf(m, Vec3(0, 0, 1), col, row);
  EXPECT_EQ(col, 4);
  EnvironmentTexelOf(m, Vec3(1, 0, 0), col, row);
  EXPECT_EQ(col, 2);
  EnvironmentTexelOf(m, Vec3(0, 1, 0), col, row);
  EXPECT_EQ(row, 0);
  EnvironmentTexelOf(m, Vec3(0, -1, 0), col, row);
  EXPECT_EQ(row, 3);
}

// ---------------------------------------------------------------------------------------------------------------
// Pdf.

// Texel-aligned midpoint quadrature in (longitude, sin latitude): 4×4 points strictly inside every texel,
// each of weight Ω/16. Pdf is constant on a texel, so the sum is exactly ∫ pdf dω = 1, and each point's Pdf ×
// Ω (Ω computed here) is the texel's probability luminance × Ω / Σ; black texels have Pdf 0.
TEST(EnvironmentSampler, PdfIntegratesToOneAndTimesSolidAngleIsTexelProbability) {
  for (const NamedMap& nm : MapGrid()) {
    const EnvironmentMap& m = nm.map;
    const EnvironmentSampler s(m);
    ASSERT_FALSE(s.Empty()) << nm.name;
    const Expected ex = MyTexelProbabilities(m);
    const int k = 4;
    double integral = 0.0;
    double worstRel = 0.0;
    std::string worstWhere;
    int zeroViolations = 0;
    for (int r = 0; r < m.height; ++r) {
      const double omega = MyTexelSolidAngle(m.width, m.height, r);
      const double sTop = std::sin(LatitudeTop(r, m.height)), sSpan = SinLatitudeSpan(r, m.height);
      for (int c = 0; c < m.width; ++c) {
        const double p = ex.probability[static_cast<size_t>(r) * m.width + c];
        for (int i = 0; i < k; ++i)
          for (int j = 0; j < k; ++j) {
            const double phi = LongitudeHigh(c, m.width) - (i + 0.5) / k * (2.0 * kPiD / m.width);
            const double sl = sTop - (j + 0.5) / k * sSpan;
            const float pdf = s.Pdf(F(DirectionFromLongSin(phi, sl)));
            integral += pdf * omega / (k * k);
            if (p == 0.0) {
              zeroViolations += pdf != 0.0f;
              continue;
            }
            const double rel = std::fabs(pdf * omega / p - 1.0);
            if (rel > worstRel) {
              worstRel = rel;
              worstWhere = "texel " + std::to_string(c) + "," + std::to_string(r) + " pdf " +
                           std::to_string(pdf) + " want " + std::to_string(p / omega);
            }
          }
      }
    }
    EXPECT_NEAR(integral, 1.0, 1e-5) << nm.name;
    EXPECT_LE(worstRel, 1e-5) << nm.name << ": worst at " << worstWhere;
    EXPECT_EQ(zeroViolations, 0) << nm.name;
  }
}

TEST(EnvironmentSampler, EmptyWhenNoTexelHasLuminance) {
  EnvironmentMap black;
  black.width = 4;
  black.height = 2;
  black.texels.assign(8, Vec3(0.0f));
  const EnvironmentSampler s(black);
  EXPECT_TRUE(s.Empty());
  for (const Vec3& d : {Vec3(0, 1, 0), Vec3(1, 0, 0), glm::normalize(Vec3(-1, -2, 3))})
    EXPECT_EQ(s.Pdf(d), 0.0f);
  float pdf = -1.0f;
  s.Sample(0.3f, 0.6f, 0.2f, 0.7f, pdf);
  EXPECT_EQ(pdf, 0.0f);
  const EnvironmentSampler none;
  EXPECT_TRUE(none.Empty());
}

// ---------------------------------------------------------------------------------------------------------------
// Sampling.

// 2^20 samples per map of the grid. Per sample (exact checks): unit direction (|1 - |ω|| ≤ 1e-6); the
// returned pdf equals Pdf(ω) (relative 1e-6); it equals P(texel)/Ω(texel) computed here, for samples farther
// than 1e-4 texel from an edge (relative 1e-5); Y(Radiance(ω))/pdf is the constant Σ Y Ω (the sampler is
// exactly proportional to luminance, relative 1e-5); no sample in a black texel. χ² of texel counts against
// P(texel); on the 512×256 map also over 8×8-texel blocks (its background texels are expected below 5 each
// and pooled at texel level). False-failure rate 1e-6 for the test: 8 χ² assertions at 1.25e-7 each.
TEST(EnvironmentSampler, SamplesFollowLuminanceTimesSolidAngleChiSquare) {
  const double tail = 1e-6 / 8;
  const int n = 1 << 20;
  uint32_t seed = 1000;
  for (const NamedMap& nm : MapGrid()) {
    const EnvironmentMap& m = nm.map;
    const EnvironmentSampler s(m);
    const Expected ex = MyTexelProbabilities(m);
    std::vector<double> observed(m.texels.size(), 0.0);
    int notUnit = 0, pdfMismatch = 0, layoutMismatch = 0, notProportional = 0, inBlack = 0, implBlack = 0;
    std::string firstPdfMismatch, firstLayoutMismatch, firstNotProportional;
    ++seed;
    for (int i = 0; i < n; ++i) {
      const RngKey key = Key(seed, static_cast<uint32_t>(i));
      float pdf = 0.0f;
      const Vec3 d = s.Sample(UniformFloat(key, 0), UniformFloat(key, 1), UniformFloat(key, 2),
                              UniformFloat(key, 3), pdf);
      const DVec3 dd = D(d);
      notUnit += std::fabs(Length(dd) - 1.0) > 1e-6;
      const float pdfAgain = s.Pdf(d);
      if (!(std::fabs(static_cast<double>(pdf) / pdfAgain - 1.0) <= 1e-6)) {
        if (pdfMismatch++ == 0)
          firstPdfMismatch = "sample " + std::to_string(i) + " pdf " + std::to_string(pdf) + " Pdf " +
                             std::to_string(pdfAgain);
      }
      const MapCoords mc = MyMapCoords(Normalize(dd), m.width, m.height);
      const size_t t = static_cast<size_t>(mc.row) * m.width + mc.column;
      observed[t] += 1.0;
      const double want = ex.probability[t] / MyTexelSolidAngle(m.width, m.height, mc.row);
      if (EdgeDistance(mc) > 1e-4) {
        inBlack += ex.probability[t] == 0.0;
        if (!(std::fabs(pdf / want - 1.0) <= 1e-5) && layoutMismatch++ == 0)
          firstLayoutMismatch = "texel " + std::to_string(mc.column) + "," + std::to_string(mc.row) +
                                " pdf " + std::to_string(pdf) + " want " + std::to_string(want);
      }
      const double y = LuminanceD(s.Radiance(d));
      implBlack += y == 0.0;
      if (!(std::fabs(y / pdf / ex.sum - 1.0) <= 1e-5) && notProportional++ == 0)
        firstNotProportional = "sample " + std::to_string(i) + " Y/pdf " + std::to_string(y / pdf) +
                               " want " + std::to_string(ex.sum);
    }
    EXPECT_EQ(notUnit, 0) << nm.name;
    EXPECT_EQ(pdfMismatch, 0) << nm.name << ": first " << firstPdfMismatch;
    EXPECT_EQ(layoutMismatch, 0) << nm.name << ": first " << firstLayoutMismatch;
    EXPECT_EQ(notProportional, 0) << nm.name << ": first " << firstNotProportional;
    EXPECT_EQ(inBlack, 0) << nm.name;
    EXPECT_EQ(implBlack, 0) << nm.name << " (samples whose Radiance is black)";
    if (m.texels.size() > 1) {
      std::vector<double> expected(ex.probability.size());
      for (size_t t = 0; t < expected.size(); ++t) expected[t] = n * ex.probability[t];
      ExpectChiSquare(nm.name + ", texels", observed, expected, tail);
      if (m.width == 512) {
        const int b = 8, bw = m.width / b, bh = m.height / b;
        std::vector<double> bo(static_cast<size_t>(bw) * bh, 0.0), be(bo.size(), 0.0);
        for (int r = 0; r < m.height; ++r)
          for (int c = 0; c < m.width; ++c) {
            const size_t t = static_cast<size_t>(r) * m.width + c,
                         k = static_cast<size_t>(r / b) * bw + c / b;
            if (r == kBrightRow && c == kBrightColumn)
              continue;  // the bright texel alone is its own bin above
            bo[k] += observed[t];
            be[k] += expected[t];
          }
        ExpectChiSquare(nm.name + ", 8x8 blocks w/o bright texel", bo, be, tail);
      }
    }
  }
}

// Within a texel the direction is uniform in solid angle: 8×8 sub-bins in (longitude, sin latitude) of chosen
// texels get equal counts. The texels: the whole sphere (1×1), a hemisphere (2×1, column 0), a 7×3 corner
// texel, a 3×40 polar texel, and the 512×256 bright texel at the pole (there uniform-in-latitude sampling
// would pile up towards the pole, 1/cos λ). 2^20 samples per map; false-failure rate 1e-6 for the test: 5 χ²
// at 2e-7.
TEST(EnvironmentSampler, UniformInSolidAngleWithinTexelChiSquare) {
  const double tail = 1e-6 / 5;
  const int n = 1 << 20, sub = 8;
  struct Case {
    std::string name;
    EnvironmentMap map;
    int column, row;
  };
  std::vector<Case> cases{
      {"1x1 texel 0,0", RandomMap(1, 1, 61, 0.0f), 0, 0},
      {"2x1 texel 0,0", RandomMap(2, 1, 62, 0.0f), 0, 0},
      {"7x3 texel 6,2", RandomMap(7, 3, 63, 0.0f), 6, 2},
      {"3x40 texel 2,0 (polar)", RandomMap(3, 40, 64, 0.0f), 2, 0},
      {"512x256 bright texel 511,0 (polar, seam)", BrightTexelMap(), kBrightColumn, kBrightRow}};
  // Make the chosen texel of the small maps carry a good share.
  cases[2].map.texels[2 * 7 + 6] *= 20.0f;
  cases[3].map.texels[0 * 3 + 2] *= 2000.0f;
  uint32_t seed = 2000;
  for (const Case& k : cases) {
    const EnvironmentMap& m = k.map;
    const EnvironmentSampler s(m);
    std::vector<double> observed(sub * sub, 0.0);
    double inTexel = 0.0;
    const double phiHigh = LongitudeHigh(k.column, m.width), phiSpan = 2.0 * kPiD / m.width;
    const double sTop = std::sin(LatitudeTop(k.row, m.height)), sSpan = SinLatitudeSpan(k.row, m.height);
    ++seed;
    for (int i = 0; i < n; ++i) {
      const RngKey key = Key(seed, static_cast<uint32_t>(i));
      float pdf = 0.0f;
      const Vec3 d = s.Sample(UniformFloat(key, 0), UniformFloat(key, 1), UniformFloat(key, 2),
                              UniformFloat(key, 3), pdf);
      const DVec3 dd = Normalize(D(d));
      const MapCoords mc = MyMapCoords(dd, m.width, m.height);
      if (mc.column != k.column || mc.row != k.row) continue;
      inTexel += 1.0;
      double phi = std::atan2(dd.x, dd.z);
      if (m.width == 1 && phi > phiHigh) phi = phiHigh;
      const double a = std::clamp((phiHigh - phi) / phiSpan, 0.0, 1.0 - 1e-12);
      const double b = std::clamp((sTop - dd.y) / sSpan, 0.0, 1.0 - 1e-12);
      observed[static_cast<size_t>(b * sub) * sub + static_cast<size_t>(a * sub)] += 1.0;
    }
    ASSERT_GT(inTexel, 1e5) << k.name;
    const std::vector<double> expected(sub * sub, inTexel / (sub * sub));
    ExpectChiSquare(k.name + ", 8x8 sub-bins", observed, expected, tail);
  }
}

// Edge uniforms (0 and the largest float below 1 for the within-texel pair): the direction is still in a
// texel of positive probability and the returned pdf equals Pdf(ω).
TEST(EnvironmentSampler, SampleAtEdgeUniformsMatchesPdf) {
  const float one = std::nextafter(1.0f, 0.0f);
  for (const NamedMap& nm : MapGrid()) {
    const EnvironmentSampler s(nm.map);
    for (float us : {0.0f, 0.37f, one})
      for (float uc : {0.0f, 0.5f, one})
        for (float up : {0.0f, 0.5f, one})
          for (float ul : {0.0f, 0.5f, one}) {
            float pdf = 0.0f;
            const Vec3 d = s.Sample(us, uc, up, ul, pdf);
            EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f) << nm.name;
            EXPECT_GT(pdf, 0.0f) << nm.name << " u = " << us << " " << uc << " " << up << " " << ul
                                 << " d = (" << d.x << ", " << d.y << ", " << d.z << ")";
            EXPECT_EQ(pdf, s.Pdf(d)) << nm.name << " u = " << us << " " << uc << " " << up << " " << ul
                                     << " d = (" << d.x << ", " << d.y << ", " << d.z << ")";
            EXPECT_GT(Luminance(s.Radiance(d)), 0.0f) << nm.name;
          }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// The sun.

std::vector<std::pair<std::string, DVec3>> SunDirections() {
  return {{"up", {0, 1, 0}},
          {"tilted", Normalize({0.3, 0.8, -0.4})},
          {"grazing", DirectionFromLongLat(2.2, 0.2 * kPiD / 180.0)},
          {"-Y", {0, -1, 0}},
          {"arbitrary", Normalize({-0.61, -0.17, 0.77})}};
}
const std::vector<double> kSunDiameters{0.1, 0.53, 5.0, 30.0, 120.0};

TEST(SunDisc, MakeSunDiscConeIsExact) {
  for (double diameter : kSunDiameters)
    for (const auto& [name, dir] : SunDirections()) {
      const Vec3 L(3.0f, 2.0f, 1.0f);
      const SunDisc s = MakeSunDisc(F(dir), static_cast<float>(diameter), L);
      const double alpha = 0.5 * diameter * kPiD / 180.0;
      const double oneMinusCos = 1.0 - std::cos(alpha);  // fine in double: 3.8e-7 at 0.1° has 9 digits left
      const double chord = 2.0 * std::sin(0.5 * alpha);
      EXPECT_NEAR(s.oneMinusCos, oneMinusCos, 1e-6 * oneMinusCos) << diameter << "° " << name;
      EXPECT_NEAR(s.chord2, chord * chord, 1e-6 * chord * chord) << diameter << "° " << name;
      EXPECT_NEAR(Length(Sub(D(s.direction), dir)), 0.0, 1e-6)
          << diameter << "° " << name;  // float unit vector
      EXPECT_TRUE(s.radiance == L);
      // SunDiscPdf × cone solid angle 2π(1 - cos α) = 1, on the axis and just inside the rim; 0 just outside.
      const float pdfAxis = SunDiscPdf(s, s.direction);
      EXPECT_NEAR(pdfAxis * 2.0 * kPiD * oneMinusCos, 1.0, 1e-6) << diameter << "° " << name;
      DVec3 t = Normalize(Cross(std::fabs(dir.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0}, dir));
      for (double f : {0.99, 1.01}) {
        const double th = f * alpha;
        const DVec3 w{std::cos(th) * dir.x + std::sin(th) * t.x, std::cos(th) * dir.y + std::sin(th) * t.y,
                      std::cos(th) * dir.z + std::sin(th) * t.z};
        EXPECT_EQ(InSunDisc(s, F(w)), f < 1.0) << diameter << "° " << name << " at " << f << " α";
        EXPECT_EQ(SunDiscPdf(s, F(w)), f < 1.0 ? pdfAxis : 0.0f) << diameter << "° " << name;
      }
    }
}

// ∫ SunDiscPdf dω = 1 numerically: midpoint quadrature in (1 - cos θ, φ) about the axis over twice the cone,
// 400 × 64 cells (the rim on a cell edge), so InSunDisc decides every point half a cell away from the rim.
TEST(SunDisc, PdfIntegratesToOne) {
  for (double diameter : kSunDiameters)
    for (const auto& [name, dir] : SunDirections()) {
      const SunDisc s = MakeSunDisc(F(dir), static_cast<float>(diameter), Vec3(1.0f));
      const double alpha = 0.5 * diameter * kPiD / 180.0;
      const double oneMinusCos = 1.0 - std::cos(alpha);
      const DVec3 a = D(s.direction);
      const DVec3 t = Normalize(Cross(std::fabs(a.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0}, a)),
                  b = Cross(a, t);
      const int nt = 400, np = 64;
      const double range = std::min(2.0 * oneMinusCos, 2.0), dt = range / nt, dp = 2.0 * kPiD / np;
      double integral = 0.0;
      for (int i = 0; i < nt; ++i) {
        const double omc = (i + 0.5) * dt, ct = 1.0 - omc, st = std::sqrt(std::max(0.0, omc * (2.0 - omc)));
        for (int j = 0; j < np; ++j) {
          const double p = (j + 0.5) * dp;
          const DVec3 w{ct * a.x + st * (std::cos(p) * t.x + std::sin(p) * b.x),
                        ct * a.y + st * (std::cos(p) * t.y + std::sin(p) * b.y),
                        ct * a.z + st * (std::cos(p) * t.z + std::sin(p) * b.z)};
          integral += SunDiscPdf(s, F(w)) * dt * dp;
        }
      }
      EXPECT_NEAR(integral, 1.0, 1e-5) << diameter << "° " << name;
    }
}

// Samples are unit, inside the disc, with pdf > 0; uniform in the cone: χ² over 16 bins of (1 - cos θ)/(1 -
// cos α) (θ from the axis, computed as |ω - axis|²/2 without cancellation) × 16 bins of φ about the axis.
// 2^19 samples per case, 25 cases; false-failure rate 1e-6 for the test: 25 χ² at 4e-8.
TEST(SunDisc, SamplesUniformInConeChiSquare) {
  const double tail = 1e-6 / 25;
  const int n = 1 << 19, bins = 16;
  uint32_t seed = 3000;
  for (double diameter : kSunDiameters)
    for (const auto& [name, dir] : SunDirections()) {
      const SunDisc s = MakeSunDisc(F(dir), static_cast<float>(diameter), Vec3(1.0f));
      const double oneMinusCos = 1.0 - std::cos(0.5 * diameter * kPiD / 180.0);
      const DVec3 a = D(s.direction);
      const DVec3 t = Normalize(Cross(std::fabs(a.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0}, a)),
                  b = Cross(a, t);
      std::vector<double> observed(bins * bins, 0.0);
      int notUnit = 0, outside = 0, beyondRim = 0;
      double worstExcess = 0.0;
      std::string worstOutside;
      ++seed;
      for (int i = 0; i < n; ++i) {
        const RngKey key = Key(seed, static_cast<uint32_t>(i));
        const Vec3 w = SampleSunDisc(s, UniformFloat(key, 0), UniformFloat(key, 1));
        const DVec3 wd = D(w);
        notUnit += std::fabs(Length(wd) - 1.0) > 1e-6;
        if (!InSunDisc(s, w) || !(SunDiscPdf(s, w) > 0.0f)) {
          const Vec3 dw = w - s.direction;
          const double excess = glm::dot(dw, dw) / s.chord2 - 1.0;
          if (outside++ == 0 || excess > worstExcess) {
            worstExcess = excess;
            char buf[160];
            std::snprintf(buf, sizeof buf,
                          "u0 %.9g u1 %.9g: |w - axis|^2 %.9g, chord2 %.9g (ratio - 1 = %.3g)",
                          UniformFloat(key, 0), UniformFloat(key, 1), glm::dot(dw, dw), s.chord2, excess);
            worstOutside = buf;
          }
        }
        const DVec3 dv = Sub(Normalize(wd), a);
        const double x = 0.5 * Dot(dv, dv) / oneMinusCos;  // (1 - cos θ)/(1 - cos α)
        beyondRim += x > 1.0 + 1e-3;
        const double phi = std::atan2(Dot(dv, b), Dot(dv, t));
        const int bx = std::clamp(static_cast<int>(x * bins), 0, bins - 1);
        const int bp = std::clamp(static_cast<int>((phi + kPiD) / (2.0 * kPiD) * bins), 0, bins - 1);
        observed[static_cast<size_t>(bx) * bins + bp] += 1.0;
      }
      const std::string what = std::to_string(diameter).substr(0, 5) + "deg " + name;
      EXPECT_EQ(notUnit, 0) << what;
      EXPECT_EQ(outside, 0) << what << ": sampled directions failing InSunDisc, worst " << worstOutside;
      EXPECT_EQ(beyondRim, 0) << what;
      ExpectChiSquare("sun " + what + ", 16 cos x 16 phi", observed,
                      std::vector<double>(bins * bins, static_cast<double>(n) / (bins * bins)), tail);
    }
}

// The extreme uniforms (0 and the largest float below 1) still give a direction in the disc: the rim sample
// passes the same InSunDisc test as every other direction.
TEST(SunDisc, SampleAtEdgeUniformsIsInDisc) {
  const float one = std::nextafter(1.0f, 0.0f);
  for (double diameter : kSunDiameters)
    for (const auto& [name, dir] : SunDirections()) {
      const SunDisc s = MakeSunDisc(F(dir), static_cast<float>(diameter), Vec3(1.0f));
      for (float u0 : {0.0f, 0.5f, one})
        for (float u1 : {0.0f, 0.25f, 0.5f, 0.75f, one}) {
          const Vec3 w = SampleSunDisc(s, u0, u1);
          EXPECT_NEAR(glm::length(w), 1.0f, 1e-6f) << diameter << "° " << name;
          EXPECT_TRUE(InSunDisc(s, w)) << diameter << "° " << name << " u = " << u0 << ", " << u1
                                       << ": |w - axis|^2 = " << glm::dot(w - s.direction, w - s.direction)
                                       << " chord2 = " << s.chord2;
        }
    }
}

// E = π L sin²α recovers the illuminance (α the half-angle, computed here in double).
TEST(SunDisc, RadianceFromIlluminanceRecoversIlluminance) {
  const Vec3 e(100000.0f, 90000.0f, 70000.0f);
  for (double diameter : kSunDiameters) {
    const Vec3 L = SunRadianceFromIlluminance(e, static_cast<float>(diameter));
    const double s = std::sin(0.5 * diameter * kPiD / 180.0);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(kPiD * L[c] * s * s / e[c], 1.0, 1e-5) << diameter << "° channel " << c;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// The sky of a frame.

// R(ρ) about +Y, right-handed (counter-clockwise seen from +Y looking down): x' = x cos ρ + z sin ρ,
// z' = -x sin ρ + z cos ρ, so a map direction at longitude φ = atan2(x, z) appears in the world at φ + ρ.
DVec3 MyRotate(const DVec3& v, double rho) {
  return {v.x * std::cos(rho) + v.z * std::sin(rho), v.y, -v.x * std::sin(rho) + v.z * std::cos(rho)};
}
Sky RotatedSky(const EnvironmentSampler* env, double rho) {
  Sky sky;
  sky.environment = env;
  sky.cosRotation = static_cast<float>(std::cos(rho));
  sky.sinRotation = static_cast<float>(std::sin(rho));
  return sky;
}
const std::vector<double> kRotations{0.0, 0.7, kPiD / 2, -2.5, kPiD};

TEST(Sky, RotationIsRAboutPlusYWorldFromMap) {
  const EnvironmentSampler env(RandomMap(7, 5, 71, 1.0f));
  for (double rho : kRotations) {
    const Sky sky = RotatedSky(&env, rho);
    for (uint32_t i = 0; i < 200; ++i) {
      const RngKey key = Key(4000, i);
      const DVec3 v =
          DirectionFromLongSin(2.0 * kPiD * UniformFloat(key, 0), 2.0 * UniformFloat(key, 1) - 1.0);
      const Vec3 w = F(v);
      EXPECT_NEAR(Length(Sub(D(sky.ToWorld(sky.ToMap(w))), D(w))), 0.0, 1e-6) << rho;
      EXPECT_NEAR(Length(Sub(D(sky.ToMap(sky.ToWorld(w))), D(w))), 0.0, 1e-6) << rho;
      EXPECT_NEAR(Length(Sub(D(sky.ToWorld(w)), MyRotate(v, rho))), 0.0, 1e-6)
          << "world = R(rho) map, rho " << rho;
      EXPECT_NEAR(Length(Sub(D(sky.ToMap(w)), MyRotate(v, -rho))), 0.0, 1e-6)
          << "map = R(-rho) world, rho " << rho;
    }
  }
  // The named case: ρ = π/2 turns the map's +Z (longitude 0) to the world's +X (longitude π/2).
  const Sky quarter = RotatedSky(&env, kPiD / 2);
  EXPECT_NEAR(Length(Sub(D(quarter.ToWorld(Vec3(0, 0, 1))), {1, 0, 0})), 0.0, 1e-6);
  EXPECT_NEAR(Length(Sub(D(quarter.ToMap(Vec3(1, 0, 0))), {0, 0, 1})), 0.0, 1e-6);
}

// A texel seen in the world at its centre's longitude + ρ, scaled by environmentScale; no sun.
TEST(Sky, RadianceOfRotatedTexelCentres) {
  const EnvironmentMap m = RandomMap(9, 5, 72, 1.0f);
  const EnvironmentSampler env(m);
  for (double rho : kRotations) {
    Sky sky = RotatedSky(&env, rho);
    sky.environmentScale = Vec3(2.0f, 0.5f, 3.0f);
    for (int r = 0; r < m.height; ++r)
      for (int c = 0; c < m.width; ++c) {
        const double phi = 0.5 * (LongitudeHigh(c, m.width) + LongitudeLow(c, m.width));
        const double lambda = 0.5 * (LatitudeTop(r, m.height) + LatitudeBottom(r, m.height));
        const Vec3 world = F(DirectionFromLongLat(phi + rho, lambda));
        const Vec3 want = m.texels[static_cast<size_t>(r) * m.width + c] * sky.environmentScale;
        const Vec3 got = sky.Radiance(world);
        EXPECT_NEAR(got.x, want.x, 1e-6f * want.x) << "rho " << rho << " texel " << c << "," << r;
        EXPECT_NEAR(got.y, want.y, 1e-6f * want.y);
        EXPECT_NEAR(got.z, want.z, 1e-6f * want.z);
        EXPECT_EQ(sky.EnvironmentPdf(world), env.Pdf(F(DirectionFromLongLat(phi, lambda)))) << rho;
      }
  }
}

// SampleEnvironment's pdf equals EnvironmentPdf of its direction; mapped back by R(-ρ) (computed here) the
// texel counts follow P(texel). 2^20 samples per rotation, 64×32 map; false-failure rate 1e-6: 5 χ² at 2e-7.
TEST(Sky, SampleEnvironmentAfterRotationChiSquare) {
  const double tail = 1e-6 / kRotations.size();
  const EnvironmentMap m = RandomMap(64, 32, 73, 2.0f);
  const EnvironmentSampler env(m);
  const Expected ex = MyTexelProbabilities(m);
  const int n = 1 << 20;
  uint32_t seed = 5000;
  for (double rho : kRotations) {
    Sky sky = RotatedSky(&env, rho);
    sky.environmentScale = Vec3(2.0f);
    std::vector<double> observed(m.texels.size(), 0.0);
    int mismatch = 0, notUnit = 0;
    ++seed;
    for (int i = 0; i < n; ++i) {
      const RngKey key = Key(seed, static_cast<uint32_t>(i));
      float pdf = 0.0f;
      const Vec3 w = sky.SampleEnvironment(UniformFloat(key, 0), UniformFloat(key, 1), UniformFloat(key, 2),
                                           UniformFloat(key, 3), pdf);
      notUnit += std::fabs(Length(D(w)) - 1.0) > 1e-6;
      mismatch += !(std::fabs(static_cast<double>(pdf) / sky.EnvironmentPdf(w) - 1.0) <= 1e-6);
      const MapCoords mc = MyMapCoords(Normalize(MyRotate(D(w), -rho)), m.width, m.height);
      observed[static_cast<size_t>(mc.row) * m.width + mc.column] += 1.0;
    }
    EXPECT_EQ(mismatch, 0) << rho;
    EXPECT_EQ(notUnit, 0) << rho;
    std::vector<double> expected(ex.probability.size());
    for (size_t t = 0; t < expected.size(); ++t) expected[t] = n * ex.probability[t];
    ExpectChiSquare("sky 64x32 rotated rho=" + std::to_string(rho).substr(0, 6), observed, expected, tail);
  }
}

TEST(Sky, RadianceAddsSunInsideDiscOnly) {
  const EnvironmentSampler env(RandomMap(1, 1, 74, 0.0f));
  const Vec3 envL = env.Map().texels[0];
  for (double diameter : kSunDiameters)
    for (const auto& [name, dir] : SunDirections()) {
      Sky sky = RotatedSky(&env, 0.7);
      sky.hasSun = true;
      sky.sun = MakeSunDisc(F(dir), static_cast<float>(diameter), Vec3(5e4f, 4e4f, 3e4f));
      const double alpha = 0.5 * diameter * kPiD / 180.0;
      const DVec3 t = Normalize(Cross(std::fabs(dir.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0}, dir));
      for (double f : {0.0, 0.5, 0.99, 1.01, 2.0}) {
        const double th = f * alpha;
        const Vec3 w =
            F({std::cos(th) * dir.x + std::sin(th) * t.x, std::cos(th) * dir.y + std::sin(th) * t.y,
               std::cos(th) * dir.z + std::sin(th) * t.z});
        const Vec3 want = f < 1.0 ? envL + sky.sun.radiance : envL;
        const Vec3 got = sky.Radiance(w);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(got[c], want[c], 1e-6f * want[c]) << diameter << "° " << name << " at " << f << " α";
        EXPECT_EQ(sky.SunPdf(w), f < 1.0 ? SunDiscPdf(sky.sun, w) : 0.0f);
      }
      // Without hasSun the disc is ignored.
      sky.hasSun = false;
      const Vec3 got = sky.Radiance(sky.sun.direction);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], envL[c], 1e-6f * envL[c]);
      EXPECT_EQ(sky.SunPdf(sky.sun.direction), 0.0f);
    }
}

TEST(Sky, SampleSunIsInDiscWithItsPdf) {
  Sky sky;
  sky.hasSun = true;
  sky.sun = MakeSunDisc(F(Normalize({0.2, 0.5, -0.8})), 0.53f, Vec3(1e5f));
  for (uint32_t i = 0; i < 10000; ++i) {
    const RngKey key = Key(6000, i);
    float pdf = 0.0f;
    const Vec3 w = sky.SampleSun(UniformFloat(key, 0), UniformFloat(key, 1), pdf);
    ASSERT_TRUE(InSunDisc(sky.sun, w)) << i;
    ASSERT_EQ(pdf, sky.SunPdf(w)) << i;
    ASSERT_GT(pdf, 0.0f);
  }
}

TEST(Sky, EmptyAndHasEnvironment) {
  EnvironmentMap black;
  black.width = 2;
  black.height = 2;
  black.texels.assign(4, Vec3(0.0f));
  const EnvironmentSampler blackEnv(black), lit(RandomMap(2, 2, 75, 0.0f));
  Sky sky;
  EXPECT_FALSE(sky.HasEnvironment());
  EXPECT_TRUE(sky.Empty());
  sky.environment = &blackEnv;
  EXPECT_FALSE(sky.HasEnvironment());
  EXPECT_TRUE(sky.Empty());
  EXPECT_EQ(sky.EnvironmentPdf(Vec3(0, 1, 0)), 0.0f);
  sky.hasSun = true;
  sky.sun = MakeSunDisc(Vec3(0, 1, 0), 0.53f, Vec3(1.0f));
  EXPECT_FALSE(sky.Empty());
  sky.environment = &lit;
  EXPECT_TRUE(sky.HasEnvironment());
  EXPECT_FALSE(sky.Empty());
  sky.hasSun = false;
  EXPECT_FALSE(sky.Empty());
}

// ---------------------------------------------------------------------------------------------------------------
// Directions as far points.

// For receivers at the origin, ~1000 m and ~1e6 m away, and directions from the normal to grazing (n·ω =
// 0.03) and below: core/shading.h evaluates the far point exactly as the direction, L albedo/π max(0, n·ω)
// (relative 1e-5), and ConnectToLight's direction is ω (1e-6).
TEST(SkyPointFor, ShadingEvaluatesTheDirection) {
  const std::vector<DVec3> receivers{{0, 0, 0}, {700, 100, -700}, {1e6, 0, 0}, {-3e5, 2e5, 9e5}};
  const std::vector<DVec3> normals{{0, 1, 0}, Normalize({0.3, 0.9, -0.2}), Normalize({-1, 0.1, 0.4})};
  const Vec3 L(2.0f, 3.0f, 0.5f), albedo(0.7f, 0.5f, 0.3f);
  for (const DVec3& x : receivers)
    for (const DVec3& n : normals) {
      const DVec3 t = Normalize(Cross(std::fabs(n.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0}, n)),
                  b = Cross(n, t);
      for (double cosTheta : {1.0, 0.7, 0.2, 0.03, -0.2})
        for (double phi : {0.0, 1.3, 4.0}) {
          const double st = std::sqrt(1.0 - cosTheta * cosTheta);
          const DVec3 wd = Normalize({cosTheta * n.x + st * (std::cos(phi) * t.x + std::sin(phi) * b.x),
                                      cosTheta * n.y + st * (std::cos(phi) * t.y + std::sin(phi) * b.y),
                                      cosTheta * n.z + st * (std::cos(phi) * t.z + std::sin(phi) * b.z)});
          const Vec3 w = F(wd);
          ShadingPoint sp;
          sp.position = F(x);
          sp.geometricNormal = F(n);
          sp.shadingNormal = F(n);
          sp.wo = F(n);
          sp.bsdf.type = BsdfType::kDiffuse;
          sp.bsdf.albedo = albedo;
          const LightSample y = SkyPointFor(sp.position, w, L);
          EXPECT_TRUE(IsSkySample(y.lightId));
          const Vec3 f = UnshadowedContribution(sp, y);
          const double cosW = Dot(D(F(n)), D(w));
          for (int c = 0; c < 3; ++c) {
            const double want = L[c] * albedo[c] / kPiD * std::max(0.0, cosW);
            if (cosTheta < 0.0)
              EXPECT_EQ(f[c], 0.0f);
            else
              EXPECT_NEAR(f[c] / want, 1.0, 1e-5) << "receiver " << x.x << "," << x.y << "," << x.z << " cos "
                                                  << cosTheta << " phi " << phi << " channel " << c;
          }
          if (cosTheta > 0.0) {
            const LightPath path = ConnectToLight(sp, y.position, y.normal);
            EXPECT_NEAR(Length(Sub(D(path.wi), D(w))), 0.0, 1e-6)
                << "receiver " << x.x << " cos " << cosTheta;
          }
        }
    }
}

}  // namespace sky_test
}  // namespace restir
