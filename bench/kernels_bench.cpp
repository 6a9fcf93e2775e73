// Microbenchmarks of the resampling kernels (DESIGN §9): items are pixels.
#include <benchmark/benchmark.h>

#include <vector>

#include "core/gris.h"
#include "core/light_sampler.h"
#include "core/reservoir.h"
#include "core/rng.h"
#include "core/shading.h"

namespace restir {
namespace {

std::vector<LightTriangle> GridLights(int count) {
  std::vector<LightTriangle> lights;
  for (int i = 0; i < count; ++i) {
    const float x = float(i % 12) - 6.0f, z = float(i / 12) - 3.0f;
    LightTriangle t;
    MakeLightTriangle(Vec3(x, 3, z), Vec3(x + 0.3f, 3, z), Vec3(x, 3, z + 0.3f),
                      Vec3(1.0f + float(i % 3), 2.0f, 1.0f + float(i % 5)), t);
    if (glm::dot(t.normal, Vec3(0, -1, 0)) < 0) MakeLightTriangle(Vec3(x, 3, z), Vec3(x, 3, z + 0.3f),
                                                                Vec3(x + 0.3f, 3, z), t.radiance, t);
    lights.push_back(t);
  }
  return lights;
}

// Streaming RIS over M = 32 candidates for one receiver per item (the initial-sampling pass without rays).
void BM_InitialRis(benchmark::State& state) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const LightSampler sampler(lights, LightSelection::kPower);
  ShadingPoint sp;
  sp.geometricNormal = sp.shadingNormal = Vec3(0, 1, 0);
  sp.wo = glm::normalize(Vec3(0.2f, 1, 0.3f));
  uint32_t pixel = 0;
  for (auto _ : state) {
    sp.position = Vec3(float(pixel % 64) * 0.05f, 0, float(pixel / 64 % 64) * 0.05f);
    Sampler s(RngKey{1, 0, pixel++, 1});
    Reservoir r;
    for (int j = 0; j < 32; ++j) {
      const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next(), uSel = s.Next();
      const LightSample y = sampler.Sample(u0, u1, u2, u3);
      const float t = TargetFunction(UnshadowedContribution(sp, y));
      StreamCandidate(r, y, t, RisWeight(t, y.pdfArea), uSel);
    }
    FinalizeRis(r, 32.0f);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_InitialRis);

// A 6-input GRIS combination (canonical + temporal-like + 4 neighbours) with analytic targets, per family.
void BM_GrisCombine(benchmark::State& state) {
  const MisFamily family = static_cast<MisFamily>(state.range(0));
  GrisInput in[6];
  for (int i = 0; i < 6; ++i) in[i] = GrisInput{true, 0.5f + 0.1f * i, 1.0f + i, 1.0f};
  uint32_t pixel = 0;
  for (auto _ : state) {
    const RngKey key{1, 0, pixel++, 3};
    float u[6];
    for (int i = 0; i < 6; ++i) u[i] = UniformFloat(key, i);
    auto target = [&](int j, int i) { return 1.0f + 0.25f * float((i * 7 + j * 3) % 5); };
    benchmark::DoNotOptimize(GrisCombine(family, in, 6, target, u, VisibilityCarry::kWeighted));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_GrisCombine)
    ->Arg(static_cast<int>(MisFamily::kUniform))
    ->Arg(static_cast<int>(MisFamily::kZ))
    ->Arg(static_cast<int>(MisFamily::kBalance))
    ->Arg(static_cast<int>(MisFamily::kPairwise));

}  // namespace
}  // namespace restir

BENCHMARK_MAIN();
