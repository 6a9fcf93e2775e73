#include "sim/metrics/summary.h"

#include <cmath>

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

}  // namespace restir
