#include "sim/estimator/passes/stochastic_pairwise_reuse.h"

#include <tbb/enumerable_thread_specific.h>

#include <cstddef>

#include "core/sampling.h"
#include "core/spmis.h"
#include "core/spmis_kernel.h"
#include "sim/estimator/passes/batching.h"
#include "sim/estimator/passes/spatial_common.h"

namespace restir {

namespace {

// What the draws carry to the weights, per pixel of a batch (seed 004 §3-5).
struct DrawState {
  float multiplicity[kMaxGrisInputs];  // K(i) of non-canonical input i
  float probability[kMaxGrisInputs];   // P(i)
  float drawnCount[kMaxGrisInputs];    // multiplicity of the d-th distinct canonical draw (domain count + d)
  float drawnProbability[kMaxGrisInputs];  // its P_c
  uint32_t drawnPixel[kMaxGrisInputs];
  int distinct = 0;                    // distinct canonical draws
  float bigN = 0.0f;                   // N: this pixel's non-canonical draws (draws or disocclusionDraws)
  float bigM = 0.0f;                   // M: the cell's candidates
  float scale = 1.0f;                  // min(1, N / M) with confidence scaling, else 1 (§4.3)
  float cBar = 0.0f;                   // scaled Σ c_i over the cell
};

// Per-thread scratch of the cell search and the stochastic weights, beside the skeleton's BatchScratch.
struct CellScratch {
  StochasticPairwiseArrays spmis;  // the batch's stochastic pairwise MIS inputs (core/spmis_kernel.h)
  // Per pixel of the batch: the cell (or -1) under each search position and its uniform, and the chosen cell.
  std::vector<int32_t> searchCell = std::vector<int32_t>(kBatchPixels * kMaxCellSearchIterations);
  std::vector<float> searchPick = std::vector<float>(kBatchPixels * kMaxCellSearchIterations);
  std::vector<int32_t> chosenCell = std::vector<int32_t>(kBatchPixels);
};

// §5.1: the neighbour cell among the cells under the search positions (cell index or -1 per iteration, with its
// uniform): similar cells compete with weight = their confidence sum, by weighted reservoir sampling; -1 when none.
int32_t ChooseCell(const SpatialParams& params, const CellGrid& grid, size_t i, const GBuffer& g,
                   const int32_t* searchCell, const float* searchPick) {
  const Vec3 n = g.GeometricNormal(i);
  int32_t chosen = -1;
  float cellWeightSum = 0.0f;
  for (int it = 0; it < params.stochastic.cellSearchIterations; ++it) {
    const int32_t c = searchCell[it];
    if (c < 0) continue;
    const CellGrid::Cell& cell = grid.cells[static_cast<size_t>(c)];
    if (cell.objectId != g.objectId[i] || glm::dot(cell.normal, n) < params.normalThreshold) continue;
    if (!(cell.confidenceSum > 0.0f)) continue;
    cellWeightSum += cell.confidenceSum;
    if (searchPick[it] * cellWeightSum < cell.confidenceSum) chosen = c;
  }
  return chosen;
}

// In the chosen cell, `bigN` draws with replacement by P(i) ∝ c_i p̂_i(X_i) W_i (Eq. 17) become the combination's
// non-canonical inputs with multiplicities K(i); N_c draws by P_c (params.canonicalPdf) are kept for the canonical
// weight. Consumes every random number of the pixel in a layout fixed by bigN and N_c. False when the pixel keeps
// its reservoir. `reads` counts the reservoirs read.
bool Draw(const StochasticPairwiseParams& params, const CellGrid& grid, size_t i, int32_t chosen, int bigN,
          const ReservoirBuffer& input, Sampler& s, Combination& c, DrawState& draws, uint64_t& reads) {
  if (chosen < 0) return false;
  const CellGrid::Cell& cell = grid.cells[static_cast<size_t>(chosen)];
  // The cell's candidates, the current pixel excluded: all M of them, and the contributing ones with P(i).
  uint32_t candidates[kMaxCellPixels];
  float cumulative[kMaxCellPixels];
  float confidenceCumulative[kMaxCellPixels];  // running Σ c over candidates (P_c ∝ c)
  uint32_t contributing[kMaxCellPixels];
  int m = 0, k = 0;
  float confidenceSum = 0.0f, contributionSum = 0.0f;
  for (uint32_t t = 0; t < cell.count; ++t) {
    const uint32_t p = grid.pixels[cell.first + t];
    if (p == i) continue;
    candidates[m++] = p;
    const StoredReservoir& r = input[p];
    confidenceSum += r.confidence;
    confidenceCumulative[m - 1] = confidenceSum;
    const float contribution = r.HasSample() ? StochasticPairwiseDrawWeight(r.confidence, r.targetPdf, r.W) : 0.0f;
    if (contribution > 0.0f && std::isfinite(contribution)) {
      contributionSum += contribution;
      contributing[k] = p;
      cumulative[k++] = contributionSum;
    }
  }
  reads += static_cast<uint64_t>(m) + 1;  // the cell's candidates and the pixel's own
  if (m == 0) return false;
  draws.bigN = static_cast<float>(bigN);
  draws.bigM = static_cast<float>(m);
  draws.scale = params.confidenceScaling ? ConfidenceScale(draws.bigN, draws.bigM) : 1.0f;
  draws.cBar = confidenceSum * draws.scale;

  const StoredReservoir& self = input[i];
  c.Reset(static_cast<uint32_t>(i), 1, 0);
  c.AddDomain(0, static_cast<uint32_t>(i));
  c.samples[0] = SampleOf(self);
  c.inputs[0] = InputOf(self, self.confidence);
  c.history[0] = self.history;
  for (int d = 0; d < bigN; ++d) {
    const float u = s.Next();
    if (k == 0) continue;
    const int idx = SampleCumulative(cumulative, k, u);
    const uint32_t p = contributing[idx];
    int slot = 1;
    while (slot < c.count && c.domainPixel[slot] != p) ++slot;
    if (slot == c.count) {
      const StoredReservoir& r = input[p];
      draws.multiplicity[slot] = 0.0f;
      draws.probability[slot] = (cumulative[idx] - (idx > 0 ? cumulative[idx - 1] : 0.0f)) / contributionSum;
      c.AddInput();
      c.samples[slot] = SampleOf(r);
      c.inputs[slot] = InputOf(r, r.confidence * draws.scale);
      const int w = grid.width;
      c.history[slot] = r.history.Moved(static_cast<int>(p % w) - static_cast<int>(i % w),
                                        static_cast<int>(p / w) - static_cast<int>(i / w), false);
      c.AddDomain(0, p);
    }
    draws.multiplicity[slot] += 1.0f;
  }
  // Canonical: N_c draws by P_c, always consumed so every pixel's stream has the same layout. With P_c ∝ c and
  // no confidence in the cell, every term is 0 and nothing is drawn.
  draws.distinct = 0;
  const bool byConfidence = params.canonicalPdf == CanonicalPdf::kConfidence;
  for (int d = 0; d < params.canonicalDraws; ++d) {
    const float u = s.Next();
    if (byConfidence && !(confidenceSum > 0.0f)) continue;
    const uint32_t p = byConfidence ? candidates[SampleCumulative(confidenceCumulative, m, u)]
                                    : candidates[std::min(m - 1, static_cast<int>(u * draws.bigM))];
    int slot = 0;
    while (slot < draws.distinct && draws.drawnPixel[slot] != p) ++slot;
    if (slot == draws.distinct) {
      draws.drawnPixel[slot] = p;
      draws.drawnCount[slot] = 0.0f;
      draws.drawnProbability[slot] = byConfidence ? input[p].confidence / confidenceSum : 1.0f / draws.bigM;
      ++draws.distinct;
    }
    draws.drawnCount[slot] += 1.0f;
  }
  for (int t = 0; t < c.count; ++t) c.u[t] = s.Next();
  return true;
}

// §5.1, first stage: each surface pixel's search positions (a rounded disk offset whose radius grows by
// cellSearchGrowth per iteration) and their uniforms, the first three dimensions of each iteration of its stream;
// the pixel cells under the positions are prefetched for the next stage.
void DrawSearchPositions(const StochasticPairwiseParams& sp, const CellGrid& grid, const SpatialBatch& b,
                         CellScratch& cs) {
  const GBuffer& g = b.g;
  const int w = g.width, h = g.height, y = b.y, iterations = sp.cellSearchIterations;
  for (int x = b.x0; x < b.x1; ++x) {
    const size_t i = static_cast<size_t>(y) * w + x;
    int32_t* q = cs.searchCell.data() + static_cast<size_t>(x - b.x0) * iterations;
    float* pick = cs.searchPick.data() + static_cast<size_t>(x - b.x0) * iterations;
    if (!g.IsSurface(i)) continue;
    Sampler s(SpatialRngKey(b.view, i, b.iteration));
    float radius = CellSearchRadiusPixels(sp, h);
    for (int it = 0; it < iterations; ++it, radius *= sp.cellSearchGrowth) {
      const float u0 = s.Next(), u1 = s.Next();
      const PixelOffset d = RoundedDiskOffset(radius, u0, u1);
      pick[it] = s.Next();
      const int qx = x + d.dx, qy = y + d.dy;
      q[it] = qx < 0 || qy < 0 || qx >= w || qy >= h ? -1 : qy * w + qx;
      if (q[it] >= 0) __builtin_prefetch(grid.pixelCell.data() + q[it]);
    }
  }
}

// Second stage: the cell under each search position (-1: off screen or no cell); the cells are prefetched.
void LookUpSearchCells(const StochasticPairwiseParams& sp, const CellGrid& grid, const SpatialBatch& b,
                       CellScratch& cs) {
  const GBuffer& g = b.g;
  const int w = g.width, iterations = sp.cellSearchIterations;
  for (int x = b.x0; x < b.x1; ++x) {
    if (!g.IsSurface(static_cast<size_t>(b.y) * w + x)) continue;
    int32_t* q = cs.searchCell.data() + static_cast<size_t>(x - b.x0) * iterations;
    for (int it = 0; it < iterations; ++it) {
      if (q[it] >= 0) q[it] = grid.pixelCell[static_cast<size_t>(q[it])];
      if (q[it] >= 0) __builtin_prefetch(grid.cells.data() + q[it]);
    }
  }
}

// Third stage: each surface pixel's neighbour cell (ChooseCell, or -1), whose reservoirs are prefetched for the
// draws.
void ChooseBatchCells(const SpatialParams& params, const CellGrid& grid, const SpatialBatch& b, CellScratch& cs) {
  const GBuffer& g = b.g;
  const int w = g.width, iterations = params.stochastic.cellSearchIterations;
  for (int x = b.x0; x < b.x1; ++x) {
    const size_t i = static_cast<size_t>(b.y) * w + x;
    int32_t& chosen = cs.chosenCell[x - b.x0];
    chosen = -1;
    if (!g.IsSurface(i)) continue;
    chosen = ChooseCell(params, grid, i, g, cs.searchCell.data() + static_cast<size_t>(x - b.x0) * iterations,
                        cs.searchPick.data() + static_cast<size_t>(x - b.x0) * iterations);
    if (chosen < 0) continue;
    const CellGrid::Cell& cell = grid.cells[static_cast<size_t>(chosen)];
    for (uint32_t t = 0; t < cell.count; ++t)
      __builtin_prefetch(reinterpret_cast<const char*>(b.input.data() + grid.pixels[cell.first + t]) +
                         offsetof(StoredReservoir, targetPdf));
  }
}

// Each surface pixel's combination from its chosen cell (Draw); a pixel keeps its reservoir unless one replaces
// it. The drawn pixels' surfaces are prefetched for the target evaluations. Returns the batch's combinations.
int DrawInputs(const SpatialParams& params, const std::vector<uint8_t>& temporalAccepted, const CellGrid& grid,
               const SpatialBatch& b, const CellScratch& cs, DrawState* draws) {
  const StochasticPairwiseParams& sp = params.stochastic;
  const GBuffer& g = b.g;
  const int w = g.width;
  std::vector<Combination>& combos = b.scratch.combinations;
  int count = 0;
  for (int x = b.x0; x < b.x1; ++x) {
    const size_t i = static_cast<size_t>(b.y) * w + x;
    b.output[i] = b.input[i];  // kept unless a combination below replaces it
    if (!g.IsSurface(i)) continue;
    Combination& c = combos[count];
    // The search used the first three dimensions of each iteration.
    Sampler s(SpatialRngKey(b.view, i, b.iteration), 3u * static_cast<uint32_t>(sp.cellSearchIterations));
    const bool boost = params.disocclusionBoost && !temporalAccepted[i];
    if (!Draw(sp, grid, i, cs.chosenCell[x - b.x0], boost ? sp.disocclusionDraws : sp.draws, b.input, s, c,
              draws[count], b.reservoirReads)) {
      ++b.failed;
      continue;
    }
    // The second Resolve evaluates targets at the drawn pixels' surfaces: start loading them now.
    for (int t = 1; t < c.count; ++t) PrefetchSurface(g, c.domainPixel[t]);
    for (int j = 0; j < draws[count].distinct; ++j) PrefetchSurface(g, draws[count].drawnPixel[j]);
    // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
    if (b.carryVisibility)
      for (int t = 1; t < c.count; ++t)
        if (c.inputs[t].hasSample) b.scratch.evaluator.RequestVisibility(c, t);
    ++count;
  }
  return count;
}

// Seed 004 Eq. 15-19: p̂_c of every input first; then, where the canonical sample can contribute, its target in
// each canonically drawn pixel, and p̂_i(Y_i) where p̂_c(Y_i) > 0. Each round is resolved as one batch.
void ResolveCellTargets(const SpatialBatch& b, const DrawState* draws, int count) {
  std::vector<Combination>& combos = b.scratch.combinations;
  TargetEvaluator& ev = b.scratch.evaluator;
  for (int k = 0; k < count; ++k) {
    Combination& c = combos[k];
    for (int t = 0; t < c.count; ++t)
      if (c.inputs[t].hasSample) ev.Request(c, 0, t);
  }
  ev.Resolve(b.rays);
  for (int k = 0; k < count; ++k) {
    Combination& c = combos[k];
    const DrawState& d = draws[k];
    if (c.inputs[0].hasSample && c.target[0][0] > 0.0f) {
      for (int j = 0; j < d.distinct; ++j) {
        c.AddDomain(0, d.drawnPixel[j]);
        ev.Request(c, c.domains - 1, 0);
      }
    }
    for (int t = 1; t < c.count; ++t)
      if (c.inputs[t].hasSample && c.target[0][t] > 0.0f) ev.Request(c, t, t);
  }
  ev.Resolve(b.rays);
}

// The weights of seed 004 Eq. 15-19 for the whole batch in the SIMD kernel (core/spmis_kernel.h), written where
// the resampling kernel reads them.
void StochasticBatchWeights(const StochasticPairwiseParams& sp, const SpatialBatch& b, const DrawState* draws,
                            int count, StochasticPairwiseArrays& sw) {
  const std::vector<Combination>& combos = b.scratch.combinations;
  b.scratch.combine.Fill(combos.data(), nullptr, count, false);
  GrisBatchArrays& a = b.scratch.combine.Arrays();
  sw.Resize(a, sp.canonicalDraws);
  for (int k = 0; k < count; ++k) {
    const Combination& c = combos[k];
    const DrawState& d = draws[k];
    sw.distinct[k] = d.distinct;
    sw.cBar[k] = d.cBar;
    sw.drawCount[k] = d.bigN;
    sw.canonicalDrawCount[k] = static_cast<float>(sp.canonicalDraws);
    for (int t = 0; t < c.count; ++t) {
      const size_t e = sw.At(t, static_cast<size_t>(k));
      sw.canonicalTarget[e] = c.Known(0, t);
      if (t == 0) continue;
      sw.multiplicity[e] = d.multiplicity[t];
      sw.probability[e] = d.probability[t];
      sw.ownTarget[e] = c.Known(t, t);
    }
    for (int j = 0; j < d.distinct; ++j) {
      const size_t e = sw.DrawAt(j, static_cast<size_t>(k));
      sw.drawnMultiplicity[e] = d.drawnCount[j];
      sw.drawnProbability[e] = d.drawnProbability[j];
      sw.drawnConfidence[e] = b.input[d.drawnPixel[j]].confidence * d.scale;
      sw.drawnTarget[e] = c.domains > c.count + j ? c.Known(c.count + j, 0) : 0.0f;
    }
  }
  StochasticPairwiseWeights(sw.View(a), StochasticPairwiseOutputInto(a));
}

// One batch of an iteration. The cell search reads random pixels up to hundreds of pixels away, then their
// cells, then the chosen cell's reservoirs: three dependent cache misses per search. Each stage runs over the
// whole batch and prefetches what the next one reads, so the misses overlap. Then the draws, their targets and
// weights, and the resampling with the given weights.
void CellBatch(const SpatialParams& params, const std::vector<uint8_t>& temporalAccepted, const CellGrid& grid,
               const SpatialBatch& b, CellScratch& cs) {
  const StochasticPairwiseParams& sp = params.stochastic;
  DrawState draws[kBatchPixels];
  DrawSearchPositions(sp, grid, b, cs);
  LookUpSearchCells(sp, grid, b, cs);
  ChooseBatchCells(params, grid, b, cs);
  const int count = DrawInputs(params, temporalAccepted, grid, b, cs, draws);
  ResolveCellTargets(b, draws, count);
  StochasticBatchWeights(sp, b, draws, count, cs.spmis);
  b.scratch.combine.Resample(b.carry);
  const std::vector<Combination>& combos = b.scratch.combinations;
  for (int k = 0; k < count; ++k) {
    const Combination& c = combos[k];
    const GrisResult gr = b.scratch.combine.Result(k);
    b.guarded += static_cast<uint64_t>(gr.guarded);
    // The canonical plus the (scaled) cell it stands for.
    b.output[c.pixel] = OutputOf(c, gr, c.inputs[0].confidence + draws[k].cBar);
  }
}

}  // namespace

void BuildCells(const GBuffer& g, const ReservoirBuffer& reservoirs, const StochasticPairwiseParams& params,
                CellGrid& grid) {
  const int w = g.width, h = g.height, tile = std::max(1, params.cellTile);
  const int tilesX = (w + tile - 1) / tile, tilesY = (h + tile - 1) / tile;
  grid.cells.clear();
  grid.width = g.width;
  grid.pixels.clear();
  grid.pixelCell.assign(g.Size(), -1);
  std::vector<std::pair<uint32_t, uint32_t>> members;  // (cell, pixel) for one tile
  for (int ty = 0; ty < tilesY; ++ty) {
    for (int tx = 0; tx < tilesX; ++tx) {
      const uint32_t tileIndex = static_cast<uint32_t>(ty * tilesX + tx);
      const size_t firstCell = grid.cells.size();
      members.clear();
      for (int y = ty * tile; y < std::min(h, (ty + 1) * tile); ++y) {
        for (int x = tx * tile; x < std::min(w, (tx + 1) * tile); ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i)) continue;
          const uint32_t q = QuantiseNormal(g.GeometricNormal(i), static_cast<uint32_t>(params.normalBins));
          const uint32_t key = CellKey(tileIndex, static_cast<uint32_t>(g.objectId[i]), q);
          size_t c = firstCell;
          while (c < grid.cells.size() && !(grid.cells[c].key == key && grid.cells[c].objectId == g.objectId[i])) ++c;
          if (c == grid.cells.size()) {
            CellGrid::Cell cell;
            cell.objectId = g.objectId[i];
            cell.key = key;
            grid.cells.push_back(cell);
          }
          grid.cells[c].normal += g.GeometricNormal(i);
          grid.cells[c].confidenceSum += reservoirs[i].confidence;
          grid.cells[c].count += 1;
          members.emplace_back(static_cast<uint32_t>(c), static_cast<uint32_t>(i));
        }
      }
      // Lay the tile's cells out contiguously, each in scan order.
      for (size_t c = firstCell; c < grid.cells.size(); ++c) {
        grid.cells[c].first = static_cast<uint32_t>(grid.pixels.size());
        grid.cells[c].normal = glm::normalize(grid.cells[c].normal);
        for (const auto& [cell, pixel] : members)
          if (cell == c) {
            grid.pixels.push_back(pixel);
            grid.pixelCell[pixel] = static_cast<int32_t>(c);
          }
      }
    }
  }
}

void StochasticPairwiseReuse(const SpatialParams& params, const FrameView& view,
                             const std::vector<uint8_t>& temporalAccepted, ReservoirBuffer& reservoirs,
                             ReservoirBuffer& spare, CellGrid& grid, PassStats& stats) {
  tbb::enumerable_thread_specific<CellScratch> cellScratch;
  uint64_t cellReads = 0;  // BuildCells reads every surface pixel's confidence once per iteration
  RunSpatialIterations(
      params, view, reservoirs, spare, stats,
      [&](const ReservoirBuffer& input) {
        BuildCells(*view.gbuffer, input, params.stochastic, grid);
        cellReads += grid.pixels.size();
      },
      [&](const SpatialBatch& b) { CellBatch(params, temporalAccepted, grid, b, cellScratch.local()); });
  stats.reservoirReads += cellReads;
}

}  // namespace restir
