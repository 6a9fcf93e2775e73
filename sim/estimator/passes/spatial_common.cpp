#include "sim/estimator/passes/spatial_common.h"

#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>

#include <utility>

#include "sim/estimator/passes/batching.h"
#include "sim/util/clock.h"

namespace restir {

RngKey SpatialRngKey(const FrameView& view, size_t i, int iteration) {
  return RngKey{view.seed, view.frame, static_cast<uint32_t>(i),
                static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)};
}

void RunSpatialIterations(const SpatialParams& params, const FrameView& view, ReservoirBuffer& reservoirs,
                          ReservoirBuffer& spare, PassStats& stats,
                          const std::function<void(const ReservoirBuffer& input)>& beginIteration,
                          const std::function<void(const SpatialBatch& batch)>& batch) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> reads([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> failed([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<BatchScratch> scratch;
  const VisibilityCarry carry = CarryFor(params.visibility);
  const bool carryVisibility = params.visibility != VisibilityReuse::kNone;
  const bool rayTraced = params.bias == BiasCorrection::kRayTraced;
  const DomainFrame frames[1] = {{&g, view.eye, &view.Lights(), SceneFrame::kCurrent, &view.sky}};
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    const ReservoirBuffer& input = reservoirs;
    ReservoirBuffer& output = spare;
    output.resize(g.Size());
    if (beginIteration) beginIteration(input);
    ForEachBatch(g.width, g.height, [&](int y, int x0, int x1) {
      BatchScratch& sc = scratch.local();
      sc.evaluator.Bind(frames, *view.materials, *view.scene, rayTraced);
      batch(SpatialBatch{view, g, iteration, y, x0, x1, input, output, carry, carryVisibility, sc, rays.local(),
                         guarded.local(), reads.local(), failed.local()});
    });
    std::swap(reservoirs, spare);
  }
  FinishReusePass("spatial", t0, rays, guarded, scratch, stats);
  stats.reservoirReads = reads.combine(std::plus<uint64_t>());
  stats.failed = failed.combine(std::plus<uint64_t>());
  for (size_t i = 0; i < g.Size(); ++i) stats.visited += g.IsSurface(i) ? uint64_t(params.iterations) : 0u;
}

}  // namespace restir
