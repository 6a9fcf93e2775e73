// The error metrics' intervals (docs/metrics.md, "Intervals"): the per-frame *_ref_sd columns (the delta method)
// against the metrics' actual spread over many references drawn around a known true image, and the run-level
// interval (summary.h ColumnInterval) against hand-computed cases and its coverage on frames whose mean is known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "sim/metrics/compare.h"
#include "sim/metrics/metrics.h"
#include "sim/metrics/summary.h"

namespace restir {
namespace {

struct NoiseCase {
  double scale;       // typical radiance: 0.05 puts relmse's 0.01 in its denominator to work, 1 and 200 do not
  double refError;    // the reference's relative standard error per channel
  double estimateError;  // the estimate's relative error per pixel (and a 5% bias)
};

// The delta method's standard deviation of rmse, luma_rmse, relmse and rmspe, computed once at the true image,
// against their sample standard deviation over kDraws references R̂ = T + noise (the channels' noise correlated, as
// one light sample feeds all three, with se and se_Y exact). The sample standard deviation of kDraws = 400 normal-ish
// draws has a relative standard error of 1/sqrt(2 · 399) = 3.5%; the bound 0.8–1.2 is 5.7 of them, on top of the
// delta method's own second-order error, which the small reference errors (1–4%) keep to a few percent. 3 scales ×
// 2 reference errors × 2 estimates × 4 metrics = 48 checks: family-wise false-failure rate below 1e-6.
TEST(ReferenceSd, IsTheSpreadOfEachMetricOverReferencesDrawnAroundTheTruth) {
  constexpr int kW = 40, kH = 25, kDraws = 400;
  std::mt19937_64 rng(40);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.2, 1.8);
  for (const double scale : {0.05, 1.0, 200.0})
    for (const double refError : {0.01, 0.04})
      for (const double estimateError : {0.1, 0.5}) {
        ImageRgb truth(kW, kH), estimate(kW, kH), se(kW, kH);
        std::vector<float> seY(truth.Size());
        for (size_t i = 0; i < truth.Size(); ++i) {
          double yCommon = 0.0, yOwn = 0.0;
          const double w[3] = {0.2126, 0.7152, 0.0722};
          for (int c = 0; c < 3; ++c) {
            const double t = scale * uniform(rng);
            truth.pixels[i][c] = static_cast<float>(t);
            estimate.pixels[i][c] = static_cast<float>(t * (1.05 + estimateError * normal(rng)));
            se.pixels[i][c] = static_cast<float>(refError * t);
            yCommon += 0.8 * w[c] * refError * t;
            yOwn += 0.36 * w[c] * w[c] * refError * refError * t * t;
          }
          seY[i] = static_cast<float>(std::sqrt(yCommon * yCommon + yOwn));
        }
        const ReferenceNoise noise{&se, &seY};
        const AccuracyMetrics delta = MeasureAccuracy(estimate, truth, nullptr, &noise);
        std::vector<double> draws[4];
        for (int k = 0; k < kDraws; ++k) {
          ImageRgb ref(kW, kH);
          for (size_t i = 0; i < truth.Size(); ++i) {
            const double common = normal(rng);
            for (int c = 0; c < 3; ++c)
              ref.pixels[i][c] = static_cast<float>(truth.pixels[i][c] +
                                                    se.pixels[i][c] * (0.8 * common + 0.6 * normal(rng)));
          }
          const AccuracyMetrics m = MeasureAccuracy(estimate, ref);
          draws[0].push_back(m.rmse);
          draws[1].push_back(m.lumaRmse);
          draws[2].push_back(m.relmse);
          draws[3].push_back(m.rmspe);
        }
        const double predicted[4] = {delta.rmseReferenceSd, delta.lumaRmseReferenceSd, delta.relmseReferenceSd,
                                     delta.rmspeReferenceSd};
        const char* names[4] = {"rmse", "luma_rmse", "relmse", "rmspe"};
        for (int m = 0; m < 4; ++m) {
          double mean = 0.0, var = 0.0;
          for (double v : draws[m]) mean += v / kDraws;
          for (double v : draws[m]) var += (v - mean) * (v - mean) / (kDraws - 1);
          ASSERT_GT(predicted[m], 0.0) << names[m];
          EXPECT_NEAR(std::sqrt(var) / predicted[m], 1.0, 0.2)
              << names[m] << " scale " << scale << " reference error " << refError << " estimate error "
              << estimateError;
        }
      }
}

// Without the reference's noise there is nothing to propagate: the sds are 0.
TEST(ReferenceSd, IsZeroWithoutReferenceNoise) {
  ImageRgb a(2, 1), r(2, 1);
  a.pixels = {Vec3(1.0f), Vec3(2.0f)};
  r.pixels = {Vec3(1.5f), Vec3(1.0f)};
  const AccuracyMetrics m = MeasureAccuracy(a, r);
  EXPECT_EQ(m.rmseReferenceSd, 0.0);
  EXPECT_EQ(m.lumaRmseReferenceSd, 0.0);
  EXPECT_EQ(m.relmseReferenceSd, 0.0);
  EXPECT_EQ(m.rmspeReferenceSd, 0.0);
}

// The table and its tail against the t distribution itself (compare.h's p-value, from the incomplete beta).
TEST(StudentTQuantile975, LeavesTwoAndAHalfPercentInEachTail) {
  for (int dof : {1, 2, 3, 5, 7, 10, 19, 30, 31, 45, 60, 120, 1000})
    EXPECT_NEAR(StudentTTwoSidedP(StudentTQuantile975(dof), dof), 0.05, 1e-3) << dof;
}

// Hand-computed: 32 frames in 4 batches whose means are 1, 2, 3, 6 (sd of the batch means sqrt(14/3), so the
// estimator's part is sqrt(14/3) / 2); frames sharing a reference add linearly, others in quadrature.
TEST(ColumnInterval, ReadsTheBatchMeansAndAddsSharedReferencesLinearly) {
  std::vector<double> values;
  for (double m : {1.0, 2.0, 3.0, 6.0})
    for (int i = 0; i < 8; ++i) values.push_back(m + (i % 2 ? 0.5 : -0.5));
  std::vector<double> sds(32, 0.1), oneReference(32, 7.0), eachItsOwn(32);
  for (int i = 0; i < 32; ++i) eachItsOwn[i] = i;
  const MetricInterval shared = ColumnInterval(values, sds, oneReference);
  EXPECT_DOUBLE_EQ(shared.mean, 3.0);
  EXPECT_NEAR(shared.estimatorSd, std::sqrt(14.0 / 3.0) / 2.0, 1e-12);
  EXPECT_NEAR(shared.referenceSd, 0.1, 1e-12);  // one reference: its error moves every frame alike
  // Welch–Satterthwaite: (14/12 + 0.01)² / ((14/12)² / 3) = 3.06 degrees of freedom, read as 3.
  EXPECT_NEAR(shared.halfWidth, 3.182 * std::sqrt(14.0 / 12.0 + 0.01), 1e-9);
  EXPECT_FALSE(shared.referenceDominated);
  const MetricInterval independent = ColumnInterval(values, sds, eachItsOwn);
  EXPECT_NEAR(independent.referenceSd, 0.1 / std::sqrt(32.0), 1e-12);
  // Fewer than 4 batches: the reference's part alone, at the normal quantile, and marked as such.
  const std::vector<double> few(values.begin(), values.begin() + 24);
  const MetricInterval short_ = ColumnInterval(few, std::vector<double>(24, 0.1), std::vector<double>(24, 7.0));
  EXPECT_TRUE(std::isnan(short_.estimatorSd));
  EXPECT_NEAR(short_.halfWidth, 1.96 * 0.1, 1e-12);
  EXPECT_TRUE(short_.referenceDominated);
  // A reference that dwarfs the frames' spread is marked.
  const MetricInterval noisy = ColumnInterval(values, std::vector<double>(32, 5.0), oneReference);
  EXPECT_TRUE(noisy.referenceDominated);
}

// With --ensemble's members' spread (*_seed_sd), the estimator's part is its mean over frames, read with the normal
// quantile; each member's spread is the sample standard deviation of its members' metrics (MeasureEnsemble).
TEST(ColumnInterval, TakesTheEstimatorsPartFromTheSeedsWhenThereAreSome) {
  const std::vector<double> values = {1.0, 2.0, 3.0}, refSds = {0.3, 0.3, 0.3}, keys = {1.0, 2.0, 3.0};
  const MetricInterval in = ColumnInterval(values, refSds, keys, {0.5, 0.7, 0.9});
  EXPECT_NEAR(in.estimatorSd, 0.7, 1e-12);
  EXPECT_NEAR(in.referenceSd, 0.3 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(in.halfWidth, 1.96 * std::sqrt(0.49 + 0.03), 1e-12);
  EXPECT_FALSE(in.referenceDominated);
  ImageRgb reference(2, 1), bias, variance;
  reference.pixels = {Vec3(1.0f), Vec3(2.0f)};
  std::vector<ImageRgb> members(3, reference);
  members[0].pixels[0] = Vec3(1.5f);
  members[1].pixels[1] = Vec3(1.0f);
  members[2].pixels = {Vec3(0.5f), Vec3(3.0f)};
  const EnsembleStats e = MeasureEnsemble(members, reference, ImageRgb(2, 1), bias, variance);
  std::vector<double> relmse;
  for (const ImageRgb& m : members) relmse.push_back(MeasureAccuracy(m, reference).relmse);
  const double mean = (relmse[0] + relmse[1] + relmse[2]) / 3.0;
  double var = 0.0;
  for (double v : relmse) var += (v - mean) * (v - mean) / 2.0;
  EXPECT_NEAR(e.seedSd[2], std::sqrt(var), 1e-12);
}

// Coverage: frames whose values are the true metric plus the estimator's noise (independent normal, sd 1) plus a
// reference error shared by all frames (normal, with its sd reported as *_ref_sd): over 4000 runs of 64 frames the
// interval must hold the true value 95% of the time, for a reference that dominates (sd 0.3 against the mean's
// 0.125), one that is comparable (0.1) and none. Binomial sd sqrt(0.95 · 0.05 / 4000) = 0.34%; the band 93.6%–96.4%
// is 4.1 of them (3 cases × 2 sides: false-failure rate 1e-4).
TEST(ColumnInterval, CoversTheTrueMeanNinetyFivePercentOfTheTime) {
  constexpr int kRuns = 4000, kFrames = 64;
  std::mt19937_64 rng(4040);
  std::normal_distribution<double> normal;
  for (const double referenceSd : {0.3, 0.1, 0.0}) {
    int covered = 0;
    for (int run = 0; run < kRuns; ++run) {
      const double referenceError = referenceSd * normal(rng);
      std::vector<double> values(kFrames);
      for (double& v : values) v = 10.0 + referenceError + normal(rng);
      const MetricInterval in = ColumnInterval(values, std::vector<double>(kFrames, referenceSd),
                                               std::vector<double>(kFrames, 1.0));
      covered += std::fabs(in.mean - 10.0) <= in.halfWidth;
    }
    const double rate = double(covered) / kRuns;
    EXPECT_GT(rate, 0.936) << referenceSd;
    EXPECT_LT(rate, 0.964) << referenceSd;
  }
}

}  // namespace
}  // namespace restir

namespace restir {
namespace {

// The Pareto front of (cost, error), on a grid of point sets with ties and non-finite values: a point is on it
// exactly when a sweep in cost order finds its error below every error of a cheaper point and the least of its own
// cost (a definition by sorting, independent of the pairwise one the implementation uses).
TEST(ParetoFront, IsThePointsNoOtherDominates) {
  const std::vector<double> values = {1.0, 2.0, 2.0, 3.0, NAN, INFINITY};
  for (int set = 0; set < 400; ++set) {
    std::vector<double> cost, error;
    const int n = 1 + set % 7;
    for (int i = 0; i < n; ++i) {
      cost.push_back(values[(set * 7 + i * 3) % values.size()]);
      error.push_back(values[(set * 5 + i * 11 + set / 7) % values.size()]);
    }
    const std::vector<uint8_t> front = ParetoFront(cost, error);
    ASSERT_EQ(front.size(), cost.size());
    std::vector<int> order;
    for (int i = 0; i < n; ++i)
      if (std::isfinite(cost[i]) && std::isfinite(error[i])) order.push_back(i);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return cost[a] < cost[b]; });
    std::vector<uint8_t> want(n, 0);
    double cheaperBest = INFINITY;
    for (size_t g = 0; g < order.size();) {
      size_t e = g;
      double groupBest = INFINITY;
      while (e < order.size() && cost[order[e]] == cost[order[g]]) groupBest = std::min(groupBest, error[order[e++]]);
      for (size_t k = g; k < e; ++k) want[order[k]] = error[order[k]] < cheaperBest && error[order[k]] == groupBest;
      cheaperBest = std::min(cheaperBest, groupBest);
      g = e;
    }
    EXPECT_EQ(front, want) << "set " << set;
  }
  EXPECT_EQ(ParetoFront({1, 2, 3}, {3, 2, 1}), (std::vector<uint8_t>{1, 1, 1}));
  EXPECT_EQ(ParetoFront({1, 2, 3}, {1, 2, 3}), (std::vector<uint8_t>{1, 0, 0}));
  EXPECT_EQ(ParetoFront({1, 1}, {2, 2}), (std::vector<uint8_t>{1, 1}));  // duplicates dominate neither
}

}  // namespace
}  // namespace restir
