#include "sim/estimator/passes/spatial_reuse.h"

#include <algorithm>

#include "core/sampling.h"
#include "sim/estimator/passes/batching.h"

namespace restir {

namespace {

// The neighbour draws of a batch's pixels: pixel index, or -1 off screen or on the pixel itself.
struct Neighbours {
  int32_t pixel[kBatchPixels][kMaxGrisInputs];
  int count[kBatchPixels];  // draws of each pixel (0 off the surfaces)
};

// Neighbours are random pixels up to `radius` away, so their G-buffer and reservoir lines miss the cache: pick
// every pixel's neighbours first and prefetch their lines, so the misses overlap instead of stalling the
// similarity tests one at a time. Pixels whose temporal reuse failed draw disocclusionNeighbours.
void PickNeighbours(const SpatialParams& params, const std::vector<uint8_t>& temporalAccepted,
                    const SpatialBatch& b, Neighbours& nb) {
  const GBuffer& g = b.g;
  const int w = g.width, h = g.height, y = b.y;
  for (int x = b.x0; x < b.x1; ++x) {
    const size_t i = static_cast<size_t>(y) * w + x;
    int& k = nb.count[x - b.x0];
    k = 0;
    if (!g.IsSurface(i)) continue;
    const bool boost = params.disocclusionBoost && !temporalAccepted[i];
    k = std::min(boost ? params.disocclusionNeighbours : params.neighbours, kMaxGrisInputs - 1);
    Sampler s(SpatialRngKey(b.view, i, b.iteration));
    for (int t = 0; t < k; ++t) {
      const float u0 = s.Next(), u1 = s.Next();
      const PixelOffset d = RoundedDiskOffset(params.radius, u0, u1);
      const int nx = x + d.dx, ny = y + d.dy;
      int32_t& ni = nb.pixel[x - b.x0][t];
      ni = -1;
      if (nx < 0 || ny < 0 || nx >= w || ny >= h || (nx == x && ny == y)) continue;
      ni = ny * w + nx;
      PrefetchSurface(g, static_cast<size_t>(ni));
      __builtin_prefetch(reinterpret_cast<const char*>(b.input.data() + ni));
      __builtin_prefetch(reinterpret_cast<const char*>(b.input.data() + ni) + sizeof(StoredReservoir) - 1);
    }
  }
}

// The combination of surface pixel x of the batch: its own reservoir (canonical) and those of its k drawn
// neighbours that are similar surfaces with finite reservoirs, then the streaming uniforms, drawn after the
// neighbours' 2k dimensions. False when no neighbour qualifies: the pixel keeps its reservoir.
bool AssembleCombination(const SpatialParams& params, const SpatialBatch& b, int x, const int32_t* neighbour, int k,
                         Combination& c) {
  const GBuffer& g = b.g;
  const int w = g.width, y = b.y;
  const size_t i = static_cast<size_t>(y) * w + x;
  const StoredReservoir& self = b.input[i];
  ++b.reservoirReads;
  c.Reset(static_cast<uint32_t>(i), 1, 0);
  c.AddDomain(0, static_cast<uint32_t>(i));
  c.samples[0] = SampleOf(self);
  c.inputs[0] = InputOf(self, self.confidence);
  c.history[0] = self.history;
  for (int t = 0; t < k; ++t) {
    if (neighbour[t] < 0) continue;
    const size_t ni = static_cast<size_t>(neighbour[t]);
    if (!g.IsSurface(ni) || !SimilarSurface(g, i, g, ni, params.normalThreshold, params.depthThreshold)) continue;
    const StoredReservoir& nr = b.input[ni];
    ++b.reservoirReads;
    if (!FiniteReservoir(nr)) continue;
    if (params.discountNaiveSamples && nr.HasSample() && nr.confidence <= kNaiveConfidence) continue;
    const int slot = c.AddInput();
    c.AddDomain(0, static_cast<uint32_t>(ni));
    c.samples[slot] = SampleOf(nr);
    c.inputs[slot] = InputOf(nr, nr.confidence);
    c.history[slot] = nr.history.Moved(static_cast<int>(ni % w) - x, static_cast<int>(ni / w) - y, false);
    // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
    if (b.carryVisibility && nr.HasSample()) b.scratch.evaluator.RequestVisibility(c, slot);
  }
  if (c.count == 1) return false;
  Sampler s(SpatialRngKey(b.view, i, b.iteration), 2u * static_cast<uint32_t>(k));  // after the neighbours'
  for (int t = 0; t < c.count; ++t) c.u[t] = s.Next();
  return true;
}

// One batch of an iteration: the neighbour draws, each pixel's combination, then the family's combination of the
// whole batch (CombineFamilyBatch) and the outputs.
void NeighbourBatch(const SpatialParams& params, MisFamily family, const std::vector<uint8_t>& temporalAccepted,
                    const SpatialBatch& b) {
  Neighbours nb;
  PickNeighbours(params, temporalAccepted, b, nb);
  std::vector<Combination>& combos = b.scratch.combinations;
  int count = 0;
  for (int x = b.x0; x < b.x1; ++x) {
    const size_t i = static_cast<size_t>(b.y) * b.g.width + x;
    b.output[i] = b.input[i];  // kept unless a combination below replaces it
    if (!b.g.IsSurface(i)) continue;
    if (AssembleCombination(params, b, x, nb.pixel[x - b.x0], nb.count[x - b.x0], combos[count]))
      ++count;
    else
      ++b.failed;
  }
  CombineFamilyBatch(b.scratch, nullptr, count, family, b.carry, b.rays);
  for (int k = 0; k < count; ++k) {
    const Combination& c = combos[k];
    const GrisResult gr = b.scratch.combine.Result(k);
    b.guarded += static_cast<uint64_t>(gr.guarded);
    b.output[c.pixel] = OutputOf(c, gr, gr.confidence);
  }
}

}  // namespace

void SpatialReuse(const SpatialParams& params, const FrameView& view, const std::vector<uint8_t>& temporalAccepted,
                  ReservoirBuffer& reservoirs, ReservoirBuffer& spare, PassStats& stats) {
  const MisFamily family = EffectiveFamily(params.mis, params.bias);
  RunSpatialIterations(params, view, reservoirs, spare, stats, nullptr,
                       [&](const SpatialBatch& b) { NeighbourBatch(params, family, temporalAccepted, b); });
}

}  // namespace restir
