// Reference quality benchmark (issue 40): how converged the reference (sim/reference/reference.cpp) is on every
// shipped sequence at its own defaults, and what that costs. One benchmark per sequence (sequences/*.json and
// sequences/regimes/*.json), each rendering the reference of a few frames from an empty cache:
//
//   mean_rel_se, p99_rel_se  MeasureReferenceConvergence over the frames' lit pixels (mean of the frames' values; the
//                            issue's goals are 2% and 10%)
//   dark_sampled             pixels per frame that took samples and came out exactly 0 with no spread
//   rays_per_px, ms          the reference's rays per pixel and wall time per frame
//   rel_var_per_ray          mean_rel_se² × rays_per_px: the relative variance one ray per pixel would leave,
//                            the sampler's efficiency with the budget taken out (lower is better)
//
//   spp, capped_frames       mean samples per sampled pixel, pilot included; frames whose error target hit the cap
//
// Environment: RESTIR_BENCH_FRAMES (default 3: the first, middle and last frame), RESTIR_BENCH_WIDTH / _HEIGHT
// (default: the sequence's); the sequence's reference defaults (its referenceError and referenceSppCap, else its
// referenceSpp) unless RESTIR_BENCH_REFERENCE_SPP (a fixed budget), RESTIR_BENCH_REFERENCE_ERROR (the error target)
// or RESTIR_BENCH_REFERENCE_CAP (its cap) say otherwise; RESTIR_BENCH_REFERENCE_LEARN=0 (the
// unshadowed selection, without the pilot's visibility learning: the before of issue 40);
// RESTIR_BENCH_REFERENCE_DIFFERENCE=0 (without the difference estimator at diffuse receivers);
// RESTIR_BENCH_REFERENCE_SPREAD=0 (the pilot's relative variances as they came, not spread to their neighbours);
// RESTIR_BENCH_REFERENCE_GUIDE=0 (the indirect paths' first direction by the BSDF alone, without the pilot's guide).
// The reference has the indirect bounces of the sequence's own presets (window_bars_sun's and shutter_reveal_sun's:
// one).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/estimator/presets.h"
#include "sim/reference/reference.h"
#include "sim/run/frame_loop.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

const std::vector<std::string>& Sequences() {
  static const std::vector<std::string> names = {
      "window_bars_pan",     "sun_street_pan",     "static_room",          "asset_table",
      "moving_occluder",     "smoke",              "regimes/door_ajar",    "regimes/many_rooms",
      "regimes/sliding_reveal", "regimes/sun_street_night", "window_bars_sun", "shutter_reveal_sun"};
  return names;
}

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

double EnvDouble(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atof(v) : fallback;
}

void BM_ReferenceQuality(benchmark::State& state) {
  const std::string name = Sequences()[static_cast<size_t>(state.range(0))];
  state.SetLabel(name);
  const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/sequences/" + name + ".json");
  const int w = EnvInt("RESTIR_BENCH_WIDTH", seq.width), h = EnvInt("RESTIR_BENCH_HEIGHT", seq.height);
  const int frames = std::max(1, std::min(EnvInt("RESTIR_BENCH_FRAMES", 3), seq.frameCount));
  ReferenceParams params;
  params.samplesPerPixel = EnvInt("RESTIR_BENCH_REFERENCE_SPP", seq.defaults.referenceSpp);
  const bool budget = std::getenv("RESTIR_BENCH_REFERENCE_SPP") != nullptr;
  params.targetRelativeError = budget ? 0.0 : EnvDouble("RESTIR_BENCH_REFERENCE_ERROR", seq.defaults.referenceError);
  if (params.targetRelativeError > 0.0)
    params.maxMeanSamplesPerPixel = EnvInt("RESTIR_BENCH_REFERENCE_CAP", seq.defaults.referenceSppCap);
  params.learnVisibility = EnvInt("RESTIR_BENCH_REFERENCE_LEARN", 1) != 0;
  params.differenceShadows = EnvInt("RESTIR_BENCH_REFERENCE_DIFFERENCE", 1) != 0;
  params.projectedSolidAngleDraws = EnvInt("RESTIR_BENCH_REFERENCE_PSA", 0) != 0;
  params.spreadRelativeVariance = EnvInt("RESTIR_BENCH_REFERENCE_SPREAD", 1) != 0;
  params.guidePaths = EnvInt("RESTIR_BENCH_REFERENCE_GUIDE", 1) != 0;
  // The indirect light the sequence's own presets ask for, as a run's reference has it.
  for (const std::string& preset : seq.defaults.presets)
    if (const Preset* p = FindPreset(preset))
      params.indirectBounces = std::max(params.indirectBounces, p->settings.indirect.bounces);
  FrameLoop loop(seq, w, h);
  double meanRel = 0.0, p99 = 0.0, dark = 0.0, rays = 0.0, ms = 0.0, capped = 0.0, spp = 0.0;
  for (auto _ : state) {
    meanRel = p99 = dark = rays = ms = capped = spp = 0.0;
    for (int k = 0; k < frames; ++k) {
      const int frame = frames == 1 ? 0 : static_cast<int>(int64_t{k} * (seq.frameCount - 1) / (frames - 1));
      loop.BeginFrame(frame);
      const auto t0 = std::chrono::steady_clock::now();
      const ReferenceImage ref = loop.Reference(params);
      ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const ReferenceConvergence noise = MeasureReferenceConvergence(ref);
      meanRel += noise.meanRelative;
      p99 += noise.p99Relative;
      dark += double(noise.darkSampled);
      rays += double(ref.rays) / (double(w) * h);
      spp += ref.allocation.meanSamplesPerPixel;
      capped += ref.allocation.scale < 1.0 ? 1.0 : 0.0;
    }
  }
  state.counters["mean_rel_se"] = meanRel / frames;
  state.counters["p99_rel_se"] = p99 / frames;
  state.counters["dark_sampled"] = dark / frames;
  state.counters["rays_per_px"] = rays / frames;
  state.counters["ms"] = ms / frames;
  state.counters["spp"] = spp / frames;
  state.counters["capped_frames"] = capped;
  state.counters["rel_var_per_ray"] = (meanRel / frames) * (meanRel / frames) * (rays / frames);
}

BENCHMARK(BM_ReferenceQuality)->DenseRange(0, 11)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace restir
BENCHMARK_MAIN();
