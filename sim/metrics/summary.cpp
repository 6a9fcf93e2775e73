#include "sim/metrics/summary.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace restir {

bool MeanSkipsFirstFrame(const std::string& column) {
  return column.rfind("ms_", 0) == 0 || column == "flicker" || column == "stability_luma_rmse" ||
         column == "temporal_acceptance";
}

double ColumnMean(const std::string& column, const std::vector<double>& values) {
  const size_t first = values.size() > 1 && MeanSkipsFirstFrame(column) ? 1 : 0;
  if (values.size() <= first) return NAN;
  double sum = 0.0;
  for (size_t i = first; i < values.size(); ++i) sum += values[i];
  return sum / static_cast<double>(values.size() - first);
}

double PostRevealMean(const std::vector<double>& values, const std::vector<double>& disoccRecentFraction) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < values.size() && i < disoccRecentFraction.size(); ++i)
    if (disoccRecentFraction[i] > 0.0) sum += values[i], ++n;
  return n ? sum / static_cast<double>(n) : NAN;
}

double Efficiency(double meanRelmse, double meanMsFrame) {
  return meanRelmse > 0.0 && meanMsFrame > 0.0 ? 1.0 / (meanRelmse * meanMsFrame * 1e-3) : NAN;
}

double AccumulatedLumaRatio(const std::vector<double>& lumaSums, const std::vector<double>& referenceLumaSums) {
  double a = 0.0, b = 0.0;
  for (double v : lumaSums) a += v;
  for (double v : referenceLumaSums) b += v;
  return b > 0.0 ? a / b : NAN;
}

double StudentTQuantile975(int dof) {
  static const double table[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                                 2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                                 2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  if (dof < 1) return NAN;
  return dof <= 30 ? table[dof - 1] : 1.96 + 2.37 / dof;
}

MetricInterval ColumnInterval(const std::vector<double>& values, const std::vector<double>& referenceSds,
                              const std::vector<double>& referenceKeys, const std::vector<double>& seedSds) {
  MetricInterval r;
  const size_t n = values.size();
  if (n == 0) return r;
  r.mean = ColumnMean("", values);
  const size_t batches = n / kBatchFrames;
  const bool fromSeeds = seedSds.size() == n;
  if (fromSeeds) {
    r.estimatorSd = ColumnMean("", seedSds);
  } else if (batches >= size_t(kMinBatches)) {
    std::vector<double> means(batches, 0.0);
    for (size_t k = 0; k < batches; ++k)
      for (int i = 0; i < kBatchFrames; ++i) means[k] += values[k * kBatchFrames + i] / kBatchFrames;
    double m = 0.0, ss = 0.0;
    for (double x : means) m += x / double(batches);
    for (double x : means) ss += (x - m) * (x - m);
    r.estimatorSd = std::sqrt(ss / double(batches - 1) / double(batches));
  }
  if (referenceSds.size() == n && referenceKeys.size() == n) {
    // Frames sharing a reference in one group; groups in first-appearance order, so the sum is the same bits
    // whatever the input's grouping.
    std::vector<std::pair<double, double>> groups;  // key, Σ sd
    for (size_t i = 0; i < n; ++i) {
      auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == referenceKeys[i]; });
      if (it == groups.end()) groups.emplace_back(referenceKeys[i], referenceSds[i]);
      else it->second += referenceSds[i];
    }
    double var = 0.0;
    for (const auto& g : groups) var += g.second * g.second;
    r.referenceSd = std::sqrt(var) / double(n);
  }
  const bool hasEstimator = !std::isnan(r.estimatorSd);
  const double est = hasEstimator ? r.estimatorSd : 0.0;
  // Welch–Satterthwaite: the estimator's part is read from batches − 1 degrees of freedom, the reference's is
  // known (its replicates give it per pixel), so the sum's effective degrees of freedom lie between the two.
  const double ref2 = std::isnan(r.referenceSd) ? 0.0 : r.referenceSd * r.referenceSd;
  const double dof = est > 0.0 && !fromSeeds
                         ? (est * est + ref2) * (est * est + ref2) / (est * est * est * est / double(batches - 1))
                         : INFINITY;
  const double q = dof < 1e6 ? StudentTQuantile975(static_cast<int>(std::floor(dof))) : 1.96;
  if (!std::isnan(r.referenceSd)) {
    r.halfWidth = q * std::sqrt(est * est + r.referenceSd * r.referenceSd);
    r.referenceDominated = r.referenceSd > est;
  } else if (hasEstimator) {
    r.halfWidth = q * r.estimatorSd;
  }
  return r;
}

std::vector<uint8_t> ParetoFront(const std::vector<double>& cost, const std::vector<double>& error) {
  const size_t n = std::min(cost.size(), error.size());
  std::vector<uint8_t> front(n, 0);
  for (size_t a = 0; a < n; ++a) {
    if (!std::isfinite(cost[a]) || !std::isfinite(error[a])) continue;
    front[a] = 1;
    for (size_t b = 0; b < n && front[a]; ++b) {
      if (b == a || !std::isfinite(cost[b]) || !std::isfinite(error[b])) continue;
      const bool noWorse = cost[b] <= cost[a] && error[b] <= error[a];
      const bool better = cost[b] < cost[a] || error[b] < error[a];
      if (noWorse && better) front[a] = 0;
    }
  }
  return front;
}

}  // namespace restir
