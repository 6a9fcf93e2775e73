// `restir-sim compare RUN_A RUN_B`: for each preset in both runs and each metrics.csv column, the mean in A and in
// B, the relative change and whether it is significant.
//
// Test: frames are correlated (temporal reuse carries error from frame to frame), so a paired t-test over frames
// would overstate the evidence. Instead the per-frame differences d_t = B_t - A_t over the frames both runs have
// are cut into consecutive batches of kCompareBatch frames (a trailing partial batch is dropped), and a paired
// (one-sample) Student t-test is run on the batch means of d, two-sided at level kCompareAlpha, with
// (batches - 1) degrees of freedom. Fewer than kCompareMinBatches batches: "too few frames". No correction for
// testing many columns at once: expect about 1 in 20 unchanged columns to be flagged.
#pragma once

#include <string>
#include <vector>

#include "sim/metrics/summary.h"

namespace restir {

constexpr int kCompareBatch = kBatchFrames;       // frames per batch
constexpr int kCompareMinBatches = kMinBatches;   // fewer batches: no test
constexpr double kCompareAlpha = 0.05;  // two-sided significance level

enum class CompareVerdict {
  kIdentical,    // every shared frame's value is the same in A and B
  kSignificant,  // p < kCompareAlpha
  kNotSignificant,
  kTooFewFrames,  // fewer than kCompareMinBatches batches
};

struct ColumnComparison {
  std::string column;
  double meanA = 0.0, meanB = 0.0;  // over the frames both runs have
  double relativeChange = 0.0;      // (meanB - meanA) / |meanA|; NaN when meanA == 0 and meanB != 0
  int batches = 0;                  // batch means the test used
  double t = 0.0;                   // the t statistic (0 when not tested)
  double p = 1.0;                   // two-sided p-value (1 when not tested)
  CompareVerdict verdict = CompareVerdict::kTooFewFrames;
  // For the error metrics with a *_ref_sd column (kIntervalMetrics): each run's 95% interval of its mean over the
  // shared frames (summary.h ColumnInterval), so a change can be read against what each run can resolve.
  bool hasIntervals = false;
  MetricInterval intervalA, intervalB;
};

struct PresetComparison {
  std::string preset;
  int frames = 0;                 // frames present in both runs
  int imageHashesDiffering = -1;  // frames whose image_hash differs; -1 when a run has no image_hash column
  std::vector<ColumnComparison> columns;  // columns present in both, in A's order
};

struct RunComparison {
  std::string pathA, pathB;                // the metrics.csv files read
  std::vector<PresetComparison> presets;   // presets in both, in A's order
  std::vector<std::string> onlyInA, onlyInB;  // presets in one run only
  std::vector<std::string> columnsOnlyInA, columnsOnlyInB;
};

// Two-sided p-value of Student's t with `dof` degrees of freedom: P(|T| >= |t|).
double StudentTTwoSidedP(double t, int dof);

// The batch-means test on per-frame paired values (frames in order).
ColumnComparison CompareSeries(const std::string& column, const std::vector<double>& a, const std::vector<double>& b);

// RUN_A and RUN_B are run output directories (or metrics.csv files). Throws InputError on bad input.
RunComparison CompareRuns(const std::string& runA, const std::string& runB);

// The compact table `restir-sim compare` prints.
std::string FormatComparison(const RunComparison& c);

}  // namespace restir
