#include "core/reservoir.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "core/rng.h"
#include "stats.h"

namespace restir {
namespace {

// A discrete toy problem: K "lights", a source pmf and a target. RIS over it has a selection pmf we can
// compute exactly by enumerating every ordered candidate tuple (K^M of them).
constexpr int kK = 4;
constexpr std::array<float, kK> kSource{0.1f, 0.2f, 0.3f, 0.4f};
constexpr std::array<float, kK> kTarget{4.0f, 0.0f, 1.0f, 2.5f};

int DrawSource(float u) {
  float c = 0;
  for (int k = 0; k < kK; ++k) {
    c += kSource[k];
    if (u < c) return k;
  }
  return kK - 1;
}

Reservoir RunRis(int m, Sampler& s) {
  Reservoir r;
  for (int j = 0; j < m; ++j) {
    const int k = DrawSource(s.Next());
    LightSample y;
    y.lightId = static_cast<uint32_t>(k);
    StreamCandidate(r, y, kTarget[k], RisWeight(kTarget[k], kSource[k]), s.Next());
  }
  FinalizeRis(r, static_cast<float>(m));
  return r;
}

std::array<double, kK> ExactRisPmf(int m) {
  std::array<double, kK> p{};
  std::vector<int> idx(m, 0);
  for (;;) {
    double prob = 1, wsum = 0;
    std::array<double, kK> wk{};
    for (int j = 0; j < m; ++j) {
      prob *= kSource[idx[j]];
      const double w = kTarget[idx[j]] / kSource[idx[j]];
      wsum += w;
      wk[idx[j]] += w;
    }
    if (wsum > 0)
      for (int k = 0; k < kK; ++k) p[k] += prob * wk[k] / wsum;
    int j = 0;
    while (j < m && ++idx[j] == kK) idx[j++] = 0;
    if (j == m) break;
  }
  return p;
}

TEST(Ris, FinalizeGivesWsumOverMTarget) {
  Reservoir r;
  LightSample y;
  StreamCandidate(r, y, 2.0f, 8.0f, 0.0f);
  FinalizeRis(r, 4.0f);
  EXPECT_FLOAT_EQ(r.W, 8.0f / (4.0f * 2.0f));
  EXPECT_FLOAT_EQ(r.confidence, 4.0f);
  Reservoir empty;
  FinalizeRis(empty, 4.0f);
  EXPECT_EQ(empty.W, 0.0f);
}

TEST(Ris, ZeroWeightCandidateNeverSelected) {
  Reservoir r;
  LightSample y;
  EXPECT_FALSE(StreamCandidate(r, y, 0.0f, 0.0f, 0.0f));
  EXPECT_EQ(r.weightSum, 0.0f);
}

// Selection pmf of streaming RIS equals the exact enumeration for M = 1, 2, 5 (an empty reservoir is one more
// outcome); M = 1 reproduces the source. Pearson chi-square, false-failure rate 1e-6 per M.
TEST(Ris, SelectionMatchesExactPmfChiSquare) {
  for (int m : {1, 2, 5}) {
    const auto exact = ExactRisPmf(m);
    if (m == 1) {
      for (int k = 0; k < kK; ++k) EXPECT_NEAR(exact[k], kTarget[k] > 0 ? kSource[k] : 0.0, 1e-7);
    }
    const int n = 400000;
    std::vector<double> obs(kK + 1, 0), exp(kK + 1);
    double mass = 0;
    for (int k = 0; k < kK; ++k) exp[k] = n * exact[k], mass += exact[k];
    exp[kK] = n * (1 - mass);
    for (int i = 0; i < n; ++i) {
      Sampler s(RngKey{1, static_cast<uint32_t>(m), static_cast<uint32_t>(i), 100});
      const Reservoir r = RunRis(m, s);
      obs[r.HasSample() ? r.sample.lightId : kK] += 1;
    }
    const auto res = test::ChiSquare(obs, exp);
    EXPECT_LT(res.statistic, test::ChiSquareCritical(res.dof, 1e-6)) << "M=" << m;
  }
}

// As M grows the selection pmf approaches the normalised target: the total variation distance falls
// monotonically from M = 2 on and is at least halved by M = 10 (the bias of RIS selection is O(1/M)).
TEST(Ris, SelectionApproachesTargetAsMGrows) {
  const double norm = 4.0 + 1.0 + 2.5;
  auto tvAt = [&](int m) {
    const auto p = ExactRisPmf(m);
    double tv = 0, mass = 0;
    for (int k = 0; k < kK; ++k) tv += 0.5 * std::abs(p[k] - kTarget[k] / norm), mass += p[k];
    return tv + 0.5 * (1 - mass);
  };
  double prev = tvAt(2);
  for (int m = 3; m <= 10; ++m) {
    const double tv = tvAt(m);
    EXPECT_LT(tv, prev) << "M=" << m;
    prev = tv;
  }
  EXPECT_LT(prev, 0.5 * tvAt(1));
}

// W is an unbiased contribution weight: E[W · 1{Y = k}] = 1 for every k with target > 0 (so E[W | Y] = 1/p(Y)).
// z-test per k, false-failure rate 1e-6 each.
TEST(Ris, ContributionWeightIsReciprocalPdfInExpectation) {
  const double z = test::NormalQuantileUpper(1e-6);
  for (int m : {1, 3, 16}) {
    std::array<test::RunningStats, kK> st;
    for (int i = 0; i < 300000; ++i) {
      Sampler s(RngKey{2, static_cast<uint32_t>(m), static_cast<uint32_t>(i), 100});
      const Reservoir r = RunRis(m, s);
      for (int k = 0; k < kK; ++k) st[k].Add(r.HasSample() && int(r.sample.lightId) == k ? r.W : 0.0);
    }
    for (int k = 0; k < kK; ++k) {
      if (kTarget[k] == 0) {
        EXPECT_EQ(st[k].mean, 0.0);
        continue;
      }
      EXPECT_NEAR(st[k].mean, 1.0, z * st[k].StdError()) << "M=" << m << " k=" << k;
    }
  }
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// The weight sum stays finite and accurate when candidate weights span 1e8 (tiny_bright's radiance range) and
// the candidates are many: streaming 1e5 log-uniform weights in [1e-4, 1e4] in float, the sum is within 1e-4
// (relative) of the double-precision sum, and W = wSum / (M p̂) stays finite and positive. The float
// accumulation error is bounded by M·eps ≈ 6e-3; 1e-4 is what the data allow (random rounding: ~sqrt(M)·eps).
TEST(Ris, WeightSumAccurateAcrossEightDecadesAndManyCandidates) {
  Sampler s(RngKey{5, 0, 0, 0});
  for (int m : {32, 1024, 100000}) {
    Reservoir r;
    double exact = 0.0;
    for (int j = 0; j < m; ++j) {
      const float w = std::pow(10.0f, -4.0f + 8.0f * s.Next());
      LightSample y;
      y.lightId = static_cast<uint32_t>(j);
      StreamCandidate(r, y, w, w, s.Next());  // p_src = 1: the weight is the target
      exact += w;
    }
    FinalizeRis(r, static_cast<float>(m));
    EXPECT_TRUE(std::isfinite(r.weightSum)) << m;
    EXPECT_NEAR(r.weightSum / exact, 1.0, 1e-4) << m;
    EXPECT_TRUE(std::isfinite(r.W) && r.W > 0.0f) << m;
  }
}

// A weight 1e8 times smaller than its rival is still selected with probability w / wSum to within the 2^-24
// resolution of u (the documented floor of the selection test).
TEST(Ris, TinyWeightBesideHugeOneKeepsItsShare) {
  Reservoir r;
  LightSample big, tiny;
  big.lightId = 0;
  tiny.lightId = 1;
  StreamCandidate(r, big, 1e4f, 1e4f, 0.5f);
  EXPECT_FALSE(StreamCandidate(r, tiny, 1e-4f, 1e-4f, 1e-7f));  // u wSum = 1e-3 > 1e-4: rejected
  EXPECT_TRUE(StreamCandidate(r, tiny, 1e-4f, 1e-4f, 5e-9f));   // u wSum = 5e-5 < 1e-4: selected
  EXPECT_EQ(r.sample.lightId, 1u);
}

}  // namespace
}  // namespace restir
