#include "core/alias_table.h"

#include <gtest/gtest.h>

#include "core/rng.h"
#include "stats.h"

namespace restir {
namespace {

TEST(AliasTable, PmfIsNormalisedWeights) {
  const std::vector<float> w{1, 0, 3, 4, 0.5f};
  AliasTable t(w);
  double sum = 0;
  for (uint32_t i = 0; i < t.Size(); ++i) {
    EXPECT_NEAR(t.Pmf(i), w[i] / 8.5, 1e-7);
    sum += t.Pmf(i);
  }
  EXPECT_NEAR(sum, 1.0, 1e-6);
}

TEST(AliasTable, AllZeroWeightsGiveEmptyTable) {
  EXPECT_TRUE(AliasTable(std::vector<float>{0, 0, 0}).Empty());
  EXPECT_TRUE(AliasTable(std::vector<float>{}).Empty());
}

TEST(AliasTable, NeverReturnsZeroWeightEntry) {
  std::vector<float> w(1000, 0.0f);
  for (int i = 0; i < 1000; i += 7) w[i] = 1.0f + static_cast<float>(i % 13);
  AliasTable t(w);
  for (int i = 0; i < 200000; ++i) {
    const RngKey key{1, 0, static_cast<uint32_t>(i), 100};
    const uint32_t k = t.Sample(UniformFloat(key, 0), UniformFloat(key, 1));
    ASSERT_GT(w[k], 0.0f) << k;
  }
}

// Samples follow the weights: Pearson chi-square over 64 entries spanning four decades, false-failure rate 1e-6.
TEST(AliasTable, SamplesFollowWeightsChiSquare) {
  std::vector<float> w(64);
  for (int i = 0; i < 64; ++i) w[i] = std::pow(10.0f, static_cast<float>(i % 5) - 2.0f) * (1 + i % 3);
  AliasTable t(w);
  const int n = 2000000;
  std::vector<double> obs(64, 0.0), exp(64);
  for (int i = 0; i < 64; ++i) exp[i] = n * t.Pmf(i);
  for (int i = 0; i < n; ++i) {
    const RngKey key{2, 0, static_cast<uint32_t>(i), 100};
    obs[t.Sample(UniformFloat(key, 0), UniformFloat(key, 1))] += 1;
  }
  const auto r = test::ChiSquare(obs, exp);
  EXPECT_LT(r.statistic, test::ChiSquareCritical(r.dof, 1e-6));
}

}  // namespace
}  // namespace restir
