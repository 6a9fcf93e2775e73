#include "core/mis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.h"

namespace restir {
namespace {

// Property tests: every MIS family of DESIGN §4 is a partition of unity over the inputs at one point y.
// Each case draws k in [2, 8] inputs with random confidences c_j (exact zeros, ordinary values in (0, 20) and
// large ones up to 1000) and random targets p̂_j(y) spanning six decades, with exact zeros for some j. Input 0
// is the canonical one. These are deterministic property checks (not Monte Carlo): there is no false-failure
// rate, only float rounding, which the 1e-5 tolerance covers with a wide margin.
constexpr int kCases = 5000;
constexpr float kTol = 1e-5f;

struct MisCase {
  int k = 0;
  std::vector<float> c;  // confidences c_j
  std::vector<float> t;  // targets p̂_j(y), t[0] = p̂_c(y)
};

MisCase DrawCase(uint32_t i) {
  Sampler s(RngKey{7, 0, i, 100});
  MisCase mc;
  mc.k = 2 + static_cast<int>(s.NextBits() % 7u);  // 2..8
  for (int j = 0; j < mc.k; ++j) {
    const float uc = s.Next();
    float c = 0.0f;
    if (uc < 0.15f) c = 0.0f;                                 // an input with no confidence
    else if (uc < 0.3f) c = 1.0f + 999.0f * s.Next();         // large: up to 1000
    else c = 20.0f * s.Next() + 1e-3f;                        // ordinary
    const float ut = s.Next();
    const float t = ut < 0.3f ? 0.0f : std::pow(10.0f, -3.0f + 6.0f * s.Next());  // exact zeros, 1e-3..1e3
    mc.c.push_back(c);
    mc.t.push_back(t);
  }
  return mc;
}

float Sum(const std::vector<float>& v) {
  float s = 0.0f;
  for (float x : v) s += x;
  return s;
}

// uniform: m_i = c_i / Σ_j c_j. Precondition: Σ_j c_j > 0. Note it sums to 1 over ALL inputs, including those
// with p̂_j(y) = 0 that cannot produce y; this is why the family is biased (checked in gris_test.cpp).
TEST(Mis, UniformIsPartitionOfUnityOverAllInputs) {
  int checked = 0;
  for (uint32_t n = 0; n < kCases; ++n) {
    const MisCase mc = DrawCase(n);
    const float cSum = Sum(mc.c);
    double sum = 0.0;
    for (int i = 0; i < mc.k; ++i) {
      const float m = MisUniform(mc.c[i], cSum);
      ASSERT_GE(m, 0.0f);
      ASSERT_LE(m, 1.0f + kTol);
      sum += m;
    }
    if (!(cSum > 0.0f)) {
      EXPECT_EQ(sum, 0.0) << "case " << n;  // outside the precondition every weight is 0
      continue;
    }
    ++checked;
    ASSERT_NEAR(sum, 1.0, kTol) << "case " << n;
  }
  EXPECT_GT(checked, kCases * 9 / 10);
}

// z (Bitterli 2020) by its definition: m_i(y) = c_i / Z(y) for inputs with p̂_i(y) > 0, else 0, where
// Z(y) = Σ_{j: p̂_j(y) > 0} c_j (GrisCombine's kZ branch). Precondition: Z(y) > 0. It sums to 1 over the
// inputs that can produce y.
TEST(Mis, ZIsPartitionOfUnityOverInputsThatCanProduceY) {
  int checked = 0;
  for (uint32_t n = 0; n < kCases; ++n) {
    const MisCase mc = DrawCase(n);
    float z = 0.0f;
    for (int j = 0; j < mc.k; ++j)
      if (mc.t[j] > 0.0f) z += mc.c[j];
    if (!(z > 0.0f)) continue;
    ++checked;
    double sum = 0.0;
    for (int i = 0; i < mc.k; ++i) {
      const float m = mc.t[i] > 0.0f ? mc.c[i] / z : 0.0f;
      ASSERT_GE(m, 0.0f);
      ASSERT_LE(m, 1.0f + kTol);
      sum += m;
    }
    ASSERT_NEAR(sum, 1.0, kTol) << "case " << n;
  }
  EXPECT_GT(checked, kCases / 2);
}

// Generalized balance heuristic (seed 000 Eq. 3). Precondition: Σ_j c_j p̂_j(y) > 0. An input with
// p̂_i(y) = 0 (it cannot produce y) gets weight exactly 0; outside the precondition every weight is 0.
TEST(Mis, BalanceIsPartitionOfUnityAndZeroWhereTargetIsZero) {
  int checked = 0, zeroTargets = 0;
  for (uint32_t n = 0; n < kCases; ++n) {
    const MisCase mc = DrawCase(n);
    float denom = 0.0f;
    for (int j = 0; j < mc.k; ++j) denom += mc.c[j] * mc.t[j];
    double sum = 0.0;
    for (int i = 0; i < mc.k; ++i) {
      const float m = MisBalance(i, mc.c.data(), mc.t.data(), mc.k);
      ASSERT_GE(m, 0.0f) << "case " << n;
      ASSERT_LE(m, 1.0f + kTol) << "case " << n;
      if (mc.t[i] == 0.0f) {
        ASSERT_EQ(m, 0.0f) << "case " << n << " input " << i;
        ++zeroTargets;
      }
      sum += m;
    }
    if (!(denom > 0.0f)) {
      EXPECT_EQ(sum, 0.0) << "case " << n;
      continue;
    }
    ++checked;
    ASSERT_NEAR(sum, 1.0, kTol) << "case " << n;
  }
  EXPECT_GT(checked, kCases / 2);
  EXPECT_GT(zeroTargets, kCases / 2);
}

// Defensive pairwise (seed 004 Eq. 11a/11b) with canonical input 0 and c̄ = Σ_{i≠0} c_i. Precondition:
// c̄ + c_c > 0 (whatever the targets, even p̂_c(y) = 0: a pair where neither side can produce y gives its
// mass to the canonical input). Non-canonical inputs with p̂_i(y) = 0 get weight 0.
TEST(Mis, PairwiseCanonicalAndNonCanonicalIsPartitionOfUnity) {
  int checked = 0;
  for (uint32_t n = 0; n < kCases; ++n) {
    const MisCase mc = DrawCase(n);
    const float cc = mc.c[0];
    float cBar = 0.0f;
    for (int j = 1; j < mc.k; ++j) cBar += mc.c[j];
    const float tc = mc.t[0];
    float mc0 = MisPairwiseCanonicalBase(cBar, cc);
    double sum = 0.0;
    for (int i = 1; i < mc.k; ++i) {
      const float m = MisPairwiseNonCanonical(mc.c[i], cBar, cc, mc.t[i], tc);
      ASSERT_GE(m, 0.0f) << "case " << n;
      ASSERT_LE(m, 1.0f + kTol) << "case " << n;
      if (mc.t[i] == 0.0f) {
        ASSERT_EQ(m, 0.0f) << "case " << n;
      }
      const float term = MisPairwiseCanonicalTerm(mc.c[i], cBar, cc, mc.t[i], tc);
      ASSERT_GE(term, 0.0f);
      mc0 += term;
      sum += m;
    }
    ASSERT_GE(mc0, 0.0f) << "case " << n;
    ASSERT_LE(mc0, 1.0f + kTol) << "case " << n;
    sum += mc0;
    if (!(cBar + cc > 0.0f)) {
      EXPECT_EQ(sum, 0.0) << "case " << n;
      continue;
    }
    ++checked;
    ASSERT_NEAR(sum, 1.0, kTol) << "case " << n;
  }
  EXPECT_GT(checked, kCases * 9 / 10);
}

// The same pairwise check with the canonical target forced to 0 and to strictly positive values, so both
// branches of the canonical term (denominator zero or not) are exercised whatever the random draw gives.
TEST(Mis, PairwiseIsPartitionOfUnityWithZeroAndPositiveCanonicalTarget) {
  for (uint32_t n = 0; n < kCases; ++n) {
    MisCase mc = DrawCase(n);
    for (float tc : {0.0f, 1e-3f, 1.0f, 1e3f}) {
      mc.t[0] = tc;
      const float cc = mc.c[0];
      float cBar = 0.0f;
      for (int j = 1; j < mc.k; ++j) cBar += mc.c[j];
      if (!(cBar + cc > 0.0f)) continue;
      double sum = MisPairwiseCanonicalBase(cBar, cc);
      for (int i = 1; i < mc.k; ++i)
        sum += MisPairwiseNonCanonical(mc.c[i], cBar, cc, mc.t[i], tc) +
               MisPairwiseCanonicalTerm(mc.c[i], cBar, cc, mc.t[i], tc);
      ASSERT_NEAR(sum, 1.0, kTol) << "case " << n << " p̂_c=" << tc;
    }
  }
}

// k = 2 with equal confidences c: seed 004 Eq. 11 reduces to m_1(y) = ½ p̂_1 / (p̂_1 + p̂_c) and
// m_c(y) = ½ + ½ p̂_c / (p̂_1 + p̂_c). Compared with that closed form computed by hand in double.
TEST(Mis, PairwiseReducesToClosedFormForTwoEqualInputs) {
  for (uint32_t n = 0; n < 2000; ++n) {
    Sampler s(RngKey{8, 0, n, 100});
    const float c = n % 3 == 0 ? 1.0f : (n % 3 == 1 ? 3.5f : 1000.0f * s.Next() + 1e-2f);
    const float t1 = n % 11 == 0 ? 0.0f : std::pow(10.0f, -3.0f + 6.0f * s.Next());
    const float tc = n % 13 == 0 ? 0.0f : std::pow(10.0f, -3.0f + 6.0f * s.Next());
    // Closed form in double (both targets zero: the defensive convention gives everything to the canonical).
    const double d1 = t1, dc = tc;
    const double m1 = d1 + dc > 0 ? 0.5 * d1 / (d1 + dc) : 0.0;
    const double mC = d1 + dc > 0 ? 0.5 + 0.5 * dc / (d1 + dc) : 1.0;
    const float cBar = c, cc = c;
    const float got1 = MisPairwiseNonCanonical(c, cBar, cc, t1, tc);
    const float gotC = MisPairwiseCanonicalBase(cBar, cc) + MisPairwiseCanonicalTerm(c, cBar, cc, t1, tc);
    EXPECT_NEAR(got1, m1, 1e-6 * std::max(1.0, m1)) << "c=" << c << " p1=" << t1 << " pc=" << tc;
    EXPECT_NEAR(gotC, mC, 1e-6 * std::max(1.0, mC)) << "c=" << c << " p1=" << t1 << " pc=" << tc;
  }
  // Hand-checked values: p̂_1 = 1, p̂_c = 3 gives m_1 = 1/8, m_c = 7/8.
  EXPECT_FLOAT_EQ(MisPairwiseNonCanonical(2.0f, 2.0f, 2.0f, 1.0f, 3.0f), 0.125f);
  EXPECT_FLOAT_EQ(MisPairwiseCanonicalBase(2.0f, 2.0f) + MisPairwiseCanonicalTerm(2.0f, 2.0f, 2.0f, 1.0f, 3.0f),
                  0.875f);
}

// Unequal confidences against Eq. 11 written out directly in double for k = 3 (c̄ = c_1 + c_2).
TEST(Mis, PairwiseMatchesEquation11InDouble) {
  const double c[3] = {4.0, 1.0, 7.0}, t[3] = {0.8, 2.5, 0.3};  // t[0] = p̂_c(y)
  const double cBar = c[1] + c[2], tot = cBar + c[0];
  double mC = c[0] / tot;
  for (int i = 1; i < 3; ++i) {
    const double mi = c[i] / tot * cBar * t[i] / (cBar * t[i] + c[0] * t[0]);
    mC += c[i] / tot * c[0] * t[0] / (cBar * t[i] + c[0] * t[0]);
    EXPECT_NEAR(MisPairwiseNonCanonical(float(c[i]), float(cBar), float(c[0]), float(t[i]), float(t[0])), mi,
                1e-6);
  }
  float got = MisPairwiseCanonicalBase(float(cBar), float(c[0]));
  for (int i = 1; i < 3; ++i)
    got += MisPairwiseCanonicalTerm(float(c[i]), float(cBar), float(c[0]), float(t[i]), float(t[0]));
  EXPECT_NEAR(got, mC, 1e-6);
}

TEST(Mis, NonFiniteWeightsAreDetected) {
  EXPECT_TRUE(IsFiniteWeight(0.0f));
  EXPECT_TRUE(IsFiniteWeight(3.0f));
  EXPECT_FALSE(IsFiniteWeight(INFINITY));
  EXPECT_FALSE(IsFiniteWeight(-INFINITY));
  EXPECT_FALSE(IsFiniteWeight(NAN));
}

}  // namespace
}  // namespace restir
