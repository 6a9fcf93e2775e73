// Seed 004's regime built on purpose (issue 20: "a case constructed so that it must win"): a 64×64 floor
// under a quad light where each pixel's initial reservoir survives a Russian roulette with probability q =
// 1/32 (its W divided by q, so every input stays an unbiased contribution weight) and is empty otherwise. Few
// reservoirs contribute, and they lie in the paper's 8×8 cells (issue 39; it was 32×32 before). Standard
// pairwise reuse with k = 5 random neighbours within 30 px mostly finds empty ones; stochastic pairwise MIS draws
// its N = 5 candidates from a cell in proportion to c p̂ W (seed 004 Eq. 17), so it finds the contributors
// wherever its cell search reaches a cell that has one. Both must stay unbiased (their frame means against
// Lambert's closed form, a t-test over 24 seeds, two-sided, |t| < 4.5: false failure about 1.6e-4 per estimator
// with 23 degrees of freedom), and stochastic pairwise MIS must leave more pixels with a contributing reservoir
// and a lower relMSE against the closed form than the standard reuse.
//
// Then the cell pass's settings of issue 39 on the same floor, each unbiased by the same t-test: the
// disocclusion boost (N = 10 where temporal reuse failed), either canonical pdf (uniform, ∝ c) with confidences
// that differ from pixel to pixel (so the two pdfs differ), cells smaller than N (the capped N/M), sparse and
// dense inputs. Seven estimators in this file: family-wise false failure about 1.1e-3.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "core/polygon_irradiance.h"
#include "core/rng.h"
#include "hand_made_frame.h"
#include "sim/estimator/passes/initial_sampling.h"
#include "sim/estimator/passes/shade.h"
#include "sim/estimator/passes/spatial_reuse.h"
#include "sim/estimator/passes/stochastic_pairwise_reuse.h"
#include "sim/estimator/presets.h"
#include "sim/estimator/reservoir_diagnostics.h"

namespace restir {
namespace {

// Lambert: outgoing radiance albedo / π · E, E from the light's two triangles (core/polygon_irradiance.h).
std::vector<double> ClosedForm(const test::HandMadeFrame& f) {
  std::vector<double> ref(f.gbuffer.Size());
  const auto& tris = f.scene->LightTriangles();
  for (size_t i = 0; i < ref.size(); ++i) {
    const Vec3 x = f.gbuffer.Position(i), normal(0.0f, 1.0f, 0.0f);
    double e = 0.0;
    for (const LightTriangle& t : tris)
      e += PolygonIrradiance(x, normal, {t.p0, t.p0 + t.e1, t.p0 + t.e2}, t.radiance.x);
    ref[i] = 0.5 / M_PI * e;
  }
  return ref;
}

// The inputs of one seed: initial sampling, then (q < 1) the Russian roulette, then (varied) confidences 1..20
// from a hash of the pixel. Both keep every input an unbiased contribution weight.
ReservoirBuffer Inputs(test::HandMadeFrame& f, uint32_t seed, float q, bool varied) {
  ReservoirBuffer initial;
  PassStats stats;
  InitialSampling(InitialSamplingParams{}, f.View(seed), initial, stats);
  for (size_t i = 0; i < initial.size(); ++i) {
    const RngKey key{seed, 77u, static_cast<uint32_t>(i), 0xABCDu};
    if (q < 1.0f) initial[i].W = UniformFloat(key, 0) < q ? initial[i].W / q : 0.0f;
    if (varied) initial[i].confidence = 1.0f + std::floor(20.0f * UniformFloat(key, 1));
  }
  return initial;
}

// One estimator over kSeeds seeds: frame mean / closed form per seed, relMSE and contributing share (means).
struct Outcome {
  static constexpr int kSeeds = 24;
  double ratio[kSeeds];
  double relmse = 0.0, contributing = 0.0, inputContributing = 0.0;
  double MeanRatio() const {
    double mean = 0.0;
    for (double r : ratio) mean += r / kSeeds;
    return mean;
  }
  double T() const {  // one-sample t of the ratio against 1
    const double mean = MeanRatio();
    double var = 0.0;
    for (double r : ratio) var += (r - mean) * (r - mean) / (kSeeds - 1);
    return (mean - 1.0) / std::sqrt(var / kSeeds);
  }
};

Outcome RunEstimator(test::HandMadeFrame& f, const std::vector<double>& ref, const SpatialParams& params,
                     const std::vector<uint8_t>& temporalAccepted, float q, bool varied) {
  Outcome o;
  const size_t n = f.gbuffer.Size();
  for (int s = 0; s < Outcome::kSeeds; ++s) {
    const uint32_t seed = 100 + s;
    ReservoirBuffer reservoirs = Inputs(f, seed, q, varied), spare;
    o.inputContributing += ContributingFraction(f.gbuffer, reservoirs, nullptr).all / Outcome::kSeeds;
    PassStats stats;
    CellGrid grid;
    if (params.mis == MisFamily::kStochasticPairwise)
      StochasticPairwiseReuse(params, f.View(seed), temporalAccepted, reservoirs, spare, grid, stats);
    else
      SpatialReuse(params, f.View(seed), temporalAccepted, reservoirs, spare, stats);
    o.contributing += ContributingFraction(f.gbuffer, reservoirs, nullptr).all / Outcome::kSeeds;
    ImageRgb image;
    Shade(ShadeParams{}, f.View(seed), reservoirs, image, stats);
    double sum = 0.0, sumRef = 0.0, err = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const double v = image.pixels[i].x;
      sum += v, sumRef += ref[i];
      err += (v - ref[i]) * (v - ref[i]) / (ref[i] * ref[i] + 1e-2 * 1e-2);
    }
    o.ratio[s] = sum / sumRef;
    o.relmse += err / double(n) / Outcome::kSeeds;
  }
  return o;
}

TEST(StochasticPairwiseReuse, WinsWhereFewReservoirsOfTheirCellsContribute) {
  test::HandMadeFrame f(64, 64);
  const std::vector<double> ref = ClosedForm(f);
  SpatialParams standard = FindPreset("restir-unbiased")->settings.spatial;
  standard.neighbours = 5;
  SpatialParams stochastic = FindPreset("restir-spmis")->settings.spatial;
  stochastic.stochastic.draws = stochastic.stochastic.canonicalDraws = 5;
  stochastic.stochastic.cellTile = 8;
  // Two tiles away: at 64 rows the default radius (30 px at 1080 rows) is under 2 px, and a cell whose own
  // contributors all failed the roulette must reach a neighbouring one.
  stochastic.stochastic.cellSearchRadius = 16.0f / 64.0f;
  const float q = 1.0f / 32.0f;
  const Outcome o[2] = {RunEstimator(f, ref, standard, {}, q, false), RunEstimator(f, ref, stochastic, {}, q, false)};
  for (int method = 0; method < 2; ++method) {
    EXPECT_LT(std::abs(o[method].T()), 4.5) << (method ? "stochastic pairwise" : "standard")
                                            << ": frame mean ratio " << o[method].MeanRatio();
    RecordProperty(method ? "spmis_luma_ratio" : "standard_luma_ratio", std::to_string(o[method].MeanRatio()));
  }
  RecordProperty("input_contributing", std::to_string(o[0].inputContributing));
  RecordProperty("standard_contributing", std::to_string(o[0].contributing));
  RecordProperty("spmis_contributing", std::to_string(o[1].contributing));
  RecordProperty("standard_relmse", std::to_string(o[0].relmse));
  RecordProperty("spmis_relmse", std::to_string(o[1].relmse));
  EXPECT_NEAR(o[0].inputContributing, q, 0.01);
  // k = 5 uniform neighbours: about 1 - (1 - q)^5 ≈ 15% of pixels find a contributor (plus their own q).
  EXPECT_LT(o[0].contributing, 0.3);
  // Measured: contributing 0.870 against 0.125 (input 0.032); relmse 3.71 against 8.42 (0.44×). At 8×8 cells
  // about (31/32)^63 = 13% of the cells hold no contributor, and a pixel whose search lands only on such cells
  // keeps nothing: hence 0.87, not the 0.965 of the 32×32 cells this test used before.
  EXPECT_GT(o[1].contributing, 0.75);
  EXPECT_LT(o[1].relmse, 0.75 * o[0].relmse)
      << "stochastic pairwise " << o[1].relmse << " vs standard " << o[0].relmse;
  std::printf(
      "[ measured ] input contributing %.4f; contributing after reuse: standard %.4f, stochastic pairwise "
      "%.4f; relmse: standard %.4f, stochastic pairwise %.4f\n",
      o[0].inputContributing, o[0].contributing, o[1].contributing, o[0].relmse, o[1].relmse);
}

// Issue 39's settings keep the cell pass unbiased (the file comment's t-test, per configuration).
TEST(StochasticPairwiseReuse, StaysUnbiasedWithTheBoostEitherCanonicalPdfAndSmallCells) {
  test::HandMadeFrame f(64, 64);
  const std::vector<double> ref = ClosedForm(f);
  std::vector<uint8_t> leftHalfFailed(f.gbuffer.Size()), allFailed(f.gbuffer.Size(), 0);
  for (size_t i = 0; i < leftHalfFailed.size(); ++i) leftHalfFailed[i] = i % 64 >= 32;
  struct Config {
    const char* name;
    CanonicalPdf pdf;
    int tile;
    const std::vector<uint8_t>* accepted;
    float q;
  };
  const Config configs[] = {
      {"uniform, boost on the left half, dense", CanonicalPdf::kUniform, 8, &leftHalfFailed, 1.0f},
      {"confidence, boost on the left half, dense", CanonicalPdf::kConfidence, 8, &leftHalfFailed, 1.0f},
      {"confidence, boost everywhere, sparse", CanonicalPdf::kConfidence, 8, &allFailed, 0.25f},
      {"confidence, 2x2 cells (M < N), boost on the left half", CanonicalPdf::kConfidence, 2, &leftHalfFailed, 1.0f},
      {"uniform, 2x2 cells (M < N), boost on the left half", CanonicalPdf::kUniform, 2, &leftHalfFailed, 1.0f},
  };
  for (const Config& c : configs) {
    SpatialParams p = FindPreset("restir-spmis")->settings.spatial;
    p.disocclusionBoost = true;
    p.stochastic.draws = 5;
    p.stochastic.disocclusionDraws = 10;
    p.stochastic.canonicalDraws = 3;
    p.stochastic.canonicalPdf = c.pdf;
    p.stochastic.cellTile = c.tile;
    p.stochastic.cellSearchRadius = 8.0f / 64.0f;
    const Outcome o = RunEstimator(f, ref, p, *c.accepted, c.q, true);
    EXPECT_LT(std::abs(o.T()), 4.5) << c.name << ": frame mean ratio " << o.MeanRatio();
    std::printf("[ measured ] %s: frame mean ratio %.5f (t = %.2f), relmse %.4f\n", c.name, o.MeanRatio(), o.T(),
                o.relmse);
  }
}

}  // namespace
}  // namespace restir
