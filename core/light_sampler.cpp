#include "core/light_sampler.h"

namespace restir {

LightSampler::LightSampler(const std::vector<LightTriangle>& lights, LightSelection selection)
    : lights_(&lights) {
  std::vector<float> weights(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    const float power = LightPower(lights[i]);
    const bool on = power > 0.0f && std::isfinite(power);
    weights[i] = on ? (selection == LightSelection::kPower ? power : 1.0f) : 0.0f;
  }
  table_ = AliasTable(weights);
}

LightSample LightSampler::Sample(float uSelect, float uCoin, float uPoint0, float uPoint1) const {
  LightSample s;
  s.lightId = table_.Sample(uSelect, uCoin);
  const LightTriangle& t = (*lights_)[s.lightId];
  s.position = SampleTrianglePoint(t, uPoint0, uPoint1);
  s.normal = t.normal;
  s.radiance = t.radiance;
  s.pdfArea = PdfArea(s.lightId);
  return s;
}

}  // namespace restir
