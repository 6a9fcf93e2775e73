// Source distribution of light candidates (DESIGN §4): a light chosen with probability proportional to its
// power through an alias table (or uniformly), then a uniform point on it. p_src(y) = P(light) / area(light).
#pragma once

#include <cstdint>
#include <vector>

#include "core/alias_table.h"
#include "core/light.h"

namespace restir {

enum class LightSelection : uint8_t { kPower, kUniform };

// The sampler as structure-of-arrays, one entry per light, for the SIMD kernels' gathers (core/ris_kernel.h).
// Every value is a copy of what LightSampler::Sample reads or computes, so a kernel reading it reproduces Sample
// bit for bit. Built once with the sampler (once per frame).
struct LightSamplerSoa {
  std::vector<float> aliasQ;        // alias-table bin: probability of keeping the bin's own index
  std::vector<int32_t> aliasIndex;  // alias-table bin: the other index
  std::vector<float> p0[3];         // LightTriangle::p0, x y z
  std::vector<float> e1[3];         // LightTriangle::e1
  std::vector<float> e2[3];         // LightTriangle::e2
  std::vector<float> normal[3];     // LightTriangle::normal
  std::vector<float> radiance[3];   // LightTriangle::radiance, r g b
  std::vector<float> pdfArea;       // LightSampler::PdfArea(id)
  // The alias-table bin two to a 64-bit word, aliasQ in the low half, so a kernel fetches both per gathered
  // element.
  std::vector<uint64_t> aliasPairs;
  // A light's other fields in one 64-byte line, so a kernel fetches all of them with one aligned load per lane:
  // p0, e1, e2, normal (x y z each), radiance (r g b), pdfArea.
  struct alignas(64) Record {
    float v[16];
  };
  std::vector<Record> records;
  uint32_t Size() const { return static_cast<uint32_t>(pdfArea.size()); }
};

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
  // SoA view of the table and the lights (empty when the sampler is empty).
  const LightSamplerSoa& Soa() const { return soa_; }

 private:
  const std::vector<LightTriangle>* lights_ = nullptr;
  AliasTable table_;
  LightSamplerSoa soa_;
};

}  // namespace restir
