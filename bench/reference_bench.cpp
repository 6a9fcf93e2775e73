// Reference benchmark (issue 16): the converged reference (sim/reference/reference.cpp) of one frame of
// sequences/window_bars_pan.json against its ray floor, measured in the same run:
//
//   reference   RenderReference from an empty cache (pilot, allocation, main pass), the fastest of `reps`.
//   ray floor   the exact rays that render traced (recorded through a RayHook, sim/scene/embree_probe.h), traced alone
//               with Embree in the reference's own batching: each thread's shadow rays in the order it traced
//               them, as arrays (ShadowRaysSoa, as the light-draw kernel hands them to Embree) through
//               EmbreeScene::OccludedBatch in blocks of kFloorBlock, and its BSDF rays with rtcIntersect1 one at
//               a time; parallel over the blocks. The fastest of `reps`.
//   ratio       ray floor / reference: the share of the reference's wall time Embree alone would need (1 = the
//               reference traces at the ray floor; the target is >= 0.8). The renders and the floor's
//               traces alternate, one of each per rep, and floor_ratio is the median of the reps' own ratios: on a
//               shared machine whose speed drifts by tens of percent within a minute, a ratio of two runs seconds
//               apart is steadier than a ratio of two minima taken a minute apart (floor_ratio_of_minima, also
//               reported).
//
// Two budgets: BM_Reference/0 at the flagship's render.referenceSpp (README command 1's reference; overridden by
// RESTIR_BENCH_REFERENCE_SPP), BM_Reference/768 at the 768 spp issue 16 measured the reference at, where the
// per-pixel work (light distributions, pilot) weighs less against the rays.
//
// Counters: ms_reference, ms_ray_floor, floor_ratio, rays, mrays_per_s (the reference's), floor_mrays_per_s,
// samples_per_pixel, mean_relative_standard_error (sim/reference/reference.h MeanRelativeStandardError).
// Environment: RESTIR_BENCH_WIDTH / _HEIGHT (default 640x360, README command 1's size),
// RESTIR_BENCH_REFERENCE_SPP, RESTIR_BENCH_REPS (default 2), RESTIR_BENCH_FRAME (default 8),
// RESTIR_BENCH_SIMD (a core/simd.h target name: the kernels' target, default the best), RESTIR_BENCH_PROFILE=1 (only
// the timed renders: for perf record).
#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/simd.h"
#include "sim/scene/embree_probe.h"
#include "sim/scene/embree_scene.h"
#include "sim/run/frame_loop.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

constexpr size_t kFloorBlock = 256;

struct ThreadRays {
  std::vector<ShadowRay> shadow;  // in the order this thread traced them
  std::vector<ShadowRay> bsdf;    // closest-hit queries (tmax may be +inf)
  std::vector<float> soa[7];      // `shadow` as arrays: origin, direction, length
  ShadowRaysSoa Block(size_t begin, size_t end) const {
    ShadowRaysSoa r;
    for (int c = 0; c < 3; ++c) {
      r.org[c] = soa[c].data() + begin;
      r.dir[c] = soa[3 + c].data() + begin;
    }
    r.tmax = soa[6].data() + begin;
    r.count = end - begin;
    return r;
  }
};

// Records every query of a render, per thread (so each thread's rays keep their order and batching).
class Capture final : public RayHook {
 public:
  void TracedOccluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame, bool) const override {
    rays_.local().shadow.push_back(ShadowRay{org, dir, tmax});
  }
  void TracedIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame, const RawHit&) const override {
    rays_.local().bsdf.push_back(ShadowRay{org, dir, tmax});
  }
  std::vector<ThreadRays> Take() const {
    std::vector<ThreadRays> out;
    for (ThreadRays& t : rays_) out.push_back(std::move(t));
    return out;
  }

 private:
  mutable tbb::enumerable_thread_specific<ThreadRays> rays_;
};

void BM_Reference(benchmark::State& state) {
  if (const char* simd = std::getenv("RESTIR_BENCH_SIMD")) {
    const std::optional<SimdTarget> target = ParseSimdTarget(simd);
    if (!target || !SetSimdTarget(*target)) {
      state.SkipWithError("RESTIR_BENCH_SIMD names no target this machine runs");
      return;
    }
  }
  const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/sequences/window_bars_pan.json");
  const int w = EnvInt("RESTIR_BENCH_WIDTH", 640), h = EnvInt("RESTIR_BENCH_HEIGHT", 360);
  const int reps = std::max(1, EnvInt("RESTIR_BENCH_REPS", 2));
  FrameLoop loop(seq, w, h);
  loop.BeginFrame(std::min(EnvInt("RESTIR_BENCH_FRAME", 8), seq.frameCount - 1));
  ReferenceParams params;
  params.samplesPerPixel = state.range(0) > 0 ? static_cast<int>(state.range(0))
                                             : EnvInt("RESTIR_BENCH_REFERENCE_SPP", seq.defaults.referenceSpp);
  if (EnvInt("RESTIR_BENCH_PROFILE", 0)) {  // only the renders, for perf record
    for (auto _ : state)
      for (int r = 0; r < reps; ++r)
        benchmark::DoNotOptimize(loop.Reference(params).rays);
    return;
  }
  // The rays, recorded by one render; then the timed renders and floors, alternating.
  Capture capture;
  SetRayHook(loop.Scene(), &capture);
  const ReferenceImage captured = loop.Reference(params);
  SetRayHook(loop.Scene(), nullptr);
  std::vector<ThreadRays> rays = capture.Take();
  for (ThreadRays& t : rays)
    for (const ShadowRay& r : t.shadow) {
      for (int c = 0; c < 3; ++c) {
        t.soa[c].push_back(r.org[c]);
        t.soa[3 + c].push_back(r.dir[c]);
      }
      t.soa[6].push_back(r.tmax);
    }
  struct Block {
    const ThreadRays* t;
    size_t begin, end;
    bool bsdf;
  };
  std::vector<Block> blocks;
  size_t shadowCount = 0, bsdfCount = 0;
  for (const ThreadRays& t : rays) {
    for (size_t b = 0; b < t.shadow.size(); b += kFloorBlock)
      blocks.push_back({&t, b, std::min(t.shadow.size(), b + kFloorBlock), false});
    for (size_t b = 0; b < t.bsdf.size(); b += kFloorBlock)
      blocks.push_back({&t, b, std::min(t.bsdf.size(), b + kFloorBlock), true});
    shadowCount += t.shadow.size();
    bsdfCount += t.bsdf.size();
  }
  const EmbreeScene& scene = loop.Scene();
  const auto traceFloor = [&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks.size()), [&](const tbb::blocked_range<size_t>& range) {
      uint8_t occluded[kFloorBlock];
      for (size_t k = range.begin(); k != range.end(); ++k) {
        const Block& b = blocks[k];
        if (b.bsdf) {
          for (size_t i = b.begin; i < b.end; ++i)
            benchmark::DoNotOptimize(IntersectRaw(scene, b.t->bsdf[i].org, b.t->bsdf[i].dir, b.t->bsdf[i].tmax));
        } else {
          scene.OccludedBatch(b.t->Block(b.begin, b.end), occluded);
          benchmark::DoNotOptimize(occluded[0]);
        }
      }
    });
  };
  ReferenceImage best;
  double bestMs = 1e300, floorMs = 1e300;
  std::vector<double> ratios;
  for (auto _ : state) {
    for (int r = 0; r < reps; ++r) {
      auto t0 = Clock::now();
      ReferenceImage ref = loop.Reference(params);
      const double ms = MsSince(t0);
      t0 = Clock::now();
      traceFloor();
      const double floor = MsSince(t0);
      ratios.push_back(floor / ms);
      floorMs = std::min(floorMs, floor);
      if (ms < bestMs) {
        bestMs = ms;
        best = std::move(ref);
      }
    }
  }
  std::sort(ratios.begin(), ratios.end());
  const size_t half = ratios.size() / 2;
  const double medianRatio = ratios.size() % 2 ? ratios[half] : 0.5 * (ratios[half - 1] + ratios[half]);
  const double rayCount = double(best.rays);
  state.counters["ms_reference"] = bestMs;
  state.counters["ms_ray_floor"] = floorMs;
  state.counters["floor_ratio"] = medianRatio;
  state.counters["floor_ratio_of_minima"] = floorMs / bestMs;
  state.counters["rays"] = rayCount;
  state.counters["captured_rays"] = double(shadowCount + bsdfCount);
  state.counters["capture_complete"] = shadowCount + bsdfCount == captured.rays ? 1 : 0;
  state.counters["mrays_per_s"] = rayCount / bestMs * 1e-3;
  state.counters["floor_mrays_per_s"] = double(shadowCount + bsdfCount) / floorMs * 1e-3;
  state.counters["samples_per_pixel"] = double(best.samples) / (double(w) * h);
  // The reference's own noise at this budget: with ms_reference, its efficiency 1 / (error² × time).
  state.counters["mean_relative_standard_error"] = MeanRelativeStandardError(best);
  state.counters["spp_budget"] = params.samplesPerPixel;
}

BENCHMARK(BM_Reference)->Arg(0)->Arg(768)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace restir

BENCHMARK_MAIN();
