// The *_corrected metrics on synthetic images whose true error is known. A true image T, an estimate I fixed
// in advance, and many independent references R̂, each the mean of 16 noisy replicates of T with its standard
// error from their spread, as RenderReference makes them. Over the references, the corrected mean squares must
// average to the error against T itself, which the test computes exactly; the raw ones must not where the
// reference's noise is not negligible (so the test can fail).
//
// Statistics: for each configuration, a one-sample t-test over kTrials references of (corrected − true),
// rejected at |t| > 4.75. With 54 configurations × 2 mean squares the family-wise false-failure rate is
// about 108 × 3e-6 ≈ 3e-4 (t with 199 degrees of freedom). Seeds are fixed, so a run is reproducible.
#include "sim/metrics/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace restir {
namespace {

constexpr int kW = 32, kH = 16, kReplicates = 16, kTrials = 200;
constexpr double kRejectT = 4.75;

struct Config {
  double scale;        // typical radiance: tiny, unit, huge
  double refRelError;  // the reference's relative standard error per channel
  int estimateKind;    // 0: exact (I = T), 1: biased 5 % bright, 2: noisy (20 % per pixel)
  bool masked;         // over half of the pixels only
};

struct Draw {
  ImageRgb mean, standardError;
  std::vector<float> lumaStandardError;
};

// 16 replicates per pixel; the channels' noise is correlated (a common term, as one light sample feeds all
// three), so Y's standard error is not Y of the channels' ones.
Draw DrawReference(const ImageRgb& truth, double relError, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Draw d{ImageRgb(kW, kH), ImageRgb(kW, kH), std::vector<float>(truth.Size())};
  const double sdReplicate = relError * std::sqrt(double(kReplicates));
  for (size_t i = 0; i < truth.Size(); ++i) {
    double rep[kReplicates][3];
    for (int r = 0; r < kReplicates; ++r) {
      const double common = normal(rng);
      for (int c = 0; c < 3; ++c)
        rep[r][c] = truth.pixels[i][c] * (1.0 + sdReplicate * (0.8 * common + 0.6 * normal(rng)));
    }
    double y[kReplicates], meanY = 0.0, varY = 0.0;
    for (int r = 0; r < kReplicates; ++r) {
      y[r] = 0.2126 * rep[r][0] + 0.7152 * rep[r][1] + 0.0722 * rep[r][2];
      meanY += y[r] / kReplicates;
    }
    for (int r = 0; r < kReplicates; ++r) varY += (y[r] - meanY) * (y[r] - meanY) / (kReplicates - 1);
    d.lumaStandardError[i] = static_cast<float>(std::sqrt(varY / kReplicates));
    for (int c = 0; c < 3; ++c) {
      double mean = 0.0, var = 0.0;
      for (int r = 0; r < kReplicates; ++r) mean += rep[r][c] / kReplicates;
      for (int r = 0; r < kReplicates; ++r) var += (rep[r][c] - mean) * (rep[r][c] - mean) / (kReplicates - 1);
      d.mean.pixels[i][c] = static_cast<float>(mean);
      d.standardError.pixels[i][c] = static_cast<float>(std::sqrt(var / kReplicates));
    }
  }
  return d;
}

struct TStat {
  double mean = 0.0, t = 0.0, standardError = 0.0;
};

TStat OneSampleT(const std::vector<double>& x, double mu) {
  double mean = 0.0, var = 0.0;
  for (double v : x) mean += v / double(x.size());
  for (double v : x) var += (v - mean) * (v - mean) / double(x.size() - 1);
  const double se = std::sqrt(var / double(x.size()));
  return {mean, se > 0.0 ? (mean - mu) / se : (mean == mu ? 0.0 : INFINITY), se};
}

TEST(ReferenceNoiseCorrection, MeanSquaresAverageToTheErrorAgainstTheTrueImage) {
  std::vector<Config> grid;
  for (double scale : {1e-3, 1.0, 1e3})
    for (double rel : {0.003, 0.03, 0.3})
      for (int kind : {0, 1, 2})
        for (bool masked : {false, true}) grid.push_back({scale, rel, kind, masked});
  uint64_t seed = 0x5eed;
  for (const Config& cfg : grid) {
    SCOPED_TRACE("scale " + std::to_string(cfg.scale) + " reference error " + std::to_string(cfg.refRelError) +
                 " estimate " + std::to_string(cfg.estimateKind) + (cfg.masked ? " masked" : ""));
    std::mt19937_64 rng(++seed);
    std::lognormal_distribution<double> spread(0.0, 1.0);
    std::normal_distribution<double> normal;
    ImageRgb truth(kW, kH), estimate(kW, kH);
    std::vector<uint8_t> mask(truth.Size());
    for (size_t i = 0; i < truth.Size(); ++i) {
      mask[i] = !cfg.masked || (i % 3 != 0);
      for (int c = 0; c < 3; ++c) {
        truth.pixels[i][c] = static_cast<float>(cfg.scale * spread(rng));
        const double t = truth.pixels[i][c];
        estimate.pixels[i][c] = static_cast<float>(cfg.estimateKind == 0   ? t
                                                   : cfg.estimateKind == 1 ? 1.05 * t
                                                                           : std::max(0.0, t * (1.0 + 0.2 * normal(rng))));
      }
    }
    const std::vector<uint8_t>* maskPtr = cfg.masked ? &mask : nullptr;
    // The true values: the same sums as MeasureAccuracy, against T.
    const AccuracyMetrics exact = MeasureAccuracy(estimate, truth, maskPtr);
    const double trueMse = exact.rmse * exact.rmse, trueLumaMse = exact.lumaRmse * exact.lumaRmse;

    std::vector<double> mse, lumaMse, rawMse, rawLumaMse, relmse, rawRelmse;
    for (int trial = 0; trial < kTrials; ++trial) {
      const Draw ref = DrawReference(truth, cfg.refRelError, rng);
      const ReferenceNoise noise{&ref.standardError, &ref.lumaStandardError};
      const AccuracyMetrics m = MeasureAccuracy(estimate, ref.mean, maskPtr, &noise);
      mse.push_back(m.mseCorrected);
      lumaMse.push_back(m.lumaMseCorrected);
      rawMse.push_back(m.rmse * m.rmse);
      rawLumaMse.push_back(m.lumaRmse * m.lumaRmse);
      relmse.push_back(m.relmseCorrected);
      rawRelmse.push_back(m.relmse);
      EXPECT_EQ(m.rmseCorrected, std::sqrt(std::max(0.0, m.mseCorrected)));
    }
    const TStat tMse = OneSampleT(mse, trueMse), tLuma = OneSampleT(lumaMse, trueLumaMse);
    EXPECT_LT(std::abs(tMse.t), kRejectT) << "corrected mse " << tMse.mean << " true " << trueMse;
    EXPECT_LT(std::abs(tLuma.t), kRejectT) << "corrected luma mse " << tLuma.mean << " true " << trueLumaMse;
    // Power: where the reference's variance is a visible share of the mean square, the raw value is caught.
    const TStat tRaw = OneSampleT(rawMse, trueMse), tRawLuma = OneSampleT(rawLumaMse, trueLumaMse);
    if (cfg.refRelError >= 0.3 || cfg.estimateKind == 0) {
      EXPECT_GT(tRaw.t, kRejectT) << "raw mse " << tRaw.mean << " true " << trueMse;
      EXPECT_GT(tRawLuma.t, kRejectT) << "raw luma mse " << tRawLuma.mean << " true " << trueLumaMse;
    }
    // relmse divides by R̂² + 0.01, which is itself noisy and correlates with the numerator: the correction
    // removes the numerator's share only, so the corrected mean is never further from the truth than the raw
    // one, and within 1 % of the truth plus the t-test's reach when the reference is 0.3 % noisy (the flagship's
    // reference: 0.9 % on average over lit pixels). docs/metrics.md states the remainder.
    const TStat tRel = OneSampleT(relmse, exact.relmse), tRawRel = OneSampleT(rawRelmse, exact.relmse);
    EXPECT_LE(std::abs(tRel.mean - exact.relmse), std::abs(tRawRel.mean - exact.relmse) + 1e-12);
    if (cfg.refRelError <= 0.003) {
      EXPECT_LT(std::abs(tRel.mean - exact.relmse), 0.01 * exact.relmse + kRejectT * tRel.standardError)
          << "corrected relmse " << tRel.mean << " true " << exact.relmse << " raw " << tRawRel.mean;
    }
  }
}

// No noise given: the corrected fields equal the raw ones, so an old reference without replicates reads as
// before.
TEST(ReferenceNoiseCorrection, WithoutNoiseCorrectedEqualsRaw) {
  ImageRgb est(2, 1), ref(2, 1);
  est.pixels = {Vec3(1, 2, 3), Vec3(0.2f)};
  ref.pixels = {Vec3(1, 1, 1), Vec3(0.5f)};
  const AccuracyMetrics m = MeasureAccuracy(est, ref);
  EXPECT_DOUBLE_EQ(m.rmseCorrected, m.rmse);
  EXPECT_DOUBLE_EQ(m.lumaRmseCorrected, m.lumaRmse);
  EXPECT_DOUBLE_EQ(m.relmseCorrected, m.relmse);
}

// Hand-computed: one pixel, se² subtracted channel by channel and se_Y² from the luma term.
TEST(ReferenceNoiseCorrection, SubtractsEachPixelsVariance) {
  ImageRgb est(1, 1), ref(1, 1), se(1, 1);
  est.pixels = {Vec3(1.5f, 1.0f, 1.0f)};
  ref.pixels = {Vec3(1.0f, 1.0f, 0.5f)};
  se.pixels = {Vec3(0.25f, 0.5f, 0.125f)};
  const std::vector<float> lumaSe = {0.0625f};
  const ReferenceNoise noise{&se, &lumaSe};
  const AccuracyMetrics m = MeasureAccuracy(est, ref, nullptr, &noise);
  EXPECT_NEAR(m.mseCorrected, ((0.25 - 0.0625) + (0.0 - 0.25) + (0.25 - 0.015625)) / 3.0, 1e-12);
  EXPECT_NEAR(m.relmseCorrected, ((0.25 - 0.0625) / 1.01 + (0.0 - 0.25) / 1.01 + (0.25 - 0.015625) / 0.26) / 3.0,
              1e-9);
  const double dy = 0.2126 * 0.5 + 0.0722 * 0.5;
  EXPECT_NEAR(m.lumaMseCorrected, dy * dy - 0.0625 * 0.0625, 1e-7);
  EXPECT_NEAR(m.rmseCorrected, std::sqrt(m.mseCorrected), 1e-15);
}

}  // namespace
}  // namespace restir
