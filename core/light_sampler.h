// Source distribution of light candidates (DESIGN §4): a light chosen with probability proportional to its
// power through an alias table (or uniformly), then a uniform point on it. p_src(y) = P(light) / area(light).
#pragma once

#include <vector>

#include "core/alias_table.h"
#include "core/light.h"

namespace restir {

enum class LightSelection : uint8_t { kPower, kUniform };

class LightSampler {
 public:
  LightSampler() = default;
  // `lights` must outlive the sampler. Lights with zero radiance (switched off) get probability 0 in both modes.
  LightSampler(const std::vector<LightTriangle>& lights, LightSelection selection);

  bool Empty() const { return table_.Empty(); }
  // Probability of choosing light `id`.
  float SelectionPmf(uint32_t id) const { return table_.Pmf(id); }
  // p_src of a point on light `id`, area measure.
  float PdfArea(uint32_t id) const {
    const float a = (*lights_)[id].area;
    return a > 0.0f ? table_.Pmf(id) / a : 0.0f;
  }
  // Draws a light sample from four uniforms: two choose the light, two the point on it.
  LightSample Sample(float uSelect, float uCoin, float uPoint0, float uPoint1) const;

  const std::vector<LightTriangle>& Lights() const { return *lights_; }

 private:
  const std::vector<LightTriangle>* lights_ = nullptr;
  AliasTable table_;
};

}  // namespace restir
