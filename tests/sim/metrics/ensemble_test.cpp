// Seed ensembles (`run --ensemble K`, DESIGN §6): the bias²/variance split is exact on hand-made images, and on a
// real run the unbiased preset's ensemble bias stays within its bound while restir-biased's does not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "sim/metrics/metrics.h"
#include "sim/run/runner.h"

namespace restir {
namespace {

TEST(Ensemble, SplitIsExactOnHandMadeImages) {
  // One pixel, K = 4 members with red values 1, 2, 3, 6 (mean 3, variance (4+1+0+9)/4 = 3.5); reference 2 with
  // standard error 0.5; green and blue exact.
  std::vector<ImageRgb> images(4, ImageRgb(1, 1));
  const float red[4] = {1, 2, 3, 6};
  for (int k = 0; k < 4; ++k) images[k].pixels[0] = Vec3(red[k], 1.0f, 1.0f);
  ImageRgb ref(1, 1), se(1, 1), bias, variance;
  ref.pixels[0] = Vec3(2.0f, 1.0f, 1.0f);
  se.pixels[0] = Vec3(0.5f, 0.0f, 0.0f);
  const EnsembleStats s = MeasureEnsemble(images, ref, se, bias, variance);
  EXPECT_DOUBLE_EQ(s.bias2, 1.0 / 3.0);                   // (3 − 2)² over 3 channels
  EXPECT_DOUBLE_EQ(s.variance, 3.5 / 3.0);
  EXPECT_DOUBLE_EQ(s.mse, (1 + 0 + 1 + 16) / 4.0 / 3.0);  // mean (I_k − R)²
  EXPECT_NEAR(s.mse, s.bias2 + s.variance, 1e-15);
  EXPECT_DOUBLE_EQ(s.bias2Noise, (3.5 / 3.0 + 0.25) / 3.0);
  EXPECT_FLOAT_EQ(bias.pixels[0].x, 1.0f);
  EXPECT_FLOAT_EQ(variance.pixels[0].x, 3.5f);
  EXPECT_FLOAT_EQ(bias.pixels[0].y, 0.0f);
}

std::map<std::string, std::vector<std::map<std::string, double>>> RowsByPreset(const RunResult& r) {
  std::map<std::string, std::vector<std::map<std::string, double>>> out;
  for (const FrameMetricsRow& row : r.rows) {
    std::map<std::string, double> m(row.values.begin(), row.values.end());
    out[row.preset].push_back(m);
  }
  return out;
}

// smoke.json has a box shadowing the floor. With K = 24 seeds per preset, per frame:
// z = (ensemble_luma_ratio − 1) / ensemble_luma_ratio_stderr. restir-unbiased: |z| < 4.42 on each of 4 frames
// (two-sided 1e-5 each under the normal approximation of a 24-member mean). restir-biased ignores visibility in
// its MIS weights and darkens: the mean of its 4 per-frame ratios is below 1 by more than 4.42 times the largest
// per-frame standard error (the mean of correlated frames has a standard error no larger than that).
TEST(Ensemble, UnbiasedPresetWithinBoundBiasedPresetDarkens) {
  const std::string out = (std::filesystem::path(::testing::TempDir()) / "restir-ensemble").string();
  std::filesystem::remove_all(out);
  RunOptions o;
  o.sequencePath = "sequences/smoke.json";
  o.presets = {"restir-unbiased", "restir-biased"};
  o.frameEnd = 4;
  o.width = 64, o.height = 36;
  o.referenceSpp = 512;
  o.ensemble = 24;
  o.outDir = out;
  o.cacheDir = out + "/cache";
  o.writeImages = true;
  o.progress = false;
  o.report = false;
  const auto rows = RowsByPreset(restir::Run(o));
  ASSERT_EQ(rows.at("restir-unbiased").size(), 4u);
  double biasedMean = 0.0, biasedMaxSe = 0.0;
  for (int f = 0; f < 4; ++f) {
    const auto& u = rows.at("restir-unbiased")[f];
    const double z = (u.at("ensemble_luma_ratio") - 1.0) / u.at("ensemble_luma_ratio_stderr");
    std::printf("frame %d: restir-unbiased ratio %.5f z %+.2f; ", f, u.at("ensemble_luma_ratio"), z);
    EXPECT_LT(std::abs(z), 4.42) << "frame " << f;
    EXPECT_NEAR(u.at("ensemble_mse"), u.at("ensemble_bias2") + u.at("ensemble_variance"),
                1e-9 * u.at("ensemble_mse"));
    const auto& b = rows.at("restir-biased")[f];
    biasedMean += b.at("ensemble_luma_ratio") / 4.0;
    biasedMaxSe = std::max(biasedMaxSe, b.at("ensemble_luma_ratio_stderr"));
    std::printf("restir-biased ratio %.5f\n", b.at("ensemble_luma_ratio"));
  }
  EXPECT_LT((biasedMean - 1.0) / biasedMaxSe, -4.42) << biasedMean << " +- " << biasedMaxSe;
  // The maps are in the frame EXR.
  EXPECT_TRUE(std::filesystem::exists(out + "/frames/restir-unbiased/0003.exr"));
}

}  // namespace
}  // namespace restir
