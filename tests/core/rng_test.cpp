#include "core/rng.h"

#include <gtest/gtest.h>

#include <vector>

#include "stats.h"

namespace restir {
namespace {

// False-failure rate of each statistical test in this file: 1e-6 (fixed keys make outcomes deterministic).
constexpr double kTail = 1e-6;

TEST(Rng, SameKeySameNumber) {
  const RngKey key{7, 3, 12345, static_cast<uint32_t>(RngPass::kInitial)};
  for (uint32_t d = 0; d < 100; ++d) EXPECT_EQ(RandomBits(key, d), RandomBits(key, d));
  Sampler a(key), b(key);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a.Next(), b.Next());
}

TEST(Rng, UnitFloatInHalfOpenInterval) {
  EXPECT_EQ(BitsToUnitFloat(0u), 0.0f);
  EXPECT_LT(BitsToUnitFloat(0xFFFFFFFFu), 1.0f);
}

// Uniformity: 1,000,000 numbers over consecutive pixels into 1000 bins, Pearson chi-square.
TEST(Rng, UniformOverPixelsChiSquare) {
  const int bins = 1000, n = 1000000;
  std::vector<double> obs(bins, 0.0), exp(bins, double(n) / bins);
  for (int i = 0; i < n; ++i) {
    const float u = UniformFloat(RngKey{1, 0, static_cast<uint32_t>(i), 1}, 0);
    obs[static_cast<int>(u * bins)] += 1;
  }
  const auto r = test::ChiSquare(obs, exp);
  EXPECT_LT(r.statistic, test::ChiSquareCritical(r.dof, kTail));
}

// Uniformity along each other key field: dimension, frame, seed and pass.
TEST(Rng, UniformOverEveryKeyFieldChiSquare) {
  const int bins = 256, n = 256000;
  for (int field = 0; field < 4; ++field) {
    std::vector<double> obs(bins, 0.0), exp(bins, double(n) / bins);
    for (int i = 0; i < n; ++i) {
      RngKey key{5, 9, 77, 2};
      uint32_t dim = 3;
      const uint32_t v = static_cast<uint32_t>(i);
      if (field == 0) dim = v % (1u << 20);
      if (field == 1) key.frame = v;
      if (field == 2) key.seed = v;
      if (field == 3) key.pass = v % 4096, dim = v / 4096;
      obs[static_cast<int>(UniformFloat(key, dim) * bins)] += 1;
    }
    const auto r = test::ChiSquare(obs, exp);
    EXPECT_LT(r.statistic, test::ChiSquareCritical(r.dof, kTail)) << "field " << field;
  }
}

// Independence: pairs (u(key), u(key')) for keys differing in one field fill a 32x32 grid uniformly. Serial
// correlation between neighbouring pixels or dimensions would pile the pairs near the diagonal.
TEST(Rng, IndependentAcrossNeighbouringKeysChiSquare) {
  const int side = 32, n = 400000;
  for (int field = 0; field < 5; ++field) {
    std::vector<double> obs(side * side, 0.0), exp(side * side, double(n) / (side * side));
    for (int i = 0; i < n; ++i) {
      RngKey a{11, 4, static_cast<uint32_t>(i), 1};
      RngKey b = a;
      uint32_t da = 0, db = 0;
      if (field == 0) b.pixel += 1;
      if (field == 1) b.frame += 1;
      if (field == 2) b.seed += 1;
      if (field == 3) b.pass += 1;
      if (field == 4) db = 1;
      const int x = static_cast<int>(UniformFloat(a, da) * side);
      const int y = static_cast<int>(UniformFloat(b, db) * side);
      obs[y * side + x] += 1;
    }
    const auto r = test::ChiSquare(obs, exp);
    EXPECT_LT(r.statistic, test::ChiSquareCritical(r.dof, kTail)) << "field " << field;
  }
}

// Correlation coefficient of neighbouring draws is within 5 standard errors of 0 (1/sqrt(n) each).
TEST(Rng, NeighbouringDimensionsUncorrelated) {
  const int n = 200000;
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (int i = 0; i < n; ++i) {
    const RngKey key{3, 1, static_cast<uint32_t>(i), 1};
    const double x = UniformFloat(key, 0), y = UniformFloat(key, 1);
    sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
  }
  const double cov = sxy / n - (sx / n) * (sy / n);
  const double rho = cov / std::sqrt((sxx / n - (sx / n) * (sx / n)) * (syy / n - (sy / n) * (sy / n)));
  EXPECT_LT(std::abs(rho), 5.0 / std::sqrt(double(n)));
}

}  // namespace
}  // namespace restir
