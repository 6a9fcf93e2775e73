// HDR-FLIP's cost per preset and frame (DESIGN §6 `flip`) at 640x360 on a plausible pair: the reference a smooth
// HDR gradient (luminance over 2^17, 9 exposures) with mild texture, each test image that reference with
// per-pixel multiplicative noise, as a path-traced estimate of it looks.
//
//   BM_FlipLegacy     the pre-optimisation implementation (tests/sim/metrics/flip_legacy.h), the "before": one call per
//                     preset and frame, doing the reference's half of the work every time.
//   BM_FlipOneCall    today's HdrFlip(reference image, test): the same one-call interface.
//   BM_FlipReference  FlipReference construction: the reference's half, once per frame (counter MB: its size).
//   BM_FlipPrepared   HdrFlip(FlipReference, test): what each preset costs once the frame's FlipReference exists.
//   BM_FlipFrame/8    a frame of 8 presets as the runner does it: one FlipReference, 8 HdrFlip calls; the time is
//                     the frame's, the counter s_per_preset its eighth.
//
// Times are wall-clock (UseRealTime): the work runs on TBB's threads. Thread count: TBB's default (all cores)
// unless RESTIR_BENCH_THREADS is set; SIMD target: the best this CPU runs unless RESTIR_BENCH_SIMD names one
// (sse4, avx2, avx512; the legacy code is plain C++ and ignores it).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "core/simd.h"
#include "sim/metrics/flip.h"
#include "tests/sim/metrics/flip_legacy.h"

namespace restir {
namespace {

constexpr int kWidth = 640, kHeight = 360;

ImageRgb GradientReference() {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ImageRgb img(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float s = float(x) / float(kWidth - 1), t = float(y) / float(kHeight - 1);
      const float lum = 0.01f * std::exp2(17.0f * s) * (0.9f + 0.2f * u(rng));  // median near 2^8.5 below max
      img.pixels[size_t(y) * kWidth + x] = Vec3(lum * (0.8f + 0.4f * t), lum, lum * (1.2f - 0.4f * t));
    }
  return img;
}

ImageRgb NoisyEstimate(const ImageRgb& reference, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  ImageRgb img = reference;
  for (Vec3& p : img.pixels) p = Vec3(p.x * u(rng), p.y * u(rng), p.z * u(rng));
  return img;
}

struct Pair {
  ImageRgb reference = GradientReference();
  std::vector<ImageRgb> tests;
  Pair() {
    for (uint32_t s = 0; s < 8; ++s) tests.push_back(NoisyEstimate(reference, 100 + s));
  }
};
const Pair& Images() {
  static const Pair pair;
  return pair;
}

std::unique_ptr<tbb::global_control> Threads() {
  const char* env = std::getenv("RESTIR_BENCH_THREADS");
  if (!env) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                               static_cast<size_t>(std::atoi(env)));
}

void BM_FlipLegacy(benchmark::State& state) {
  const auto threads = Threads();
  const Pair& p = Images();
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(legacy_flip::HdrFlip(p.reference, p.tests[i++ % 8]));
  FlipExposureRange range;
  legacy_flip::HdrFlip(p.reference, p.tests[0], kFlipDefaultPpd, &range);
  state.counters["exposures"] = range.count;
}
BENCHMARK(BM_FlipLegacy)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_FlipOneCall(benchmark::State& state) {
  const auto threads = Threads();
  const Pair& p = Images();
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(HdrFlip(p.reference, p.tests[i++ % 8]));
}
BENCHMARK(BM_FlipOneCall)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_FlipReference(benchmark::State& state) {
  const auto threads = Threads();
  const Pair& p = Images();
  for (auto _ : state) {
    FlipReference prepared(p.reference);
    benchmark::DoNotOptimize(prepared);
  }
  state.counters["MB"] = double(FlipReference(p.reference).Bytes()) / 1048576.0;
}
BENCHMARK(BM_FlipReference)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_FlipPrepared(benchmark::State& state) {
  const auto threads = Threads();
  const Pair& p = Images();
  const FlipReference prepared(p.reference);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(HdrFlip(prepared, p.tests[i++ % 8]));
}
BENCHMARK(BM_FlipPrepared)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_FlipFrame(benchmark::State& state) {
  const auto threads = Threads();
  const Pair& p = Images();
  const int presets = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const FlipReference prepared(p.reference);
    for (int i = 0; i < presets; ++i) benchmark::DoNotOptimize(HdrFlip(prepared, p.tests[size_t(i) % 8]));
  }
  // Seconds per preset (printed with an SI prefix: "m" is ms).
  state.counters["s_per_preset"] = benchmark::Counter(
      double(presets), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_FlipFrame)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace
}  // namespace restir

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  if (const char* simd = std::getenv("RESTIR_BENCH_SIMD")) {
    const std::optional<restir::SimdTarget> target = restir::ParseSimdTarget(simd);
    if (!target || !restir::SetSimdTarget(*target)) {
      std::fprintf(stderr, "flip_bench: RESTIR_BENCH_SIMD=%s is not a target this CPU runs\n", simd);
      return 2;
    }
  }
  benchmark::AddCustomContext("simd", restir::ActiveSimdTargetName());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
