#include "core/spmis.h"

#include <gtest/gtest.h>

#include <vector>

#include "core/rng.h"
#include "stats.h"

namespace restir {
namespace {

// A fixed cell: M candidates with confidences, contributions (for P(i)) and targets.
struct CellFixture {
  std::vector<float> c{3, 1, 2, 5, 4, 1};          // c_j
  std::vector<float> contribution{2, 0, 1, 6, 3, 0.5f};  // c_j p̂_j(X_j) W_j (Eq. 17)
  std::vector<float> targetOwn{1.5f, 0, 0.7f, 2.0f, 0.9f, 0.3f};  // p̂_j(Y_j)
  std::vector<float> targetCAtYj{0.8f, 0, 1.1f, 0.2f, 0.6f, 1.4f};  // p̂_c(Y_j)
  std::vector<float> targetJAtYc{0.4f, 0.9f, 0.0f, 1.2f, 0.5f, 0.7f};  // p̂_j(Y_c)
  float cc = 2.0f, targetC = 1.0f;  // canonical confidence and p̂_c(Y_c)
  int M() const { return static_cast<int>(c.size()); }
  float CBar(float scale) const {
    float s = 0;
    for (float v : c) s += v * scale;
    return s;
  }
  float P(int i) const {
    float s = 0;
    for (float v : contribution) s += v;
    return contribution[i] / s;
  }
};

// With N = M and every candidate drawn exactly once (K = 1, P = 1/M, no confidence scaling since N/M = 1), the
// stochastic weights equal deterministic pairwise MIS.
TEST(StochasticPairwise, EveryCandidateOnceReducesToPairwise) {
  const CellFixture f;
  const float m = static_cast<float>(f.M()), cBar = f.CBar(1.0f);
  float canonical = MisPairwiseCanonicalBase(cBar, f.cc), canonicalDet = canonical;
  for (int j = 0; j < f.M(); ++j) {
    const float stochastic =
        StochasticPairwiseNonCanonical(1, m, 1 / m, f.c[j], cBar, f.cc, f.targetOwn[j], f.targetCAtYj[j]);
    const float det = MisPairwiseNonCanonical(f.c[j], cBar, f.cc, f.targetOwn[j], f.targetCAtYj[j]);
    EXPECT_NEAR(stochastic, det, 1e-6f * (1 + det)) << j;
    canonical += StochasticPairwiseCanonicalTerm(1, m, 1 / m, f.c[j], cBar, f.cc, f.targetJAtYc[j], f.targetC);
    canonicalDet += MisPairwiseCanonicalTerm(f.c[j], cBar, f.cc, f.targetJAtYc[j], f.targetC);
  }
  EXPECT_NEAR(canonical, canonicalDet, 1e-6f);
  EXPECT_FLOAT_EQ(ScaledConfidence(3.0f, m, m), 3.0f);
}

// Seed 004 §4.3's N/M, capped at 1 when N > M (issue 39): scaled, a cell never counts more than its Σ c.
TEST(StochasticPairwise, ConfidenceScaleIsCappedAtOne) {
  EXPECT_FLOAT_EQ(ConfidenceScale(3.0f, 8.0f), 0.375f);
  EXPECT_EQ(ConfidenceScale(8.0f, 8.0f), 1.0f);
  EXPECT_EQ(ConfidenceScale(10.0f, 3.0f), 1.0f);
  EXPECT_EQ(ConfidenceScale(5.0f, 0.0f), 1.0f);
  for (int m = 1; m <= 40; ++m)
    for (int n = 1; n <= 15; ++n) EXPECT_LE(ScaledConfidence(2.0f, float(n), float(m)) * float(m), 2.0f * m);
}

// E[m̃_i] = m_i: N = 3 draws with replacement by P(i) ∝ contribution, repeated 200,000 times; per candidate a
// z-test of the mean stochastic weight against the deterministic one (false-failure rate 1e-6 each). Same for
// the canonical weight with N_c = 2 uniform draws. Confidences scaled by N/M as the estimator does.
TEST(StochasticPairwise, WeightsAreUnbiasedEstimatesOfPairwise) {
  const CellFixture f;
  const int n = 3, nc = 2, trials = 200000;
  const float m = static_cast<float>(f.M()), scale = n / m, cBar = f.CBar(scale);
  std::vector<float> cum(f.M());
  float run = 0;
  for (int j = 0; j < f.M(); ++j) cum[j] = run += f.contribution[j];
  std::vector<test::RunningStats> stats(f.M());
  test::RunningStats canonicalStats;
  for (int t = 0; t < trials; ++t) {
    Sampler s(RngKey{9, 0, static_cast<uint32_t>(t), 100});
    std::vector<float> k(f.M(), 0.0f), kc(f.M(), 0.0f);
    for (int d = 0; d < n; ++d) k[SampleCumulative(cum.data(), f.M(), s.Next())] += 1;
    for (int d = 0; d < nc; ++d) kc[std::min(f.M() - 1, static_cast<int>(s.Next() * m))] += 1;
    float canonical = MisPairwiseCanonicalBase(cBar, f.cc);
    for (int j = 0; j < f.M(); ++j) {
      stats[j].Add(k[j] > 0 ? StochasticPairwiseNonCanonical(k[j], n, f.P(j), f.c[j] * scale, cBar, f.cc,
                                                             f.targetOwn[j], f.targetCAtYj[j])
                            : 0.0);
      if (kc[j] > 0)
        canonical += StochasticPairwiseCanonicalTerm(kc[j], nc, 1 / m, f.c[j] * scale, cBar, f.cc, f.targetJAtYc[j],
                                                     f.targetC);
    }
    canonicalStats.Add(canonical);
  }
  const double z = test::NormalQuantileUpper(0.5e-6);
  for (int j = 0; j < f.M(); ++j) {
    const double det = MisPairwiseNonCanonical(f.c[j] * scale, cBar, f.cc, f.targetOwn[j], f.targetCAtYj[j]);
    if (f.P(j) == 0) {
      // A candidate that cannot be drawn must be one whose weight never matters: no contribution.
      EXPECT_EQ(stats[j].mean, 0.0);
      continue;
    }
    EXPECT_NEAR(stats[j].mean, det, z * stats[j].StdError() + 1e-7) << j;
  }
  double canonicalDet = MisPairwiseCanonicalBase(cBar, f.cc);
  for (int j = 0; j < f.M(); ++j)
    canonicalDet += MisPairwiseCanonicalTerm(f.c[j] * scale, cBar, f.cc, f.targetJAtYc[j], f.targetC);
  EXPECT_NEAR(canonicalStats.mean, canonicalDet, z * canonicalStats.StdError());
}

TEST(StochasticPairwise, SampleCumulativeSkipsZeroProbabilityEntries) {
  const std::vector<float> cum{0, 2, 2, 2, 5, 5};
  for (int t = 0; t < 10000; ++t) {
    const int i = SampleCumulative(cum.data(), 6, UniformFloat(RngKey{1, 0, static_cast<uint32_t>(t), 100}, 0));
    EXPECT_TRUE(i == 1 || i == 4) << i;
  }
}

TEST(StochasticPairwise, NormalQuantisationSeparatesOrientations) {
  const uint32_t bins = 4;
  const Vec3 dirs[] = {Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, -1)};
  for (size_t a = 0; a < 6; ++a) {
    EXPECT_LT(QuantiseNormal(dirs[a], bins), bins * bins);
    EXPECT_EQ(QuantiseNormal(dirs[a], bins), QuantiseNormal(glm::normalize(dirs[a] + Vec3(0.01f, 0.0f, 0.01f)), bins));
    for (size_t b = a + 1; b < 6; ++b) EXPECT_NE(QuantiseNormal(dirs[a], bins), QuantiseNormal(dirs[b], bins));
  }
  EXPECT_NE(CellKey(1, 2, 3), CellKey(1, 2, 4));
  EXPECT_NE(CellKey(1, 2, 3), CellKey(2, 2, 3));
}

}  // namespace
}  // namespace restir
