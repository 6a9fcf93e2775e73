#include "core/light_sampler.h"

#include <cstring>

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
  if (table_.Empty()) return;
  const size_t n = lights.size();
  soa_.aliasQ.resize(n);
  soa_.aliasIndex.resize(n);
  soa_.pdfArea.resize(n);
  for (int c = 0; c < 3; ++c) {
    soa_.p0[c].resize(n);
    soa_.e1[c].resize(n);
    soa_.e2[c].resize(n);
    soa_.normal[c].resize(n);
    soa_.radiance[c].resize(n);
  }
  for (size_t i = 0; i < n; ++i) {
    const uint32_t id = static_cast<uint32_t>(i);
    const LightTriangle& t = lights[i];
    soa_.aliasQ[i] = table_.KeepProbability(id);
    soa_.aliasIndex[i] = static_cast<int32_t>(table_.Alias(id));
    soa_.pdfArea[i] = PdfArea(id);
    for (int c = 0; c < 3; ++c) {
      soa_.p0[c][i] = t.p0[c];
      soa_.e1[c][i] = t.e1[c];
      soa_.e2[c][i] = t.e2[c];
      soa_.normal[c][i] = t.normal[c];
      soa_.radiance[c][i] = t.radiance[c];
    }
  }
  auto bits = [](float v) {
    uint32_t b;
    std::memcpy(&b, &v, sizeof(b));
    return static_cast<uint64_t>(b);
  };
  const std::vector<float>* fields[16] = {&soa_.p0[0],     &soa_.p0[1],     &soa_.p0[2],     &soa_.e1[0],
                                          &soa_.e1[1],     &soa_.e1[2],     &soa_.e2[0],     &soa_.e2[1],
                                          &soa_.e2[2],     &soa_.normal[0], &soa_.normal[1], &soa_.normal[2],
                                          &soa_.radiance[0], &soa_.radiance[1], &soa_.radiance[2], &soa_.pdfArea};
  soa_.aliasPairs.resize(n);
  soa_.records.resize(n);
  for (size_t i = 0; i < n; ++i) {
    soa_.aliasPairs[i] = bits(soa_.aliasQ[i]) | (static_cast<uint64_t>(static_cast<uint32_t>(soa_.aliasIndex[i])) << 32);
    for (int f = 0; f < 16; ++f) soa_.records[i].v[f] = (*fields[f])[i];
  }
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
