#include "core/alias_table.h"

namespace restir {

AliasTable::AliasTable(const std::vector<float>& weights) {
  const size_t n = weights.size();
  double total = 0.0;
  for (float w : weights) total += w > 0.0f ? static_cast<double>(w) : 0.0;
  totalWeight_ = total;
  if (n == 0 || !(total > 0.0)) {
    bins_.clear();
    return;
  }
  bins_.resize(n);
  // Scaled probabilities p_i * n, split into under- and over-full work lists (Vose 1991). Double precision
  // keeps the mass exact enough that leftovers are only rounding.
  std::vector<double> scaled(n);
  std::vector<uint32_t> small, large;
  small.reserve(n);
  large.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const double p = (weights[i] > 0.0f ? weights[i] : 0.0) / total;
    bins_[i].pmf = static_cast<float>(p);
    scaled[i] = p * static_cast<double>(n);
    (scaled[i] < 1.0 ? small : large).push_back(static_cast<uint32_t>(i));
  }
  while (!small.empty() && !large.empty()) {
    const uint32_t s = small.back();
    small.pop_back();
    const uint32_t l = large.back();
    bins_[s].q = static_cast<float>(scaled[s]);
    bins_[s].alias = l;
    scaled[l] = (scaled[l] + scaled[s]) - 1.0;
    if (scaled[l] < 1.0) {
      large.pop_back();
      small.push_back(l);
    }
  }
  // Whatever is left holds (up to rounding) exactly one bin of mass.
  for (uint32_t i : large) {
    bins_[i].q = 1.0f;
    bins_[i].alias = i;
  }
  uint32_t anyPositive = 0;
  while (bins_[anyPositive].pmf <= 0.0f) ++anyPositive;
  for (uint32_t i : small) {
    // Rounding can strand an entry here; a zero-weight one must still never be returned.
    const bool positive = bins_[i].pmf > 0.0f;
    bins_[i].q = positive ? 1.0f : 0.0f;
    bins_[i].alias = positive ? i : anyPositive;
  }
}

}  // namespace restir
