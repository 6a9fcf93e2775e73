// The run-level figures that `report` (summary.json, report.html), `sweep` (sweep.csv, sweep.md) and `compare`
// quote, each defined once (docs/metrics.md "Summary figures"), so the three never disagree.
#pragma once

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

// Σ luma_sum / Σ reference_luma_sum over the frames (the accumulated luma ratio); NaN without reference light.
double AccumulatedLumaRatio(const std::vector<double>& lumaSums, const std::vector<double>& referenceLumaSums);

}  // namespace restir
