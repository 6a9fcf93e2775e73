// The run-level figures that `report` (summary.json, report.html), `sweep` (sweep.csv, sweep.md) and `compare`
// quote, each defined once (docs/metrics.md "Summary figures"), so the three never disagree.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace restir {

// Whether a metrics.csv column's first frame is left out of its mean: the timings (the first frame warms the
// caches and has no temporal input, so it is not what a frame costs) and the frame-to-frame columns (flicker,
// stability_luma_rmse, temporal_acceptance), which have no previous frame there and read 0.
bool MeanSkipsFirstFrame(const std::string& column);

// A column's mean over a preset's frames, in frame order (NaN for none): the first frame left out where
// MeanSkipsFirstFrame and there is more than one.
double ColumnMean(const std::string& column, const std::vector<double>& values);

// The mean of a *_disocc column over the frames with recently disoccluded pixels (disocc_recent_fraction > 0),
// the post-reveal windows; NaN when there are none.
double PostRevealMean(const std::vector<double>& values, const std::vector<double>& disoccRecentFraction);

// Efficiency 1 / (relmse · seconds per frame) (DESIGN §9) from the two columns' means; NaN unless both are
// positive.
double Efficiency(double meanRelmse, double meanMsFrame);

// The Pareto front of points (cost[i], error[i]), lower better in both: 1 where no other point is at most as costly
// and as wrong and better in one. Non-finite points are never on it and dominate nothing.
std::vector<uint8_t> ParetoFront(const std::vector<double>& cost, const std::vector<double>& error);

// Σ luma_sum / Σ reference_luma_sum over the frames (the accumulated luma ratio); NaN without reference light.
double AccumulatedLumaRatio(const std::vector<double>& lumaSums, const std::vector<double>& referenceLumaSums);

// Frames are correlated (temporal reuse carries error from frame to frame), so the spread of a run's frames is read
// from the means of batches of consecutive frames: kBatchFrames each, a trailing partial batch dropped, and none
// read from fewer than kMinBatches batches (`compare`'s test and the intervals below).
constexpr int kBatchFrames = 8;
constexpr int kMinBatches = 4;

// The error metrics that carry an interval: each has a *_ref_sd column beside it in metrics.csv.
inline const char* const kIntervalMetrics[] = {"rmse", "luma_rmse", "relmse", "rmspe"};

// A metric's 95% interval for its mean over a run's frames (docs/metrics.md, "Intervals"), from two independent
// sources of error: the estimator's (other seeds would give other frames) and the reference's (another reference
// would move every error).
struct MetricInterval {
  double mean = NAN;  // ColumnMean
  // The estimator's part: with --ensemble, the members' spread (seedSds below); else the standard error of the mean
  // from the frames' own spread, the standard deviation of the batch means over sqrt(batches), which also holds the
  // scene's real change along the sequence, so it errs wide. NaN below kMinBatches batches.
  double estimatorSd = NAN;
  // The reference's share: per frame the metric's *_ref_sd, summed linearly over frames that share one reference
  // (same reference_luma_sum: a static stretch renders one reference) and in quadrature across references, over
  // the frame count.
  double referenceSd = NAN;
  // t sqrt(estimatorSd² + referenceSd²), t Student's 97.5% quantile with the Welch–Satterthwaite degrees of
  // freedom (batches − 1 for the estimator's part, read from few batches; the reference's part known); 1.96
  // referenceSd when the estimator's part is unknown.
  double halfWidth = NAN;
  bool referenceDominated = false;  // the reference's part is the larger (or the only one known)
};

// Student's t 97.5% quantile with `dof` degrees of freedom (a two-sided 95% interval): the table's values to 30,
// then 1.96 + 2.37 / dof (within 0.002 of the exact quantile above 30).
double StudentTQuantile975(int dof);

// `values`, `referenceSds` and `referenceKeys` (each frame's reference_luma_sum) in frame order. `seedSds` (the
// metric's *_seed_sd column, from --ensemble), when given, replaces the batch means as the estimator's part: the
// mean over frames of the members' spread, which bounds the spread of a mean over frames from above (frames of one
// seed move together at worst), read with the normal quantile (many frames' spreads averaged).
MetricInterval ColumnInterval(const std::vector<double>& values, const std::vector<double>& referenceSds,
                              const std::vector<double>& referenceKeys, const std::vector<double>& seedSds = {});

}  // namespace restir
