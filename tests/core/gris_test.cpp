#include "core/gris.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "core/reservoir.h"
#include "core/rng.h"
#include "stats.h"

namespace restir {
namespace {

constexpr MisFamily kAllFamilies[] = {MisFamily::kUniform, MisFamily::kZ, MisFamily::kBalance,
                                      MisFamily::kPairwise};


// ---------------------------------------------------------------------------------------------------------
// A 1-D toy problem with a closed-form integral. Domain y in [0, 1), source pdf uniform (p_src = 1). The
// integrand is f(y) = 1 + sin(3y) on [0, 0.7) and 0 on [0.7, 1), so I = ∫ f = 0.7 + (1 - cos 2.1) / 3.
// Four inputs, each a streaming-RIS reservoir with M_i candidates (confidence c_i = M_i) and its own target:
//   p̂_0(y) = 0.5 + y                                   (canonical, > 0 everywhere, so > 0 wherever f > 0)
//   p̂_1(y) = 0.3 + exp(-((y - 0.2) / 0.15)²)  on [0, 0.5), and 0 on [0.5, 1) when `restricted`
//   p̂_2(y) = 0.2 + exp(-((y - 0.7) / 0.2)²)
//   p̂_3(y) = 0.25 + |y - 0.35|                on [0.35, 1), and 0 on [0, 0.35) when `restricted`
// The restricted inputs cannot produce part of the region where f > 0. Every target is bounded away from 0 on
// its support, so every W has finite variance and the z-tests below are valid.
constexpr int kInputs = 4;
constexpr int kCandidates[kInputs] = {2, 3, 1, 4};

double Integrand(double y) { return y < 0.7 ? 1.0 + std::sin(3.0 * y) : 0.0; }
// ∫_a^b (1 + sin 3y) dy.
double F(double a, double b) { return (b - a) + (std::cos(3.0 * a) - std::cos(3.0 * b)) / 3.0; }

float ToyTarget(int j, float y, bool restricted) {
  switch (j) {
    case 0: return 0.5f + y;
    case 1: {
      const float d = (y - 0.2f) / 0.15f;
      return restricted && !(y < 0.5f) ? 0.0f : 0.3f + std::exp(-d * d);
    }
    case 2: {
      const float d = (y - 0.7f) / 0.2f;
      return 0.2f + std::exp(-d * d);
    }
    default: return restricted && y < 0.35f ? 0.0f : 0.25f + std::abs(y - 0.35f);
  }
}

// One RIS reservoir for input j: M_j uniform candidates streamed with w = p̂_j(y) / 1.
Reservoir ToyRis(int j, bool restricted, Sampler& s) {
  Reservoir r;
  for (int m = 0; m < kCandidates[j]; ++m) {
    LightSample cand;
    const float y = s.Next();
    cand.position = Vec3(y, 0.0f, 0.0f);
    cand.pdfArea = 1.0f;
    const float t = ToyTarget(j, y, restricted);
    StreamCandidate(r, cand, t, RisWeight(t, cand.pdfArea), s.Next());
  }
  FinalizeRis(r, static_cast<float>(kCandidates[j]));
  return r;
}

// Mean and standard error of the per-trial estimate f(Y)·W of GrisCombine over `n` independent trials.
test::RunningStats RunToy(MisFamily family, bool restricted, uint32_t seed, int n) {
  test::RunningStats st;
  for (int t = 0; t < n; ++t) {
    Sampler s(RngKey{seed, 0, static_cast<uint32_t>(t), 100});
    Reservoir res[kInputs];
    GrisInput in[kInputs];
    float ys[kInputs], u[kInputs];
    for (int i = 0; i < kInputs; ++i) {
      res[i] = ToyRis(i, restricted, s);
      ys[i] = res[i].sample.position.x;
      in[i] = GrisInput{res[i].HasSample(), res[i].W, res[i].confidence, 1.0f};
    }
    for (int i = 0; i < kInputs; ++i) u[i] = s.Next();
    auto target = [&](int j, int i) { return ToyTarget(j, ys[i], restricted); };
    const GrisResult r = GrisCombine(family, in, kInputs, target, u, VisibilityCarry::kSelected);
    EXPECT_EQ(r.guarded, 0);
    st.Add(r.selected >= 0 ? Integrand(ys[r.selected]) * r.W : 0.0);
  }
  return st;
}

constexpr int kToyTrials = 150000;

// Unbiasedness of GRIS for the z, balance and pairwise families: E[f(Y) W] = ∫ f over the support of p̂_0
// (= [0, 1), where every point can be produced by some input), both when two inputs' targets vanish on part
// of the domain and when all have full support. Test statistic: z = (mean − I) / s.e. over 150k independent
// trials; two-sided false-failure rate 1e-6 per (family, configuration).
TEST(Gris, CombineIsUnbiasedForZBalanceAndPairwise) {
  const double truth = F(0.0, 0.7);
  const double zCrit = test::NormalQuantileUpper(0.5e-6);
  uint32_t seed = 30;
  for (MisFamily family : {MisFamily::kZ, MisFamily::kBalance, MisFamily::kPairwise}) {
    for (bool restricted : {true, false}) {
      const test::RunningStats st = RunToy(family, restricted, seed++, kToyTrials);
      EXPECT_NEAR(st.mean, truth, zCrit * st.StdError())
          << MisFamilyName(family) << (restricted ? " restricted" : " full support") << " se=" << st.StdError();
    }
  }
}

// Uniform weights m_i = c_i / Σ c_j are unbiased when every input has full support (z-test as above,
// two-sided false-failure rate 1e-6), but biased when inputs 1 and 3 cannot produce part of the region
// where f > 0: then E[f(Y) W] = Σ_i c_i/C ∫_{supp p̂_i} f, which is
//   (c_0 + c_2)/C · F(0, 0.7) + c_1/C · F(0, 0.5) + c_3/C · F(0.35, 0.7)  <  I  (darkening).
// Assertions: (a) mean − I < −6 s.e. (the bias has the expected, negative sign; it is ≈ −0.32 = I − 0.877,
// about 160 s.e. of 0.002, so this assertion's false-failure rate is far below 1e-9); (b) the mean matches the biased expectation above
// (z-test, two-sided false-failure rate 1e-6).
TEST(Gris, UniformIsBiasedOnlyWhenSomeInputCannotProduceY) {
  const double truth = F(0.0, 0.7);
  const double zCrit = test::NormalQuantileUpper(0.5e-6);

  const test::RunningStats full = RunToy(MisFamily::kUniform, false, 40, kToyTrials);
  EXPECT_NEAR(full.mean, truth, zCrit * full.StdError()) << "se=" << full.StdError();

  const test::RunningStats restr = RunToy(MisFamily::kUniform, true, 41, kToyTrials);
  double cSum = 0.0;
  for (int c : kCandidates) cSum += c;
  const double biased = (kCandidates[0] + kCandidates[2]) / cSum * F(0.0, 0.7) +
                        kCandidates[1] / cSum * F(0.0, 0.5) + kCandidates[3] / cSum * F(0.35, 0.7);
  ASSERT_LT(biased, truth);
  EXPECT_LT(restr.mean - truth, -6.0 * restr.StdError()) << "mean=" << restr.mean << " truth=" << truth;
  EXPECT_NEAR(restr.mean, biased, zCrit * restr.StdError()) << "se=" << restr.StdError();
}

// ---------------------------------------------------------------------------------------------------------
// Deterministic cases.

// A fixed 3-input case: p̂_j(Y_i) = kT[j][i]. Input 1's domain cannot produce Y_2.
constexpr float kT[3][3] = {{1.5f, 0.8f, 2.0f}, {0.6f, 1.1f, 0.0f}, {0.9f, 0.4f, 1.7f}};
constexpr float kC[3] = {2.0f, 1.0f, 3.0f};
constexpr float kW[3] = {0.7f, 1.3f, 0.4f};
constexpr float kV[3] = {1.0f, 0.0f, 0.5f};

std::array<GrisInput, 3> FixedInputs() {
  std::array<GrisInput, 3> in;
  for (int i = 0; i < 3; ++i) in[i] = GrisInput{true, kW[i], kC[i], kV[i]};
  return in;
}
float FixedTarget(int j, int i) { return kT[j][i]; }

// w_i = m_i(Y_i) p̂_c(Y_i) W_i with m_i written out by hand (DESIGN §4) in double.
std::array<double, 3> HandWeights(MisFamily family) {
  const double cSum = kC[0] + kC[1] + kC[2], cc = kC[0], cBar = kC[1] + kC[2];
  std::array<double, 3> m{};
  switch (family) {
    case MisFamily::kUniform:
      for (int i = 0; i < 3; ++i) m[i] = kC[i] / cSum;
      break;
    case MisFamily::kZ:
      for (int i = 0; i < 3; ++i) m[i] = kC[i];  // 1/Z applied after selection
      break;
    case MisFamily::kBalance:
      for (int i = 0; i < 3; ++i) {
        double d = 0.0;
        for (int j = 0; j < 3; ++j) d += double(kC[j]) * kT[j][i];
        m[i] = kC[i] * double(kT[i][i]) / d;
      }
      break;
    default:  // pairwise, seed 004 Eq. 11
      m[0] = cc / cSum;
      for (int j = 1; j < 3; ++j)
        m[0] += kC[j] / cSum * cc * kT[0][0] / (cBar * kT[j][0] + cc * kT[0][0]);
      for (int i = 1; i < 3; ++i) m[i] = kC[i] / cSum * cBar * kT[i][i] / (cBar * kT[i][i] + cc * kT[0][i]);
      break;
  }
  std::array<double, 3> w{};
  for (int i = 0; i < 3; ++i) w[i] = m[i] * kT[0][i] * kW[i];
  return w;
}

// kWeighted carries V = Σ V_i w_i / Σ w_i (seed 000 Eq. 4) whatever sample is selected; weightSum and the
// contribution weight W = Σ w_i / p̂_c(Y_z) (with 1/Z for the z family) match the hand computation.
TEST(Gris, WeightedVisibilityIsWeightAverage) {
  const auto in = FixedInputs();
  for (MisFamily family : kAllFamilies) {
    const auto w = HandWeights(family);
    const double wSum = w[0] + w[1] + w[2];
    const double v = (kV[0] * w[0] + kV[1] * w[1] + kV[2] * w[2]) / wSum;
    for (int k = 0; k < 3; ++k) {
      float u[3];
      for (int j = 0; j < 3; ++j) u[j] = j == k ? 0.0f : 0.999f;  // selects input k
      const GrisResult r = GrisCombine(family, in.data(), 3, FixedTarget, u, VisibilityCarry::kWeighted);
      ASSERT_EQ(r.selected, k) << MisFamilyName(family);
      EXPECT_NEAR(r.weightSum, wSum, 1e-6 * wSum) << MisFamilyName(family);
      EXPECT_NEAR(r.visibility, v, 1e-6) << MisFamilyName(family) << " selected " << k;
      double z = 1.0;
      if (family == MisFamily::kZ) {
        z = 0.0;
        for (int j = 0; j < 3; ++j)
          if (kT[j][k] > 0.0f) z += kC[j];
      }
      const double wOut = wSum / z / kT[0][k];
      EXPECT_NEAR(r.W, wOut, 1e-6 * wOut) << MisFamilyName(family) << " selected " << k;
      EXPECT_FLOAT_EQ(r.confidence, kC[0] + kC[1] + kC[2]);
    }
  }
  // A spot value for pairwise, fully by hand: m = (97/148.5, 11/90, 17/54) = (0.6531987, 0.1222222, 0.3148148),
  // w = (0.6858586, 0.1271111, 0.2518519), V = (0.6858586 + 0.5 · 0.2518519) / 1.0648215 = 0.7623667.
  const float u[3] = {0.0f, 0.0f, 0.0f};
  const GrisResult r = GrisCombine(MisFamily::kPairwise, in.data(), 3, FixedTarget, u, VisibilityCarry::kWeighted);
  EXPECT_NEAR(r.weightSum, 1.0648215, 1e-6);
  EXPECT_NEAR(r.visibility, 0.7623667, 1e-6);
}

// kSelected carries V of the selected input.
TEST(Gris, SelectedVisibilityIsThatOfTheSelectedInput) {
  const auto in = FixedInputs();
  for (MisFamily family : kAllFamilies) {
    for (int k = 0; k < 3; ++k) {
      float u[3];
      for (int j = 0; j < 3; ++j) u[j] = j == k ? 0.0f : 0.999f;
      const GrisResult r = GrisCombine(family, in.data(), 3, FixedTarget, u, VisibilityCarry::kSelected);
      ASSERT_EQ(r.selected, k) << MisFamilyName(family);
      EXPECT_EQ(r.visibility, kV[k]) << MisFamilyName(family);
    }
  }
}

// Streaming selection picks input i with probability w_i / Σ w_i. Pearson chi-square over 3 bins from 200k
// trials with independent uniforms; false-failure rate 1e-6 per family.
TEST(Gris, SelectionFollowsResamplingWeightsChiSquare) {
  const auto in = FixedInputs();
  uint32_t seed = 50;
  for (MisFamily family : kAllFamilies) {
    const auto w = HandWeights(family);
    const double wSum = w[0] + w[1] + w[2];
    const int n = 200000;
    std::vector<double> obs(3, 0.0), exp(3);
    for (int i = 0; i < 3; ++i) exp[i] = n * w[i] / wSum;
    for (int t = 0; t < n; ++t) {
      Sampler s(RngKey{seed, 0, static_cast<uint32_t>(t), 100});
      const float u[3] = {s.Next(), s.Next(), s.Next()};
      const GrisResult r = GrisCombine(family, in.data(), 3, FixedTarget, u, VisibilityCarry::kSelected);
      ASSERT_GE(r.selected, 0);
      obs[r.selected] += 1;
    }
    ++seed;
    const auto res = test::ChiSquare(obs, exp);
    EXPECT_LT(res.statistic, test::ChiSquareCritical(res.dof, 1e-6)) << MisFamilyName(family);
  }
}

// Output confidence is Σ c_i, counting empty inputs and inputs with confidence but no usable sample.
TEST(Gris, OutputConfidenceIsSumOfInputConfidences) {
  GrisInput in[4] = {{true, 0.5f, 3.0f, 1.0f}, {false, 0.0f, 20.0f, 1.0f}, {true, 2.0f, 0.25f, 1.0f},
                     {true, 1.0f, 7.0f, 1.0f}};
  auto target = [](int j, int i) { return i == 3 ? 0.0f : 1.0f + 0.1f * j; };  // p̂_c(Y_3) = 0: skipped
  const float u[4] = {0.3f, 0.3f, 0.3f, 0.3f};
  for (MisFamily family : kAllFamilies) {
    const GrisResult r = GrisCombine(family, in, 4, target, u, VisibilityCarry::kWeighted);
    EXPECT_FLOAT_EQ(r.confidence, 3.0f + 20.0f + 0.25f + 7.0f) << MisFamilyName(family);
    EXPECT_NE(r.selected, 1) << MisFamilyName(family);
    EXPECT_NE(r.selected, 3) << MisFamilyName(family);
    EXPECT_EQ(r.guarded, 0);
  }
}

// When every input is empty (no sample, or W = 0) the output has no sample: selected = -1, W = 0, Σ w = 0,
// while the confidence is still Σ c_i.
TEST(Gris, AllEmptyInputsGiveNoSample) {
  const GrisInput in[3] = {{false, 0.0f, 1.0f, 1.0f}, {true, 0.0f, 5.0f, 1.0f}, {false, 3.0f, 2.0f, 1.0f}};
  int calls = 0;
  auto target = [&calls](int, int) { ++calls; return 1.0f; };
  const float u[3] = {0.0f, 0.0f, 0.0f};
  for (MisFamily family : kAllFamilies) {
    for (VisibilityCarry carry : {VisibilityCarry::kSelected, VisibilityCarry::kWeighted}) {
      const GrisResult r = GrisCombine(family, in, 3, target, u, carry);
      EXPECT_EQ(r.selected, -1) << MisFamilyName(family);
      EXPECT_EQ(r.W, 0.0f) << MisFamilyName(family);
      EXPECT_EQ(r.weightSum, 0.0f) << MisFamilyName(family);
      EXPECT_EQ(r.guarded, 0) << MisFamilyName(family);
      EXPECT_FLOAT_EQ(r.confidence, 8.0f) << MisFamilyName(family);
    }
  }
  EXPECT_EQ(calls, 0);  // no target (no ray) is evaluated for empty inputs
  // count = 1 with an empty canonical input.
  const GrisResult r = GrisCombine(MisFamily::kPairwise, in, 1, target, u, VisibilityCarry::kSelected);
  EXPECT_EQ(r.selected, -1);
  EXPECT_EQ(r.W, 0.0f);
}

// Reference for the guard tests: the same inputs with input 1 dropped (hasSample = false, confidence kept).
void ExpectGuardedAndSkipped(float badW) {
  auto in = FixedInputs();
  in[1].W = badW;
  auto ref = FixedInputs();
  ref[1].hasSample = false;
  const float u[3] = {0.5f, 0.0f, 0.999f};  // u[1] = 0 would select input 1 if it were kept
  for (MisFamily family : kAllFamilies) {
    const GrisResult r = GrisCombine(family, in.data(), 3, FixedTarget, u, VisibilityCarry::kWeighted);
    const GrisResult e = GrisCombine(family, ref.data(), 3, FixedTarget, u, VisibilityCarry::kWeighted);
    EXPECT_EQ(r.guarded, 1) << MisFamilyName(family) << " W=" << badW;
    EXPECT_NE(r.selected, 1) << MisFamilyName(family) << " W=" << badW;
    EXPECT_EQ(r.selected, e.selected) << MisFamilyName(family) << " W=" << badW;
    EXPECT_EQ(r.weightSum, e.weightSum) << MisFamilyName(family) << " W=" << badW;
    EXPECT_EQ(r.W, e.W) << MisFamilyName(family) << " W=" << badW;
    EXPECT_EQ(r.visibility, e.visibility) << MisFamilyName(family) << " W=" << badW;
    EXPECT_TRUE(std::isfinite(r.W) && std::isfinite(r.weightSum)) << MisFamilyName(family);
  }
}

// A non-finite W input (+Inf) is counted in `guarded` and skipped: the result equals combining without it.
TEST(Gris, InfiniteWInputIsGuardedAndSkipped) { ExpectGuardedAndSkipped(INFINITY); }

// The same for W = NaN (DESIGN §10: non-finite weights are dropped AND counted). GrisCombine's early
// `!(in[i].W > 0.0f)` test drops a NaN W silently, before the IsFiniteWeight guard can count it.
TEST(Gris, NanWInputIsGuardedAndSkipped) { ExpectGuardedAndSkipped(NAN); }

// A non-finite canonical target p̂_c(Y_i) = +Inf makes w_i non-finite: guarded and skipped in every family.
TEST(Gris, InfiniteTargetIsGuardedAndSkipped) {
  const auto in = FixedInputs();
  auto target = [](int j, int i) { return j == 0 && i == 2 ? INFINITY : kT[j][i]; };
  const float u[3] = {0.5f, 0.5f, 0.0f};
  for (MisFamily family : kAllFamilies) {
    const GrisResult r = GrisCombine(family, in.data(), 3, target, u, VisibilityCarry::kWeighted);
    EXPECT_EQ(r.guarded, 1) << MisFamilyName(family);
    EXPECT_NE(r.selected, 2) << MisFamilyName(family);
    EXPECT_TRUE(std::isfinite(r.W) && std::isfinite(r.weightSum)) << MisFamilyName(family);
  }
}

}  // namespace
}  // namespace restir
