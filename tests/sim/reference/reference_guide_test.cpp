#include "sim/reference/reference_guide.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "stats.h"

namespace restir {
namespace {

constexpr double kFourPi = 4.0 * M_PI;
constexpr double kFalseFailure = 1e-4;  // per claim

Vec3 UniformSphere(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double z = 2.0 * u(rng) - 1.0, phi = 2.0 * M_PI * u(rng), r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(static_cast<float>(r * std::cos(phi)), static_cast<float>(z), static_cast<float>(r * std::sin(phi)));
}

// Weights a test draws from: sparse (most bins 0, as a guide that learned one patch), and dense with a spread of
// five orders of magnitude.
std::vector<double> Weights(std::mt19937& rng, bool sparse) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> w(kGuideBins);
  for (double& x : w) x = sparse ? (u(rng) < 0.05 ? u(rng) : 0.0) : std::pow(10.0, -5.0 * u(rng));
  return w;
}

// The map is equal-area: uniform directions fill the bins evenly (Pearson's χ² over the bins at kFalseFailure),
// which is what lets a bin's density be its share over 4π / kGuideBins.
TEST(GuideBin, UniformDirectionsFillEveryBinEvenly) {
  std::mt19937 rng(7);
  const int n = 200 * kGuideBins;
  std::vector<double> observed(kGuideBins, 0.0), expected(kGuideBins, double(n) / kGuideBins);
  for (int k = 0; k < n; ++k) observed[static_cast<size_t>(GuideBin(UniformSphere(rng)))] += 1.0;
  const test::ChiSquareResult chi = test::ChiSquare(observed, expected);
  EXPECT_LT(chi.statistic, test::ChiSquareCritical(chi.dof, kFalseFailure));
  // The poles and the seam: every unit direction has a bin.
  for (const Vec3& d : {Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(1, 0, 0), Vec3(1, 0, -1e-7f), Vec3(-1, 0, 0)}) {
    const int b = GuideBin(glm::normalize(d));
    EXPECT_GE(b, 0);
    EXPECT_LT(b, kGuideBins);
  }
}

// The density integrates to 1 over the sphere: it is constant in each bin, so the sum over the bins' centres of
// Pdf × 4π / bins is exactly Σ shares = 1 (to float rounding).
TEST(DirectionGuide, DensityIntegratesToOne) {
  std::mt19937 rng(11);
  for (bool sparse : {true, false}) {
    const std::vector<double> w = Weights(rng, sparse);
    const DirectionGuide guide(w.data());
    ASSERT_FALSE(guide.Empty());
    double integral = 0.0;
    for (int row = 0; row < kGuideRows; ++row)
      for (int column = 0; column < kGuideColumns; ++column) {
        const double z = -1.0 + 2.0 * (row + 0.5) / kGuideRows, phi = 2.0 * M_PI * (column + 0.5) / kGuideColumns;
        const double r = std::sqrt(1.0 - z * z);
        const Vec3 d(static_cast<float>(r * std::cos(phi)), static_cast<float>(z), static_cast<float>(r * std::sin(phi)));
        ASSERT_EQ(GuideBin(d), row * kGuideColumns + column);
        integral += guide.Pdf(d) * kFourPi / kGuideBins;
      }
    EXPECT_NEAR(integral, 1.0, 1e-5) << (sparse ? "sparse" : "dense");
  }
}

// Sample draws what Pdf says: its bins follow the weights (χ²), it never lands in a bin of weight 0, and within the
// bins it is uniform in solid angle with the stated density, so E[g(ω) / Pdf(ω)] = ∫ g over the support, for g = 1
// and for a g that varies inside the bins (a t-test on the mean of g / Pdf, kFalseFailure; the integral by the
// midpoint rule on a fine grid).
TEST(DirectionGuide, SamplesFollowTheDensity) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const double tCritical = test::StudentTQuantileTwoSided(kFalseFailure, 1e6);
  for (bool sparse : {true, false}) {
    const std::vector<double> w = Weights(rng, sparse);
    const DirectionGuide guide(w.data());
    double total = 0.0;
    for (double x : w) total += x;
    const int n = 400000;
    std::vector<double> observed(kGuideBins, 0.0), expected(kGuideBins);
    for (int b = 0; b < kGuideBins; ++b) expected[static_cast<size_t>(b)] = n * w[static_cast<size_t>(b)] / total;
    const auto g = [](const Vec3& d) { return 1.0 + 3.0 * d.y * d.y + std::sin(5.0 * d.x); };
    test::RunningStats one, varying;
    int outside = 0;  // draws whose rounding crossed into a bin of weight 0 (a point on a bin's edge)
    for (int k = 0; k < n; ++k) {
      const float u0 = u(rng), u1 = u(rng);
      const Vec3 d = guide.Sample(u0, u1);
      ASSERT_NEAR(glm::length(d), 1.0f, 1e-5f);
      const int b = GuideBin(d);
      if (!(w[static_cast<size_t>(b)] > 0.0)) {
        ++outside;
        continue;
      }
      observed[static_cast<size_t>(b)] += 1.0;
      const double pdf = guide.Pdf(d);
      one.Add(1.0 / pdf);
      varying.Add(g(d) / pdf);
    }
    // Only float rounding at a bin's edge can put a draw outside the support: about 1e-7 of them.
    EXPECT_LE(outside, 2) << (sparse ? "sparse" : "dense");
    const test::ChiSquareResult chi = test::ChiSquare(observed, expected);
    EXPECT_LT(chi.statistic, test::ChiSquareCritical(chi.dof, kFalseFailure)) << (sparse ? "sparse" : "dense");
    // ∫ over the support of 1 and of g, by the midpoint rule at 16 × 16 cells a bin (its error is far below the
    // means' standard errors, about 0.2%).
    double support = 0.0, integral = 0.0;
    const int sub = 16;
    const double cell = kFourPi / kGuideBins / (sub * sub);
    for (int row = 0; row < kGuideRows * sub; ++row)
      for (int column = 0; column < kGuideColumns * sub; ++column) {
        const int b = (row / sub) * kGuideColumns + column / sub;
        if (!(w[static_cast<size_t>(b)] > 0.0)) continue;
        const double z = -1.0 + 2.0 * (row + 0.5) / (kGuideRows * sub);
        const double phi = 2.0 * M_PI * (column + 0.5) / (kGuideColumns * sub), r = std::sqrt(1.0 - z * z);
        support += cell;
        integral += cell * g(Vec3(float(r * std::cos(phi)), float(z), float(r * std::sin(phi))));
      }
    EXPECT_LT(std::fabs(one.mean - support) / one.StdError(), tCritical) << one.mean << " against " << support;
    EXPECT_LT(std::fabs(varying.mean - integral) / varying.StdError(), tCritical)
        << varying.mean << " against " << integral;
  }
}

TEST(DirectionGuide, NoPositiveFiniteWeightIsEmpty) {
  std::vector<double> w(kGuideBins, 0.0);
  EXPECT_TRUE(DirectionGuide(w.data()).Empty());
  w[3] = -1.0;
  w[7] = std::nan("");
  w[9] = -std::numeric_limits<double>::infinity();
  EXPECT_TRUE(DirectionGuide(w.data()).Empty());
  EXPECT_EQ(DirectionGuide(w.data()).Pdf(Vec3(0, 1, 0)), 0.0f);
  EXPECT_TRUE(DirectionGuide().Empty());
  w[9] = 2.0;
  const DirectionGuide one(w.data());
  ASSERT_FALSE(one.Empty());
  // One bin: density bins / 4π inside it, 0 elsewhere.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < 1000; ++k) {
    const float u0 = u(rng), u1 = u(rng);
    const Vec3 d = one.Sample(u0, u1);
    EXPECT_EQ(GuideBin(d), 9);
    EXPECT_NEAR(one.Pdf(d), kGuideBins / kFourPi, 1e-3);
  }
}

}  // namespace
}  // namespace restir
