#include "sim/estimator/passes/spatial_reuse.h"

#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>

#include "core/sampling.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"

namespace restir {

RngKey SpatialRngKey(const FrameView& view, size_t i, int iteration) {
  return RngKey{view.seed, view.frame, static_cast<uint32_t>(i),
                static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)};
}

void SpatialReuse(const SpatialParams& params, VisibilityReuse visibility, const FrameView& view,
                  const std::vector<uint8_t>* temporalAccepted, ReservoirBuffer& reservoirs, ReservoirBuffer& spare,
                  PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  const int w = g.width, h = g.height;
  const size_t n = g.Size();
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<BatchScratch> scratch;
  const MisFamily family = EffectiveFamily(params.mis, params.bias);
  const VisibilityCarry carry = CarryFor(visibility);
  const bool carryVisibility = visibility != VisibilityReuse::kNone;
  const DomainFrame frames[1] = {{&g, view.eye, &view.Lights(), SceneFrame::kCurrent, &view.sky}};
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    const ReservoirBuffer& input = reservoirs;
    ReservoirBuffer& output = spare;
    output.resize(n);
    ForEachBatch(w, h, [&](int y, int x0, int x1) {
      uint64_t& localRays = rays.local();
      BatchScratch& sc = scratch.local();
      std::vector<Combination>& combos = sc.combinations;
      TargetEvaluator& ev = sc.evaluator;
      ev.Bind(frames, *view.materials, *view.scene, params.bias == BiasCorrection::kRayTraced);
      // Neighbours are random pixels up to `radius` away, so their G-buffer and reservoir lines miss the cache:
      // pick every pixel's neighbours first and prefetch their lines, so the misses overlap instead of stalling
      // the similarity tests one at a time.
      int32_t neighbour[kBatchPixels][kMaxGrisInputs];
      int neighbourCount[kBatchPixels];
      for (int x = x0; x < x1; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        int& k = neighbourCount[x - x0];
        k = 0;
        if (!g.IsSurface(i)) continue;
        const bool boost = temporalAccepted && !(*temporalAccepted)[i];
        k = std::min(boost ? params.disocclusionNeighbours : params.neighbours, kMaxGrisInputs - 1);
        Sampler s(SpatialRngKey(view, i, iteration));
        for (int t = 0; t < k; ++t) {
          const float u0 = s.Next(), u1 = s.Next();
          const PixelOffset d = RoundedDiskOffset(params.radius, u0, u1);
          const int nx = x + d.dx, ny = y + d.dy;
          int32_t& ni = neighbour[x - x0][t];
          ni = -1;
          if (nx < 0 || ny < 0 || nx >= w || ny >= h || (nx == x && ny == y)) continue;
          ni = ny * w + nx;
          PrefetchSurface(g, static_cast<size_t>(ni));
          __builtin_prefetch(reinterpret_cast<const char*>(input.data() + ni));
          __builtin_prefetch(reinterpret_cast<const char*>(input.data() + ni) + sizeof(StoredReservoir) - 1);
        }
      }
      int count = 0;
      for (int x = x0; x < x1; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        output[i] = input[i];  // kept unless a combination below replaces it
        if (!g.IsSurface(i)) continue;
        Combination& c = combos[count];
        const int k = neighbourCount[x - x0];
        const StoredReservoir& self = input[i];
        c.Reset(static_cast<uint32_t>(i), 1, 0);
        c.AddDomain(0, static_cast<uint32_t>(i));
        c.samples[0] = SampleOf(self);
        c.inputs[0] = InputOf(self, self.confidence);
        c.history[0] = self.history;
        for (int t = 0; t < k; ++t) {
          if (neighbour[x - x0][t] < 0) continue;
          const size_t ni = static_cast<size_t>(neighbour[x - x0][t]);
          if (!g.IsSurface(ni) || !SimilarSurface(g, i, g, ni, params.normalThreshold, params.depthThreshold))
            continue;
          const StoredReservoir& nr = input[ni];
          if (!FiniteReservoir(nr)) continue;
          if (params.discountNaiveSamples && nr.HasSample() && nr.confidence <= kNaiveConfidence) continue;
          const int slot = c.AddInput();
          c.AddDomain(0, static_cast<uint32_t>(ni));
          c.samples[slot] = SampleOf(nr);
          c.inputs[slot] = InputOf(nr, nr.confidence);
          c.history[slot] = nr.history.Moved(static_cast<int>(ni % w) - x, static_cast<int>(ni / w) - y, false);
          // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
          if (carryVisibility && nr.HasSample()) ev.RequestVisibility(c, slot);
        }
        if (c.count == 1) continue;
        Sampler s(SpatialRngKey(view, i, iteration), 2u * static_cast<uint32_t>(k));  // after the neighbours'
        for (int t = 0; t < c.count; ++t) c.u[t] = s.Next();
        ++count;
      }
      for (int k = 0; k < count; ++k) RequestCanonicalTargets(combos[k], ev);
      ev.Resolve(localRays);
      for (int k = 0; k < count; ++k) RequestFamilyTargets(combos[k], family, carry, ev);
      ev.Resolve(localRays);
      sc.combine.Fill(combos.data(), nullptr, count, true);
      sc.combine.Combine(family, carry);
      for (int k = 0; k < count; ++k) {
        const Combination& c = combos[k];
        const GrisResult gr = sc.combine.Result(k);
        guarded.local() += static_cast<uint64_t>(gr.guarded);
        output[c.pixel] = OutputOf(c, gr, gr.confidence);
      }
    });
    std::swap(reservoirs, spare);
  }
  FinishReusePass("spatial", t0, rays, guarded, scratch, stats);
}

}  // namespace restir
