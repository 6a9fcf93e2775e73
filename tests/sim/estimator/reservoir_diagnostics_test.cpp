// Reservoir diagnostics (sim/estimator/reservoir_diagnostics.h, issue 20) against answers worked out by hand or by
// formulas that do not share the implementation's loop: contributing fractions over crafted buffers
// (background pixels, NaN and infinite weights, a region), duplicate fractions of constant, distinct and
// striped sample patterns (the stripes' expected value by counting columns, border windows included),
// confidence spread and ages; and through whole frames: the columns are in metrics.csv, ris keeps age 0 and
// confidence spread 0, spatial reuse raises duplication, and the shaded fraction never exceeds what the
// reservoirs offered.
#include "sim/estimator/reservoir_diagnostics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/run/frame_loop.h"
#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

GBuffer Surfaces(int w, int h) {
  GBuffer g;
  g.Resize(w, h);
  for (size_t i = 0; i < g.Size(); ++i) g.objectId[i] = 0, g.materialId[i] = 0;
  return g;
}

StoredReservoir WithSample(uint32_t light, float x, float target = 1.0f, float W = 1.0f) {
  StoredReservoir r;
  r.lightId = light;
  r.position = Vec3(x, 1.0f, 0.0f);
  r.normal = Vec3(0.0f, -1.0f, 0.0f);
  r.targetPdf = target;
  r.W = W;
  r.confidence = 1.0f;
  return r;
}

TEST(ReservoirDiagnostics, ContributingCountsSurfacePixelsWithPositiveFiniteTargetTimesWeight) {
  GBuffer g = Surfaces(4, 3);
  ReservoirBuffer r(g.Size());
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  // 12 pixels: 2 background (one holding a contributing sample: not counted), 10 surfaces of which 4
  // contribute.
  g.objectId[0] = -1, r[0] = WithSample(0, 0.0f);
  g.materialId[1] = -1;
  r[2] = WithSample(0, 0.1f);                  // contributes
  r[3] = WithSample(0, 0.2f, 0.0f, 1.0f);      // p̂ = 0: rejected by its own target
  r[4] = WithSample(0, 0.3f, 1.0f, 0.0f);      // W = 0: empty
  r[5] = WithSample(0, 0.4f, 2.0f, 1e-3f);     // contributes
  r[6] = WithSample(0, 0.5f, 1.0f, inf);       // not finite
  r[7] = WithSample(0, 0.6f, nan, 1.0f);       // not finite
  r[8] = WithSample(0, 0.7f, 1e-30f, 1e-30f);  // p̂ W underflows to 0 in float
  r[9] = WithSample(0, 0.8f);                  // contributes
  r[10] = WithSample(0, 0.9f);                 // contributes
  // r[11] default: empty
  std::vector<uint8_t> region(g.Size(), 0);
  region[0] = region[2] = region[3] = region[4] = region[9] = 1;  // surfaces 2, 3, 4, 9: two contribute
  const Contributing c = ContributingFraction(g, r, &region);
  EXPECT_DOUBLE_EQ(c.all, 4.0 / 10.0);
  EXPECT_DOUBLE_EQ(c.region, 2.0 / 4.0);
  EXPECT_DOUBLE_EQ(ContributingFraction(g, r, nullptr).region, 0.0);
  std::vector<uint8_t> none(g.Size(), 0);
  EXPECT_DOUBLE_EQ(ContributingFraction(g, r, &none).region, 0.0);
}

// Expected duplicate fraction of vertical stripes of period 2 (column parity decides the sample) on a w x h
// image where every pixel is a surface with a sample: for pixel (x, y) the window's valid columns and rows
// are counted, the same-parity columns among them give the matches.
double StripesExpected(int w, int h) {
  double sum = 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int cols = 0, sameCols = 0, rows = 0;
      for (int dx = -kDuplicateRadius; dx <= kDuplicateRadius; ++dx)
        if (x + dx >= 0 && x + dx < w) ++cols, sameCols += (dx % 2 == 0);
      for (int dy = -kDuplicateRadius; dy <= kDuplicateRadius; ++dy) rows += (y + dy >= 0 && y + dy < h);
      sum += double(sameCols * rows - 1) / double(cols * rows - 1);
    }
  return sum / double(w * h);
}

TEST(ReservoirDiagnostics, DuplicateFractionOfConstantDistinctAndStripedPatterns) {
  for (const auto& [w, h] : {std::pair{7, 5}, std::pair{31, 17}, std::pair{2, 9}}) {
    const GBuffer g = Surfaces(w, h);
    ReservoirBuffer same(g.Size(), WithSample(3, 0.25f)), distinct(g.Size()), stripes(g.Size());
    for (size_t i = 0; i < g.Size(); ++i) {
      distinct[i] = WithSample(3, 0.001f * float(i));
      stripes[i] = WithSample(static_cast<uint32_t>((i % w) % 2), 0.5f);  // same point, two lights
    }
    ReservoirDiagnostics d;
    MeasureOutputReservoirs(g, same, d);
    EXPECT_DOUBLE_EQ(d.duplicateFraction, 1.0) << w << "x" << h;
    MeasureOutputReservoirs(g, distinct, d);
    EXPECT_DOUBLE_EQ(d.duplicateFraction, 0.0) << w << "x" << h;
    MeasureOutputReservoirs(g, stripes, d);
    EXPECT_NEAR(d.duplicateFraction, StripesExpected(w, h), 1e-12) << w << "x" << h;
  }
  // Pixels without a sample and background pixels neither count nor are compared with.
  GBuffer g = Surfaces(5, 5);
  ReservoirBuffer r(g.Size(), WithSample(1, 0.5f));
  for (size_t i = 0; i < g.Size(); ++i)
    if (i % 2) g.objectId[i] = -1;  // every other pixel is background
  r[12].W = 0.0f;                   // the centre is empty
  ReservoirDiagnostics d;
  MeasureOutputReservoirs(g, r, d);
  EXPECT_DOUBLE_EQ(d.duplicateFraction, 1.0);
  // Half the remaining pixels move their point by one ulp: a different sample.
  for (size_t i = 0; i < g.Size(); i += 4) r[i].position.x = std::nextafter(0.5f, 1.0f);
  MeasureOutputReservoirs(g, r, d);
  EXPECT_LT(d.duplicateFraction, 1.0);
  EXPECT_GT(d.duplicateFraction, 0.0);
}

TEST(ReservoirDiagnostics, ConfidenceSpreadAndAgeOverTheRightPixels) {
  GBuffer g = Surfaces(4, 1);
  ReservoirBuffer r(4);
  r[0] = WithSample(0, 0.0f), r[0].confidence = 2.0f, r[0].history.age = 3;
  r[1] = WithSample(0, 0.1f), r[1].confidence = 4.0f, r[1].history.age = 5;
  r[2].confidence = 6.0f, r[2].history.age = 100;  // no sample: counts for confidence, not for age
  r[3] = WithSample(0, 0.2f), r[3].confidence = 50.0f, r[3].history.age = 200;
  g.objectId[3] = -1;  // background: counts for nothing
  ReservoirDiagnostics d;
  MeasureOutputReservoirs(g, r, d);
  EXPECT_DOUBLE_EQ(d.confidenceMean, 4.0);
  EXPECT_NEAR(d.confidenceSd, std::sqrt(8.0 / 3.0), 1e-12);  // population sd of {2, 4, 6}
  EXPECT_DOUBLE_EQ(d.ageMean, 4.0);
}

// Whole frames of the flagship at a small size: what each preset's reservoirs say.
TEST(ReservoirDiagnostics, FramesReportAgesSpreadAndDuplicationThePresetsImply) {
  const Sequence seq = LoadSequence("sequences/window_bars_pan.json");
  FrameLoop loop(seq, 96, 54);
  Pipeline ris(FindPreset("ris")->settings), temporal(FindPreset("temporal")->settings),
      unbiased(FindPreset("restir-unbiased")->settings);
  loop.Play(0, 4, [&](int frame) {
    FrameInputs in = loop.Inputs(seq.seed);
    in.measureReservoirs = true;
    const FrameResult a = ris.RenderFrame(in), b = temporal.RenderFrame(in), c = unbiased.RenderFrame(in);
    // ris: fresh samples every frame, confidence 1 everywhere, no pass after initial sampling.
    EXPECT_EQ(a.diagnostics.ageMean, 0.0);
    EXPECT_EQ(a.diagnostics.confidenceSd, 0.0);
    EXPECT_EQ(a.diagnostics.contributingSpatial, a.diagnostics.contributingInitial);
    // Temporal reuse: a sample is at most `frame` frames old, and on frames after the first some are older.
    EXPECT_LE(b.diagnostics.ageMean, double(frame));
    if (frame > 0) {
      EXPECT_GT(b.diagnostics.ageMean, 0.0);
      EXPECT_GT(b.diagnostics.confidenceSd, 0.0);
    }
    // Spatial reuse copies neighbours' samples (ris and temporal have none in a window of distinct points).
    EXPECT_GT(c.diagnostics.duplicateFraction, a.diagnostics.duplicateFraction);
    for (const FrameResult* r : {&a, &b, &c}) {
      const ReservoirDiagnostics& d = r->diagnostics;
      for (double f :
           {d.contributingInitial, d.contributingTemporal, d.contributingSpatial, d.contributingShaded}) {
        EXPECT_GE(f, 0.0);
        EXPECT_LE(f, 1.0);
      }
      // A shaded contribution needs a sample its target accepted: visibility only removes.
      EXPECT_LE(d.contributingShaded, d.contributingSpatial + 1e-12);
    }
  });
}

}  // namespace
}  // namespace restir
