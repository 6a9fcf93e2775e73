// Walker/Vose alias table: O(1) sampling of a discrete distribution (light selection by power, DESIGN §4).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace restir {

class AliasTable {
 public:
  AliasTable() = default;
  // Weights must be finite and >= 0. All-zero (or empty) weights give an empty table: Sample() is invalid and
  // Pmf() is 0 everywhere. Construction is deterministic (fixed work-list order).
  explicit AliasTable(const std::vector<float>& weights);

  bool Empty() const { return bins_.empty() || totalWeight_ <= 0.0; }
  uint32_t Size() const { return static_cast<uint32_t>(bins_.size()); }
  double TotalWeight() const { return totalWeight_; }
  // Probability of index i.
  float Pmf(uint32_t i) const { return bins_[i].pmf; }
  // Bin i as Sample() reads it: the probability of keeping i, and the alias (for SoA copies in SIMD kernels).
  float KeepProbability(uint32_t i) const { return bins_[i].q; }
  uint32_t Alias(uint32_t i) const { return bins_[i].alias; }
  // uIndex picks the bin, uCoin chooses between the bin and its alias; both uniform in [0, 1).
  uint32_t Sample(float uIndex, float uCoin) const {
    const uint32_t n = Size();
    uint32_t i = static_cast<uint32_t>(uIndex * static_cast<float>(n));
    if (i >= n) i = n - 1;
    return uCoin < bins_[i].q ? i : bins_[i].alias;
  }

 private:
  struct Bin {
    float q = 1.0f;      // probability of keeping i rather than its alias
    uint32_t alias = 0;  // the other index sharing this bin
    float pmf = 0.0f;    // normalised probability of index i
  };
  std::vector<Bin> bins_;
  double totalWeight_ = 0.0;
};

}  // namespace restir
