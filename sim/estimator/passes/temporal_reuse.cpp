#include "sim/estimator/passes/temporal_reuse.h"

#include <tbb/combinable.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/rng.h"
#include "core/sampling.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"

namespace restir {

namespace {

// RTXDI's permutation sampling reads a neighbour of the reprojected pixel only when it is the same surface, by
// the similarity test its spatial pass uses with RTXDI's default thresholds.
constexpr float kPermutationNormalThreshold = 0.9f;
constexpr float kPermutationDepthThreshold = 0.1f;

}  // namespace

void TemporalReuse(const TemporalParams& params, VisibilityReuse visibility, const FrameView& view,
                   const ReservoirBuffer& previous, ReservoirBuffer& current, std::vector<uint8_t>& accepted,
                   PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  const int w = g.width, h = g.height;
  const size_t n = g.Size();
  accepted.assign(n, 0);
  stats.name = "temporal";
  const bool haveHistory = view.HasHistory() && previous.size() == n && view.previousGbuffer->Size() == n;
  if (!haveHistory) {
    // RTXDI filters whatever its temporal pass outputs, the first frame's initial reservoirs included.
    BoilingFilter(params.boilingFilterStrength, w, h, current);
    stats.ms = MsSince(t0);
    return;
  }
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> crossObject([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<BatchScratch> scratch;
  const VisibilityCarry carry = CarryFor(visibility);
  // RTXDI permutation sampling: one XOR pattern per frame, so neighbouring pixels read different history.
  const RngKey frameKey{view.seed, view.frame, 0xFFFFFFFFu, static_cast<uint32_t>(RngPass::kTemporal)};
  const uint32_t permBits = params.permutation ? (RandomBits(frameKey, 0) & 3u) : 0u;
  const MisFamily family = EffectiveFamily(params.mis, params.bias);
  const GBuffer& pg = *view.previousGbuffer;
  const DomainFrame frames[2] = {{&g, view.eye, &view.Lights(), SceneFrame::kCurrent, &view.sky},
                                 {&pg, view.previousEye, view.previousLights, SceneFrame::kPrevious, &view.previousSky}};
  ForEachBatch(w, h, [&](int y, int x0, int x1) {
    uint64_t& localRays = rays.local();
    BatchScratch& sc = scratch.local();
    std::vector<Combination>& combos = sc.combinations;
    std::vector<int>& order = sc.order;
    TargetEvaluator& ev = sc.evaluator;
    ev.Bind(frames, *view.materials, *view.scene, params.bias == BiasCorrection::kRayTraced,
            params.visibilityShortcut);
    int count = 0;
    for (int x = x0; x < x1; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!g.IsSurface(i) || !g.prevValid[i]) continue;
      const int px = std::clamp(static_cast<int>(std::floor(g.prevX[i])), 0, w - 1);
      const int py = std::clamp(static_cast<int>(std::floor(g.prevY[i])), 0, h - 1);
      size_t pi = static_cast<size_t>(py) * w + px;
      if (permBits) {
        const int qx = std::clamp(px ^ static_cast<int>(permBits & 1u), 0, w - 1);
        const int qy = std::clamp(py ^ static_cast<int>(permBits >> 1), 0, h - 1);
        const size_t qi = static_cast<size_t>(qy) * w + qx;
        if (pg.objectId[qi] == pg.objectId[pi] &&
            SimilarSurface(pg, pi, pg, qi, kPermutationNormalThreshold, kPermutationDepthThreshold))
          pi = qi;
      }
      const StoredReservoir& prev = previous[pi];
      if (!FiniteReservoir(prev) || !pg.IsSurface(pi)) continue;
      if (params.sampleChecks && !prev.HasSample()) continue;
      const StoredReservoir& cur = current[i];
      order[count] = count;
      Combination& c = combos[count++];
      c.Reset(static_cast<uint32_t>(i), 2, 0);
      c.AddDomain(0, static_cast<uint32_t>(i));
      c.AddDomain(1, static_cast<uint32_t>(pi));
      c.samples[0] = SampleOf(cur);
      c.samples[1] = SampleOf(prev);
      c.inputs[0] = InputOf(cur, cur.confidence);
      c.inputs[1] = InputOf(prev, std::min(prev.confidence, params.maxHistory));
      c.history[0] = cur.history;
      // A frame older, and moved from the previous pixel it was read at (RTXDI's temporal spatialOffset).
      c.history[1] = prev.history.Moved(static_cast<int>(pi % w) - x, static_cast<int>(pi / w) - y, true);
      const RngKey key{view.seed, view.frame, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kTemporal)};
      c.u[0] = UniformFloat(key, 0);
      c.u[1] = UniformFloat(key, 1);
      // Fused spatiotemporal: previous-frame neighbours of the reprojected pixel, each its own input and domain.
      for (int t = 0; t < params.fusedNeighbours; ++t) {
        const PixelOffset d =
            RoundedDiskOffset(params.fusedRadius, UniformFloat(key, 32u + 2u * t), UniformFloat(key, 33u + 2u * t));
        const int qx = static_cast<int>(pi % w) + d.dx, qy = static_cast<int>(pi / w) + d.dy;
        if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
        const size_t qi = static_cast<size_t>(qy) * w + qx;
        if (qi == pi || !pg.IsSurface(qi) || pg.objectId[qi] != g.objectId[i] ||
            !SimilarSurface(g, i, pg, qi, kPermutationNormalThreshold, kPermutationDepthThreshold))
          continue;
        const StoredReservoir& nr = previous[qi];
        if (!FiniteReservoir(nr) || (params.sampleChecks && !nr.HasSample())) continue;
        const int slot = c.AddInput();
        c.AddDomain(1, static_cast<uint32_t>(qi));
        c.samples[slot] = SampleOf(nr);
        c.inputs[slot] = InputOf(nr, std::min(nr.confidence, params.maxHistory));
        c.history[slot] = nr.history.Moved(qx - x, qy - y, true);
        c.u[slot] = UniformFloat(key, static_cast<uint32_t>(slot));
      }
      if (params.sampleChecks) ev.Request(c, 0, 1);
    }
    // seed 003's sample tests need p̂_c(Y_prev) before anything else is evaluated.
    if (params.sampleChecks) {
      ev.Resolve(localRays);
      int kept = 0;
      for (int k = 0; k < count; ++k) {
        const Combination& c = combos[order[k]];
        const float t01 = c.target[0][1];
        if (!(t01 > 0.0f)) continue;
        if (params.targetRatioClamp) {
          const float prevTarget = previous[c.domainPixel[1]].targetPdf;
          const float ratio = prevTarget > 0.0f ? t01 / prevTarget : 0.0f;
          if (!(ratio >= 0.1f && ratio <= 10.0f)) continue;
        }
        order[kept++] = order[k];
      }
      count = kept;
    }
    for (int k = 0; k < count; ++k) RequestCanonicalTargets(combos[order[k]], ev);
    ev.Resolve(localRays);
    for (int k = 0; k < count; ++k) RequestFamilyTargets(combos[order[k]], family, carry, ev);
    ev.Resolve(localRays);
    sc.combine.Fill(combos.data(), order.data(), count, true);
    sc.combine.Combine(family, carry);
    for (int k = 0; k < count; ++k) {
      Combination& c = combos[order[k]];
      const size_t i = c.pixel;
      if (pg.objectId[c.domainPixel[1]] != g.objectId[i]) crossObject.local() += 1;
      const GrisResult gr = sc.combine.Result(k);
      guarded.local() += static_cast<uint64_t>(gr.guarded);
      current[i] = OutputOf(c, gr, gr.confidence);
      accepted[i] = 1;
    }
  });
  BoilingFilter(params.boilingFilterStrength, w, h, current);
  stats.crossObjectReuse = crossObject.combine(std::plus<uint64_t>());
  FinishReusePass("temporal", t0, rays, guarded, scratch, stats);
}

size_t BoilingFilter(float strength, int width, int height, ReservoirBuffer& reservoirs) {
  if (!(strength > 0.0f) || reservoirs.size() != static_cast<size_t>(width) * height) return 0;
  // Utils/BoilingFilter.hlsli: 10 / clamp(strength, 1e-6, 1) - 9.
  const float multiplier = 10.0f / std::clamp(strength, 1e-6f, 1.0f) - 9.0f;
  const int tilesX = (width + kBoilingFilterTile - 1) / kBoilingFilterTile;
  const int tilesY = (height + kBoilingFilterTile - 1) / kBoilingFilterTile;
  tbb::combinable<size_t> emptied([] { return size_t{0}; });
  // Tiles are independent and each is summed in its own pixel order: the same bits whatever the thread count.
  tbb::parallel_for(tbb::blocked_range<int>(0, tilesX * tilesY), [&](const tbb::blocked_range<int>& range) {
    for (int t = range.begin(); t < range.end(); ++t) {
      const int x0 = (t % tilesX) * kBoilingFilterTile, y0 = (t / tilesX) * kBoilingFilterTile;
      const int x1 = std::min(width, x0 + kBoilingFilterTile), y1 = std::min(height, y0 + kBoilingFilterTile);
      double sum = 0.0;
      size_t count = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const float W = reservoirs[static_cast<size_t>(y) * width + x].W;
          if (W > 0.0f && std::isfinite(W)) sum += W, ++count;
        }
      if (count == 0) continue;
      const float threshold = static_cast<float>(sum / double(count)) * multiplier;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          StoredReservoir& r = reservoirs[static_cast<size_t>(y) * width + x];
          if (r.W > threshold) {
            r = StoredReservoir{};  // RTXDI_EmptyDIReservoir: no sample, W = 0, M = 0
            emptied.local() += 1;
          }
        }
    }
  });
  return emptied.combine(std::plus<size_t>());
}

}  // namespace restir
