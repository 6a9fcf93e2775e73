#include "sim/estimator/passes/temporal_reuse.h"

#include <tbb/combinable.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/rng.h"
#include "core/sampling.h"
#include "core/temporal.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"

namespace restir {

namespace {

// RTXDI's permutation sampling reads a neighbour of the reprojected pixel only when it is the same surface, by
// the similarity test its spatial pass uses with RTXDI's default thresholds.
constexpr float kPermutationNormalThreshold = 0.9f;
constexpr float kPermutationDepthThreshold = 0.1f;

// What every batch of the pass reads and writes, decided once per frame.
struct TemporalFrame {
  const TemporalParams& params;      // the pass's parameters
  const FrameView& view;             // the frame, with its previous one
  const GBuffer& g;                  // this frame's G-buffer
  const GBuffer& pg;                 // the previous frame's
  const ReservoirBuffer& previous;   // last frame's output, one per pixel of pg
  ReservoirBuffer& current;          // this frame's reservoirs, combined in place (each batch its own pixels)
  std::vector<uint8_t>& accepted;    // per pixel: the previous reservoir entered the combination
  const DomainFrame* frames;         // the current and the previous frame, the combinations' domains 0 and 1
  MisFamily family;                  // EffectiveFamily of the parameters
  VisibilityCarry carry;             // how combinations carry visibility for the shading pass
  uint32_t permBits;                 // RTXDI permutation sampling's XOR pattern of this frame (0: off)
};

// The previous pixel surface pixel i reads: where it reprojects, or with permutation sampling the pixel the
// frame's XOR pattern gives, when that is the same surface.
size_t PreviousPixel(const TemporalFrame& f, size_t i) {
  const GBuffer& g = f.g;
  const GBuffer& pg = f.pg;
  const int w = g.width, h = g.height;
  const int px = std::clamp(static_cast<int>(std::floor(g.prevX[i])), 0, w - 1);
  const int py = std::clamp(static_cast<int>(std::floor(g.prevY[i])), 0, h - 1);
  size_t pi = static_cast<size_t>(py) * w + px;
  if (f.permBits) {
    const int qx = std::clamp(px ^ static_cast<int>(f.permBits & 1u), 0, w - 1);
    const int qy = std::clamp(py ^ static_cast<int>(f.permBits >> 1), 0, h - 1);
    const size_t qi = static_cast<size_t>(qy) * w + qx;
    if (pg.objectId[qi] == pg.objectId[pi] &&
        SimilarSurface(pg, pi, pg, qi, kPermutationNormalThreshold, kPermutationDepthThreshold))
      pi = qi;
  }
  return pi;
}

// Fused spatiotemporal (RTXDI DI/SpatioTemporalResampling.hlsli): previous-frame neighbours of the reprojected
// pixel pi, each its own input and domain, their offsets from dimensions 32 on of the pixel's temporal stream.
void AddFusedNeighbours(const TemporalFrame& f, size_t i, size_t pi, int x, int y, const RngKey& key,
                        Combination& c) {
  const TemporalParams& params = f.params;
  const int w = f.g.width, h = f.g.height;
  for (int t = 0; t < params.fusedNeighbours; ++t) {
    const PixelOffset d =
        RoundedDiskOffset(params.fusedRadius, UniformFloat(key, 32u + 2u * t), UniformFloat(key, 33u + 2u * t));
    const int qx = static_cast<int>(pi % w) + d.dx, qy = static_cast<int>(pi / w) + d.dy;
    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
    const size_t qi = static_cast<size_t>(qy) * w + qx;
    if (qi == pi || !f.pg.IsSurface(qi) || f.pg.objectId[qi] != f.g.objectId[i] ||
        !SimilarSurface(f.g, i, f.pg, qi, kPermutationNormalThreshold, kPermutationDepthThreshold))
      continue;
    const StoredReservoir& nr = f.previous[qi];
    if (!FiniteReservoir(nr) || (params.sampleChecks && !nr.HasSample())) continue;
    const int slot = c.AddInput();
    c.AddDomain(1, static_cast<uint32_t>(qi));
    c.samples[slot] = SampleOf(nr);
    c.inputs[slot] = InputOf(nr, CappedHistoryConfidence(nr.confidence, params.maxHistory));
    c.history[slot] = nr.history.Moved(qx - x, qy - y, true);
    c.u[slot] = UniformFloat(key, static_cast<uint32_t>(slot));
  }
}

// The combination of pixel i = (x, y): its reservoir (canonical, this frame) and the previous one at pi (the
// previous frame, its confidence capped at maxHistory), then any fused neighbours.
void AssembleCombination(const TemporalFrame& f, size_t i, size_t pi, int x, int y, Combination& c) {
  const int w = f.g.width;
  const StoredReservoir& cur = f.current[i];
  const StoredReservoir& prev = f.previous[pi];
  c.Reset(static_cast<uint32_t>(i), 2, 0);
  c.AddDomain(0, static_cast<uint32_t>(i));
  c.AddDomain(1, static_cast<uint32_t>(pi));
  c.samples[0] = SampleOf(cur);
  c.samples[1] = SampleOf(prev);
  c.inputs[0] = InputOf(cur, cur.confidence);
  c.inputs[1] = InputOf(prev, CappedHistoryConfidence(prev.confidence, f.params.maxHistory));
  c.history[0] = cur.history;
  // A frame older, and moved from the previous pixel it was read at (RTXDI's temporal spatialOffset).
  c.history[1] = prev.history.Moved(static_cast<int>(pi % w) - x, static_cast<int>(pi / w) - y, true);
  const RngKey key{f.view.seed, f.view.frame, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kTemporal)};
  c.u[0] = UniformFloat(key, 0);
  c.u[1] = UniformFloat(key, 1);
  AddFusedNeighbours(f, i, pi, x, y, key, c);
}

// Seed 003's sample tests, which need p̂_c(Y_prev) before anything else is evaluated (queued by the caller):
// drops from sc.order the combinations whose p̂_c(Y_prev) is not > 0 or, with targetRatioClamp, whose target
// ratio is out of range (seed 003 §5). Returns the combinations kept.
int ApplySampleChecks(const TemporalFrame& f, BatchScratch& sc, int count, uint64_t& rays) {
  sc.evaluator.Resolve(rays);
  int kept = 0;
  for (int k = 0; k < count; ++k) {
    const Combination& c = sc.combinations[sc.order[k]];
    const float t01 = c.target[0][1];
    if (!(t01 > 0.0f)) continue;
    if (f.params.targetRatioClamp && !TargetRatioInRange(t01, f.previous[c.domainPixel[1]].targetPdf)) continue;
    sc.order[kept++] = sc.order[k];
  }
  return kept;
}

// One batch: the combination of every pixel whose previous reservoir is usable, seed 003's sample tests, the
// family's combination of the batch (CombineFamilyBatch), and the outputs.
void TemporalBatch(const TemporalFrame& f, int y, int x0, int x1, BatchScratch& sc, uint64_t& rays,
                   uint64_t& guarded, uint64_t& crossObject) {
  const TemporalParams& params = f.params;
  const GBuffer& g = f.g;
  sc.evaluator.Bind(f.frames, *f.view.materials, *f.view.scene, params.bias == BiasCorrection::kRayTraced,
                    params.visibilityShortcut);
  int count = 0;
  for (int x = x0; x < x1; ++x) {
    const size_t i = static_cast<size_t>(y) * g.width + x;
    if (!g.IsSurface(i) || !g.prevValid[i]) continue;
    const size_t pi = PreviousPixel(f, i);
    const StoredReservoir& prev = f.previous[pi];
    if (!FiniteReservoir(prev) || !f.pg.IsSurface(pi)) continue;
    if (params.sampleChecks && !prev.HasSample()) continue;
    sc.order[count] = count;
    Combination& c = sc.combinations[count++];
    AssembleCombination(f, i, pi, x, y, c);
    if (params.sampleChecks) sc.evaluator.Request(c, 0, 1);
  }
  if (params.sampleChecks) count = ApplySampleChecks(f, sc, count, rays);
  CombineFamilyBatch(sc, sc.order.data(), count, f.family, f.carry, rays);
  for (int k = 0; k < count; ++k) {
    Combination& c = sc.combinations[sc.order[k]];
    const size_t i = c.pixel;
    if (f.pg.objectId[c.domainPixel[1]] != g.objectId[i]) crossObject += 1;
    const GrisResult gr = sc.combine.Result(k);
    guarded += static_cast<uint64_t>(gr.guarded);
    f.current[i] = OutputOf(c, gr, gr.confidence);
    f.accepted[i] = 1;
  }
}

}  // namespace

void TemporalReuse(const TemporalParams& params, const FrameView& view, const ReservoirBuffer& previous,
                   ReservoirBuffer& current, std::vector<uint8_t>& accepted, PassStats& stats) {
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
  // RTXDI permutation sampling: one XOR pattern per frame, so neighbouring pixels read different history.
  const RngKey frameKey{view.seed, view.frame, 0xFFFFFFFFu, static_cast<uint32_t>(RngPass::kTemporal)};
  const uint32_t permBits = params.permutation ? (RandomBits(frameKey, 0) & 3u) : 0u;
  const GBuffer& pg = *view.previousGbuffer;
  const DomainFrame frames[2] = {
      {&g, view.eye, &view.Lights(), SceneFrame::kCurrent, &view.sky},
      {&pg, view.previousEye, view.previousLights, SceneFrame::kPrevious, &view.previousSky}};
  const TemporalFrame f{params, view, g, pg, previous, current, accepted, frames,
                        EffectiveFamily(params.mis, params.bias), CarryFor(params.visibility), permBits};
  ForEachBatch(w, h, [&](int y, int x0, int x1) {
    TemporalBatch(f, y, x0, x1, scratch.local(), rays.local(), guarded.local(), crossObject.local());
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
