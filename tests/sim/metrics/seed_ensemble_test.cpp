// Seed ensembles across sweep jobs: the relative-error file refuses damage, and the bias²/variance split is
// unbiased with intervals that cover at their stated rate on synthetic seeds whose true bias and variance are
// known (a Gaussian model written here, not the simulator's estimators).
#include "sim/metrics/seed_ensemble.h"

#include "sim/metrics/relative_error_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sim/metrics/metrics.h"

namespace restir {
namespace {

TEST(StudentT975, MatchesPublishedTable) {
  // Two-sided 5% critical values of Student's t (any statistics table, e.g. NIST/SEMATECH e-Handbook 1.3.6.7.2).
  EXPECT_NEAR(StudentT975(1), 12.706, 5e-4);
  EXPECT_NEAR(StudentT975(2), 4.303, 5e-4);
  EXPECT_NEAR(StudentT975(4), 2.776, 5e-4);
  EXPECT_NEAR(StudentT975(10), 2.228, 5e-4);
  EXPECT_NEAR(StudentT975(30), 2.042, 5e-4);
  EXPECT_TRUE(std::isnan(StudentT975(0)));
}

TEST(RelativeError, SquaresAverageToRelmse) {
  ImageRgb estimate(3, 2), reference(3, 2);
  for (size_t i = 0; i < estimate.Size(); ++i) {
    reference.pixels[i] = Vec3(0.0f, 0.05f * float(i), 30.0f + float(i));  // black, dark, bright
    estimate.pixels[i] = Vec3(0.2f, 0.3f * float(i), 1e3f / float(i + 1));
  }
  std::vector<float> e;
  AppendRelativeError(estimate, reference, e);
  ASSERT_EQ(e.size(), 18u);
  double sum = 0.0;
  for (float v : e) sum += double(v) * v;
  EXPECT_NEAR(sum / 18.0, MeasureAccuracy(estimate, reference).relmse, 1e-6 * MeasureAccuracy(estimate, reference).relmse);
  EXPECT_GT(e[0], 0.0f);  // signed: the estimate is above a black reference
}

TEST(RelativeErrorFile, RoundTripsAndRefusesDamage) {
  const std::vector<float> v = {0.5f, -1.0f, 3.0f, 0.0f, 2.0f, -7.0f};
  const std::string header = EncodeRelativeErrorHeader(2, 1, 4);
  const std::string frame = EncodeRelativeErrorFrame(v);
  std::string problem;
  EXPECT_TRUE(DecodeRelativeErrorHeader(header, 2, 1, 4, problem)) << problem;
  EXPECT_FALSE(DecodeRelativeErrorHeader(header, 2, 1, 5, problem));
  EXPECT_NE(problem.find("4 frames"), std::string::npos) << problem;
  EXPECT_FALSE(DecodeRelativeErrorHeader(header.substr(0, 10), 2, 1, 4, problem));
  std::vector<float> out;
  EXPECT_TRUE(DecodeRelativeErrorFrame(frame, 6, out, problem)) << problem;
  EXPECT_EQ(out, v);
  EXPECT_FALSE(DecodeRelativeErrorFrame(frame.substr(0, frame.size() - 1), 6, out, problem));
  for (size_t k = 0; k < frame.size(); ++k) {  // every flipped byte is caught
    std::string bad = frame;
    bad[k] = char(bad[k] ^ 0x10);
    EXPECT_FALSE(DecodeRelativeErrorFrame(bad, 6, out, problem)) << k;
  }
  std::vector<float> nan = v;
  nan[2] = NAN;
  EXPECT_FALSE(DecodeRelativeErrorFrame(EncodeRelativeErrorFrame(nan), 6, out, problem));
  EXPECT_EQ(problem, "a non-finite value");
  EXPECT_EQ(RelativeErrorFileSize(2, 1, 4), header.size() + 4 * frame.size());
}

struct Trial {
  double bias2, bias2Half, variance, varianceHalf;
};

// S seeds of F frames of N values: e = b_i + sigma_i z with b_i and sigma_i fixed per value (so the truth is
// bias² = mean b², variance = mean sigma²), scaled by `scale` to test tiny and huge errors.
Trial RunTrial(std::mt19937_64& rng, int seeds, int frames, int n, double b, double sigma, double scale,
               double referenceNoise) {
  std::normal_distribution<double> z(0.0, 1.0);
  SeedSplit split(seeds);
  std::vector<std::vector<float>> e(static_cast<size_t>(seeds), std::vector<float>(static_cast<size_t>(n)));
  std::vector<const float*> p;
  for (auto& v : e) p.push_back(v.data());
  for (int f = 0; f < frames; ++f) {
    for (int s = 0; s < seeds; ++s)
      for (int i = 0; i < n; ++i) {
        const double bi = b * (i % 2 ? 1.0 : -1.0), si = sigma * (0.5 + double(i % 3) / 2.0);
        e[size_t(s)][size_t(i)] = static_cast<float>(scale * (bi + si * z(rng)));
      }
    split.AddFrame(p, size_t(n), referenceNoise * scale * scale);
  }
  const SeedSplitResult r = split.Result();
  return {r.bias2 / (scale * scale), r.bias2Ci95 / (scale * scale), r.variance / (scale * scale),
          r.varianceCi95 / (scale * scale)};
}

// Unbiasedness on a grid of seed counts, bias levels, scales and reference noise: the mean of 300 trials' estimates
// against the truth by a z-test at |z| < 4.42 (two-sided false-failure rate 1e-5 per check, 48 checks: ~5e-4).
TEST(SeedSplit, BiasAndVarianceAreUnbiasedOnAGrid) {
  std::mt19937_64 rng(20261124);
  const double sigma = 0.3;
  const double trueVariance = sigma * sigma * (0.25 + 1.0 + 2.25) / 3.0;  // mean of (0.5, 1, 1.5)² sigma²
  for (int seeds : {2, 3, 8})
    for (double b : {0.0, 0.2})
      for (double scale : {1e-3, 1.0, 1e3})
        for (double noise : {0.0, 0.01}) {
          const int trials = 300;
          std::vector<double> bias2, variance;
          for (int t = 0; t < trials; ++t) {
            const Trial r = RunTrial(rng, seeds, 2, 24, b, sigma, scale, noise);
            // The reference noise n_R is subtracted as given: add it back to compare with the seeds' own bias².
            bias2.push_back(r.bias2 + noise);
            variance.push_back(r.variance);
          }
          auto z = [&](const std::vector<double>& x, double truth) {
            double m = 0.0, v = 0.0;
            for (double a : x) m += a / x.size();
            for (double a : x) v += (a - m) * (a - m) / (x.size() - 1);
            return (m - truth) / std::sqrt(v / x.size());
          };
          const std::string at = "S=" + std::to_string(seeds) + " b=" + std::to_string(b) +
                                 " scale=" + std::to_string(scale) + " noise=" + std::to_string(noise);
          EXPECT_LT(std::fabs(z(bias2, b * b)), 4.42) << at;
          EXPECT_LT(std::fabs(z(variance, trueVariance)), 4.42) << at;
        }
}

// The intervals cover the truth at close to their 95%: with 400 trials the observed rate's standard deviation is
// 0.011, so [0.90, 0.99] fails by chance with probability below 1e-4 for an exact 95% interval. Few seeds and many
// values per frame: the regime of a study (the jackknife of a near-linear statistic).
TEST(SeedSplit, IntervalsCoverAtTheirRate) {
  std::mt19937_64 rng(7);
  for (int seeds : {4, 8, 16}) {
    const double sigma = 0.3, b = 0.1;
    const double trueVariance = sigma * sigma * (0.25 + 1.0 + 2.25) / 3.0;
    int coverBias = 0, coverVariance = 0;
    const int trials = 400;
    for (int t = 0; t < trials; ++t) {
      const Trial r = RunTrial(rng, seeds, 3, 64, b, sigma, 1.0, 0.0);
      coverBias += std::fabs(r.bias2 - b * b) <= r.bias2Half;
      coverVariance += std::fabs(r.variance - trueVariance) <= r.varianceHalf;
    }
    EXPECT_GE(coverBias, 0.90 * trials) << seeds;
    EXPECT_LE(coverBias, 0.99 * trials) << seeds;
    EXPECT_GE(coverVariance, 0.90 * trials) << seeds;
    EXPECT_LE(coverVariance, 0.99 * trials) << seeds;
  }
}

// The reference's own error eta is shared by every seed (one reference): e_s = b + eta + sigma z_s. Given n_R =
// E eta² (what relmse − relmse_corrected estimates), bias2 stays unbiased for b² over trials that redraw eta; the
// jackknife cannot see eta (it is constant across seeds), so its intervals are conditional on the reference. Same
// z-test and rate as above.
TEST(SeedSplit, SharedReferenceNoiseIsTakenOutByItsExpectedSquare) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> z(0.0, 1.0);
  const int seeds = 4, n = 32, trials = 400;
  const double b = 0.15, sigma = 0.2, tau = 0.1;  // tau: the reference's standard error
  std::vector<double> bias2;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> eta(static_cast<size_t>(n));
    for (double& x : eta) x = tau * z(rng);
    std::vector<std::vector<float>> e(static_cast<size_t>(seeds), std::vector<float>(static_cast<size_t>(n)));
    std::vector<const float*> p;
    for (auto& v : e) p.push_back(v.data());
    for (int s = 0; s < seeds; ++s)
      for (int i = 0; i < n; ++i) e[size_t(s)][size_t(i)] = static_cast<float>(b + eta[size_t(i)] + sigma * z(rng));
    SeedSplit split(seeds);
    split.AddFrame(p, size_t(n), tau * tau);
    bias2.push_back(split.Result().bias2);
  }
  double m = 0.0, v = 0.0;
  for (double x : bias2) m += x / trials;
  for (double x : bias2) v += (x - m) * (x - m) / (trials - 1);
  EXPECT_LT(std::fabs(m - b * b) / std::sqrt(v / trials), 4.42) << m;
}

// The delete-one shortcuts (O(1) per seed from the seeds' sums) against the jackknife recomputed by brute force:
// S splits of S − 1 seeds each.
TEST(SeedSplit, JackknifeMatchesDeleteOneRecomputation) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> z(0.0, 1.0);
  for (int seeds : {3, 5, 9}) {
    const int n = 40, frames = 3;
    std::vector<std::vector<std::vector<float>>> e(static_cast<size_t>(frames));
    for (auto& frame : e) {
      frame.assign(static_cast<size_t>(seeds), std::vector<float>(static_cast<size_t>(n)));
      for (auto& seed : frame)
        for (float& x : seed) x = static_cast<float>(0.3 + 0.5 * z(rng));
    }
    auto run = [&](int without) {
      SeedSplit split(without < 0 ? seeds : seeds - 1);
      for (int f = 0; f < frames; ++f) {
        std::vector<const float*> p;
        for (int s = 0; s < seeds; ++s)
          if (s != without) p.push_back(e[size_t(f)][size_t(s)].data());
        split.AddFrame(p, size_t(n), 0.002);
      }
      return split.Result();
    };
    const SeedSplitResult all = run(-1);
    std::vector<double> b, v;
    for (int k = 0; k < seeds; ++k) {
      const SeedSplitResult r = run(k);
      b.push_back(r.bias2);
      v.push_back(r.variance);
    }
    auto half = [&](const std::vector<double>& x) {
      double m = 0.0, ss = 0.0;
      for (double a : x) m += a / seeds;
      for (double a : x) ss += (a - m) * (a - m);
      return StudentT975(seeds - 1) * std::sqrt(double(seeds - 1) / seeds * ss);
    };
    EXPECT_NEAR(all.varianceCi95, half(v), 1e-9 + 1e-6 * half(v)) << seeds;
    EXPECT_NEAR(all.bias2Ci95, half(b), 1e-9 + 1e-6 * half(b)) << seeds;
  }
}

TEST(SeedSplit, TwoSeedsHaveNoIntervalOneSeedNoSplit) {
  std::mt19937_64 rng(1);
  const Trial two = RunTrial(rng, 2, 1, 8, 0.1, 0.1, 1.0, 0.0);
  EXPECT_TRUE(std::isfinite(two.bias2) && std::isfinite(two.variance));
  EXPECT_TRUE(std::isnan(two.bias2Half) && std::isnan(two.varianceHalf));
  SeedSplit one(1);
  const float x = 1.0f;
  one.AddFrame({&x}, 1, 0.0);
  EXPECT_TRUE(std::isnan(one.Result().bias2));
}

}  // namespace
}  // namespace restir
