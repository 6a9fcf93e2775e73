#include "sim/pipeline.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>

#include "core/gris.h"
#include "core/ris_kernel.h"
#include "core/rng.h"
#include "core/spmis.h"

namespace restir {

namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Rows are the unit of parallel work: every pixel is independent, so the result does not depend on the split.
template <typename F>
void ForEachRow(int height, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y) f(y);
  });
}

}  // namespace

std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence) {
  std::vector<Bsdf> out;
  out.reserve(sequence.materials.size());
  for (const Material& m : sequence.materials) {
    Bsdf b;
    b.type = m.type == MaterialType::kGgx ? BsdfType::kGgx : BsdfType::kDiffuse;
    b.albedo = m.albedo;
    b.alpha = m.roughness * m.roughness;
    out.push_back(b);
  }
  return out;
}

ShadingPoint ShadingPointAt(const GBuffer& g, size_t i, const Camera& camera, const std::vector<Bsdf>& bsdfs) {
  ShadingPoint sp;
  sp.position = g.Position(i);
  sp.geometricNormal = g.GeometricNormal(i);
  sp.shadingNormal = g.ShadingNormal(i);
  sp.wo = glm::normalize(camera.position - sp.position);
  sp.bsdf = bsdfs[static_cast<size_t>(g.materialId[i])];
  return sp;
}

Vec3 DirectEmission(const GBuffer& g, size_t i, const std::vector<LightTriangle>& lights) {
  const int32_t id = g.lightId[i];
  if (id < 0) return Vec3(0.0f);
  const LightTriangle& t = lights[static_cast<size_t>(id)];
  // The G-buffer normal faces the camera; the emitter is seen from its front when its own normal does too.
  return glm::dot(t.normal, g.GeometricNormal(i)) > 0.0f ? t.radiance : Vec3(0.0f);
}

bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       SceneFrame frame) {
  const Vec3 toLight = lightPosition - sp.position;
  const float d = glm::length(toLight);
  const Vec3 dir = toLight / d;
  const Vec3 org = OffsetRayOrigin(sp.position, sp.geometricNormal, dir);
  // Stop a relative 1e-3 short of the light point so the emitter itself never counts as an occluder.
  const float tmax = glm::length(lightPosition - org) * (1.0f - 1e-3f);
  return scene.Occluded(org, dir, tmax, frame);
}

// A resampling domain: a surface in a frame, with that frame's lights and scene (DESIGN §4 "p̂ from i").
struct Domain {
  ShadingPoint sp;
  const std::vector<LightTriangle>* lights = nullptr;
  SceneFrame frame = SceneFrame::kCurrent;
};

namespace {

// p̂_d(y): the domain's unshadowed target with the emitter radiance of the domain's frame (a light switched
// off in that frame gives 0), times visibility traced in that frame when requested.
float DomainTarget(const Domain& d, const LightSample& y, bool withVisibility, const EmbreeScene& scene,
                   uint64_t& rays) {
  if (y.lightId >= d.lights->size()) return 0.0f;
  LightSample lit = y;
  lit.radiance = (*d.lights)[y.lightId].radiance;
  float t = TargetFunction(UnshadowedContribution(d.sp, lit));
  if (t > 0.0f && withVisibility) {
    ++rays;
    if (ShadowRayOccluded(scene, d.sp, y.position, d.frame)) t = 0.0f;
  }
  return t;
}

// Lazily evaluated, memoised p̂_j(Y_i) for up to kMaxGrisInputs inputs, so that a family pays only for the
// entries (and, ray traced, the rays) it uses.
class TargetMatrix {
 public:
  TargetMatrix(const Domain* domains, const LightSample* samples, int count, bool visibility,
               const EmbreeScene& scene, uint64_t& rays)
      : domains_(domains), samples_(samples), count_(count), visibility_(visibility), scene_(scene), rays_(rays) {
    for (int k = 0; k < count * count; ++k) cache_[k] = -1.0f;
  }
  float operator()(int j, int i) {
    float& v = cache_[j * count_ + i];
    if (v < 0.0f) v = DomainTarget(domains_[j], samples_[i], visibility_, scene_, rays_);
    return v;
  }

 private:
  const Domain* domains_;
  const LightSample* samples_;
  int count_;
  bool visibility_;
  const EmbreeScene& scene_;
  uint64_t& rays_;
  float cache_[kMaxGrisInputs * kMaxGrisInputs];
};

MisFamily EffectiveFamily(MisFamily family, BiasCorrection bias) {
  return bias == BiasCorrection::kNone ? MisFamily::kUniform : family;
}

VisibilityCarry CarryFor(VisibilityReuse v) {
  return v == VisibilityReuse::kWeighted ? VisibilityCarry::kWeighted : VisibilityCarry::kSelected;
}

bool SimilarSurface(const GBuffer& a, size_t i, const GBuffer& b, size_t j, float normalThreshold,
                    float depthThreshold) {
  if (b.objectId[j] < 0 || b.materialId[j] < 0) return false;
  if (glm::dot(a.GeometricNormal(i), b.GeometricNormal(j)) < normalThreshold) return false;
  const float da = a.depth[i], db = b.depth[j];
  return std::abs(da - db) <= depthThreshold * std::max(da, db);
}

bool FiniteReservoir(const Reservoir& r) {
  return std::isfinite(r.W) && std::isfinite(r.confidence) && std::isfinite(r.visibility) && r.W >= 0.0f;
}

}  // namespace

// Stochastic pairwise reuse for one pixel (seed 004 §3-5): pick a neighbour cell by weighted reservoir
// sampling, draw N contributing pixels of it by P(i) ∝ c_i p̂_i(X_i) W_i and N_c pixels uniformly, and combine
// with the stochastic pairwise weights.
void Pipeline::StochasticPairwiseReuse(const FrameInputs& in, size_t i, int x, int y, const Domain& self,
                                       Sampler& s, uint64_t& rays, uint64_t& guarded) {
  const SpatialParams& sp = settings_.spatial;
  const GBuffer& g = *in.gbuffer;
  const int w = g.width, h = g.height;
  const Camera& camera = in.state->camera;
  const std::vector<LightTriangle>& lights = in.scene->LightTriangles();
  const Vec3 n = g.GeometricNormal(i);

  // §5.1: 12 random pixels in a growing radius; similar cells compete with weight = their confidence sum.
  int32_t chosen = -1;
  float cellWeightSum = 0.0f, radius = sp.cellSearchRadius;
  for (int it = 0; it < sp.cellSearchIterations; ++it, radius *= sp.cellSearchGrowth) {
    const float r = radius * std::sqrt(s.Next()), phi = 2.0f * kPi * s.Next(), uPick = s.Next();
    const int qx = x + static_cast<int>(std::lround(r * std::cos(phi)));
    const int qy = y + static_cast<int>(std::lround(r * std::sin(phi)));
    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
    const int32_t c = pixelCell_[static_cast<size_t>(qy) * w + qx];
    if (c < 0) continue;
    const Cell& cell = cells_[static_cast<size_t>(c)];
    if (cell.objectId != g.objectId[i] || glm::dot(cell.normal, n) < sp.normalThreshold) continue;
    if (!(cell.confidenceSum > 0.0f)) continue;
    cellWeightSum += cell.confidenceSum;
    if (uPick * cellWeightSum < cell.confidenceSum) chosen = c;
  }
  if (chosen < 0) return;
  const Cell& cell = cells_[static_cast<size_t>(chosen)];

  // The cell's candidates, the current pixel excluded: all M of them, and the contributing ones with P(i).
  uint32_t candidates[kMaxCellPixels];
  float cumulative[kMaxCellPixels];
  uint32_t contributing[kMaxCellPixels];
  int m = 0, k = 0;
  float confidenceSum = 0.0f, contributionSum = 0.0f;
  for (uint32_t t = 0; t < cell.count; ++t) {
    const uint32_t p = cellPixels_[cell.first + t];
    if (p == i) continue;
    candidates[m++] = p;
    const Reservoir& r = spatialInput_[p];
    confidenceSum += r.confidence;
    const float contribution = r.HasSample() ? r.confidence * r.targetPdf * r.W : 0.0f;  // Eq. 17
    if (contribution > 0.0f && std::isfinite(contribution)) {
      contributionSum += contribution;
      contributing[k] = p;
      cumulative[k++] = contributionSum;
    }
  }
  if (m == 0) return;
  const float bigM = static_cast<float>(m), bigN = static_cast<float>(sp.draws);
  const float nc = static_cast<float>(sp.canonicalDraws);
  const float scale = sp.confidenceScaling ? bigN / bigM : 1.0f;  // §4.3
  const float cBar = confidenceSum * scale;
  const Reservoir& selfRes = spatialInput_[i];
  const float cc = selfRes.confidence;
  const bool rayTraced = sp.bias == BiasCorrection::kRayTraced;

  // Non-canonical: N draws with replacement by P(i); distinct draws become inputs with multiplicity K(i).
  Domain domains[kMaxGrisInputs];
  LightSample samples[kMaxGrisInputs];
  GrisInput inputs[kMaxGrisInputs];
  float multiplicity[kMaxGrisInputs], probability[kMaxGrisInputs];
  uint32_t pixelOf[kMaxGrisInputs];
  domains[0] = self;
  samples[0] = selfRes.sample;
  inputs[0] = GrisInput{selfRes.HasSample(), selfRes.W, cc, selfRes.visibility};
  int count = 1;
  for (int d = 0; d < sp.draws; ++d) {
    const float u = s.Next();
    if (k == 0) continue;
    const int idx = SampleCumulative(cumulative, k, u);
    const uint32_t p = contributing[idx];
    int slot = 1;
    while (slot < count && pixelOf[slot] != p) ++slot;
    if (slot == count) {
      const Reservoir& r = spatialInput_[p];
      pixelOf[slot] = p;
      multiplicity[slot] = 0.0f;
      probability[slot] = (cumulative[idx] - (idx > 0 ? cumulative[idx - 1] : 0.0f)) / contributionSum;
      domains[slot] = Domain{ShadingPointAt(g, p, camera, *in.materials), &lights, SceneFrame::kCurrent};
      samples[slot] = r.sample;
      inputs[slot] = GrisInput{r.HasSample(), r.W, r.confidence * scale, r.visibility};
      if (settings_.shade.visibility != VisibilityReuse::kNone && r.HasSample()) {
        rays += 1;  // seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel
        inputs[slot].visibility = ShadowRayOccluded(*in.scene, self.sp, r.sample.position) ? 0.0f : 1.0f;
      }
      ++count;
    }
    multiplicity[slot] += 1.0f;
  }
  TargetMatrix target(domains, samples, count, rayTraced, *in.scene, rays);
  float mis[kMaxGrisInputs], pc[kMaxGrisInputs];
  for (int t = 0; t < count; ++t) {
    mis[t] = 0.0f;
    pc[t] = inputs[t].hasSample ? target(0, t) : 0.0f;
  }
  // Canonical: base share plus N_c uniform draws (P_c = 1/M) of the pairwise terms (Eq. 18-19).
  if (inputs[0].hasSample && pc[0] > 0.0f) {
    mis[0] = MisPairwiseCanonicalBase(cBar, cc);
    uint32_t drawn[kMaxGrisInputs];
    float drawnCount[kMaxGrisInputs];
    int distinct = 0;
    for (int d = 0; d < sp.canonicalDraws; ++d) {
      const uint32_t p = candidates[std::min(m - 1, static_cast<int>(s.Next() * bigM))];
      int slot = 0;
      while (slot < distinct && drawn[slot] != p) ++slot;
      if (slot == distinct) drawn[distinct] = p, drawnCount[distinct++] = 0.0f;
      drawnCount[slot] += 1.0f;
    }
    for (int d = 0; d < distinct; ++d) {
      const Domain dj{ShadingPointAt(g, drawn[d], camera, *in.materials), &lights, SceneFrame::kCurrent};
      const float tj = DomainTarget(dj, samples[0], rayTraced, *in.scene, rays);
      mis[0] += StochasticPairwiseCanonicalTerm(drawnCount[d], nc, 1.0f / bigM, spatialInput_[drawn[d]].confidence * scale,
                                                cBar, cc, tj, pc[0]);
    }
  } else {
    // Still consume the canonical draws so every pixel's random stream has the same layout.
    for (int d = 0; d < sp.canonicalDraws; ++d) s.Next();
  }
  for (int t = 1; t < count; ++t)
    if (inputs[t].hasSample && pc[t] > 0.0f)
      mis[t] = StochasticPairwiseNonCanonical(multiplicity[t], bigN, probability[t], inputs[t].confidence, cBar, cc,
                                              target(t, t), pc[t]);
  float u[kMaxGrisInputs];
  for (int t = 0; t < count; ++t) u[t] = s.Next();
  const GrisResult gr = GrisResample(inputs, mis, pc, count, u, CarryFor(settings_.shade.visibility));
  guarded += static_cast<uint64_t>(gr.guarded);
  Reservoir out;
  out.confidence = cc + cBar;  // the canonical plus the (scaled) cell it stands for
  if (gr.selected >= 0) {
    out.sample = samples[gr.selected];
    out.targetPdf = pc[gr.selected];
    out.W = gr.W;
    out.weightSum = gr.weightSum;
    out.visibility = gr.visibility;
  }
  reservoirs_[i] = out;
}

// Screen-space cells (seed 004 §5): each tile's surface pixels grouped by (object id, quantised normal), built
// sequentially in tile and scan order so the lists never depend on the thread count.
void Pipeline::BuildCells(const GBuffer& g, const std::vector<Reservoir>& reservoirs) {
  const SpatialParams& sp = settings_.spatial;
  const int w = g.width, h = g.height, tile = std::max(1, sp.cellTile);
  const int tilesX = (w + tile - 1) / tile, tilesY = (h + tile - 1) / tile;
  cells_.clear();
  cellPixels_.clear();
  pixelCell_.assign(g.Size(), -1);
  std::vector<std::pair<uint32_t, uint32_t>> members;  // (cell, pixel) for one tile
  for (int ty = 0; ty < tilesY; ++ty) {
    for (int tx = 0; tx < tilesX; ++tx) {
      const uint32_t tileIndex = static_cast<uint32_t>(ty * tilesX + tx);
      const size_t firstCell = cells_.size();
      members.clear();
      for (int y = ty * tile; y < std::min(h, (ty + 1) * tile); ++y) {
        for (int x = tx * tile; x < std::min(w, (tx + 1) * tile); ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i)) continue;
          const uint32_t q = QuantiseNormal(g.GeometricNormal(i), static_cast<uint32_t>(sp.normalBins));
          const uint32_t key = CellKey(tileIndex, static_cast<uint32_t>(g.objectId[i]), q);
          size_t c = firstCell;
          while (c < cells_.size() && !(cells_[c].key == key && cells_[c].objectId == g.objectId[i])) ++c;
          if (c == cells_.size()) {
            Cell cell;
            cell.objectId = g.objectId[i];
            cell.key = key;
            cells_.push_back(cell);
          }
          cells_[c].normal += g.GeometricNormal(i);
          cells_[c].confidenceSum += reservoirs[i].confidence;
          cells_[c].count += 1;
          members.emplace_back(static_cast<uint32_t>(c), static_cast<uint32_t>(i));
        }
      }
      // Lay the tile's cells out contiguously, each in scan order.
      for (size_t c = firstCell; c < cells_.size(); ++c) {
        cells_[c].first = static_cast<uint32_t>(cellPixels_.size());
        cells_[c].normal = glm::normalize(cells_[c].normal);
        for (const auto& [cell, pixel] : members)
          if (cell == c) {
            cellPixels_.push_back(pixel);
            pixelCell_[pixel] = static_cast<int32_t>(c);
          }
      }
    }
  }
}

FrameResult Pipeline::RenderFrame(const FrameInputs& in) {
  const GBuffer& g = *in.gbuffer;
  const int w = g.width, h = g.height;
  const size_t n = g.Size();
  reservoirs_.assign(n, Reservoir{});
  FrameResult result;
  result.image = ImageRgb(w, h);
  result.temporalAccepted.assign(n, 0);
  const Camera& camera = in.state->camera;
  const InitialSamplingParams& ip = settings_.initial;
  const TemporalParams& tp = settings_.temporal;
  const SpatialParams& spp = settings_.spatial;
  const std::vector<LightTriangle>& lights = in.scene->LightTriangles();
  const bool carryVisibility = settings_.shade.visibility != VisibilityReuse::kNone;
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });

  // Initial sampling: streaming RIS over M candidates from the light sampler (seed 003 §1).
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  auto t0 = std::chrono::steady_clock::now();
  // The RIS itself runs in the SIMD kernel (core/ris_kernel.h) a row at a time, on the target core/simd.h
  // selects; every target gives the same bits.
  const RisMaterials risMaterials = MakeRisMaterials(*in.materials);
  const RisParams risParams{in.seed, in.frame, static_cast<uint32_t>(RngPass::kInitial), ip.candidates};
  const bool haveLights = !in.lights->Empty();
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    const size_t rw = static_cast<size_t>(w);
    // Row inputs the G-buffer does not hold as arrays: wo and the surface mask.
    std::vector<float> woRow[3];
    for (auto& v : woRow) v.resize(rw);
    std::vector<uint8_t> activeRow(rw, 0);
    for (size_t x = 0; x < rw; ++x) {
      const size_t i = rowStart + x;
      if (!g.IsSurface(i) || !haveLights) continue;
      activeRow[x] = 1;
      const Vec3 wo = glm::normalize(camera.position - g.Position(i));  // as ShadingPointAt
      for (int c = 0; c < 3; ++c) woRow[c][x] = wo[c];
    }
    std::vector<int32_t> outId(rw);
    std::vector<float> outF[12];
    for (auto& v : outF) v.resize(rw);
    RisPixels px;
    px.position[0] = g.posX.data() + rowStart, px.position[1] = g.posY.data() + rowStart;
    px.position[2] = g.posZ.data() + rowStart;
    px.geometricNormal[0] = g.ngX.data() + rowStart, px.geometricNormal[1] = g.ngY.data() + rowStart;
    px.geometricNormal[2] = g.ngZ.data() + rowStart;
    px.shadingNormal[0] = g.nsX.data() + rowStart, px.shadingNormal[1] = g.nsY.data() + rowStart;
    px.shadingNormal[2] = g.nsZ.data() + rowStart;
    for (int c = 0; c < 3; ++c) px.wo[c] = woRow[c].data();
    px.materialId = g.materialId.data() + rowStart;
    px.active = activeRow.data();
    px.pixelBase = static_cast<uint32_t>(rowStart);
    px.count = rw;
    RisOutput ro;
    ro.lightId = outId.data();
    for (int c = 0; c < 3; ++c) {
      ro.position[c] = outF[c].data();
      ro.normal[c] = outF[3 + c].data();
      ro.radiance[c] = outF[6 + c].data();
    }
    ro.pdfArea = outF[9].data();
    ro.weightSum = outF[10].data();
    ro.targetPdf = outF[11].data();
    if (haveLights) RisInitialSampling(px, in.lights->Soa(), risMaterials, risParams, ro);
    for (int x = 0; x < w; ++x) {
      const size_t i = rowStart + static_cast<size_t>(x);
      if (!activeRow[x]) continue;
      Reservoir r;
      r.sample.lightId = static_cast<uint32_t>(outId[x]);
      r.sample.position = Vec3(outF[0][x], outF[1][x], outF[2][x]);
      r.sample.normal = Vec3(outF[3][x], outF[4][x], outF[5][x]);
      r.sample.radiance = Vec3(outF[6][x], outF[7][x], outF[8][x]);
      r.sample.pdfArea = outF[9][x];
      r.weightSum = outF[10][x];
      r.targetPdf = outF[11][x];
      FinalizeRis(r, static_cast<float>(ip.candidates));
      // An initial reservoir counts one frame of history (DESIGN §4), or its candidates (seed 003).
      if (!ip.countCandidates) r.confidence = 1.0f;
      if (ip.visibility && r.HasSample()) {
        rays.local() += 1;
        const ShadingPoint sp = ShadingPointAt(g, i, camera, *in.materials);
        if (ShadowRayOccluded(*in.scene, sp, r.sample.position)) r.W = 0.0f, r.visibility = 0.0f;
      }
      if (!FiniteReservoir(r)) {
        guarded.local() += 1;
        r = Reservoir{};
        r.confidence = ip.countCandidates ? static_cast<float>(ip.candidates) : 1.0f;
      }
      reservoirs_[i] = r;
    }
  });
  result.passes.push_back({"initial", MsSince(t0), rays.combine(std::plus<uint64_t>())});

  // Temporal reuse (seed 003 §3-5; DESIGN §4): the previous reservoir at the reprojected pixel, validated,
  // confidence-capped, combined with the current one by GRIS.
  const bool haveHistory = tp.enabled && in.previousGbuffer && in.previousState &&
                           previousReservoirs_.size() == n && in.previousGbuffer->Size() == n;
  if (tp.enabled) {
    tbb::combinable<uint64_t> trays([] { return uint64_t{0}; });
    tbb::combinable<uint64_t> crossObject([] { return uint64_t{0}; });
    t0 = std::chrono::steady_clock::now();
    // RTXDI permutation sampling: one XOR pattern per frame, so neighbouring pixels read different history.
    const RngKey frameKey{in.seed, in.frame, 0xFFFFFFFFu, static_cast<uint32_t>(RngPass::kTemporal)};
    const uint32_t permBits = tp.permutation ? (RandomBits(frameKey, 0) & 3u) : 0u;
    const MisFamily family = EffectiveFamily(tp.mis, tp.bias);
    if (haveHistory) {
      const GBuffer& pg = *in.previousGbuffer;
      ForEachRow(h, [&](int y) {
        uint64_t& localRays = trays.local();
        for (int x = 0; x < w; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i) || !g.prevValid[i]) continue;
          int px = std::clamp(static_cast<int>(std::floor(g.prevX[i])), 0, w - 1);
          int py = std::clamp(static_cast<int>(std::floor(g.prevY[i])), 0, h - 1);
          size_t pi = static_cast<size_t>(py) * w + px;
          if (permBits) {
            const int qx = std::clamp(px ^ static_cast<int>(permBits & 1u), 0, w - 1);
            const int qy = std::clamp(py ^ static_cast<int>(permBits >> 1), 0, h - 1);
            const size_t qi = static_cast<size_t>(qy) * w + qx;
            if (pg.objectId[qi] == pg.objectId[pi] && SimilarSurface(pg, pi, pg, qi, 0.9f, 0.1f)) pi = qi;
          }
          const Reservoir& prev = previousReservoirs_[pi];
          if (!FiniteReservoir(prev) || !pg.IsSurface(pi)) continue;
          Reservoir& cur = reservoirs_[i];
          Domain domains[2];
          domains[0] = Domain{ShadingPointAt(g, i, camera, *in.materials), &lights, SceneFrame::kCurrent};
          domains[1] = Domain{ShadingPointAt(pg, pi, in.previousState->camera, *in.materials), in.previousLights,
                              SceneFrame::kPrevious};
          const LightSample samples[2] = {cur.sample, prev.sample};
          TargetMatrix target(domains, samples, 2, tp.bias == BiasCorrection::kRayTraced, *in.scene, localRays);
          if (tp.sampleChecks) {
            if (!prev.HasSample() || !(target(0, 1) > 0.0f)) continue;
            if (tp.targetRatioClamp) {
              const float ratio = prev.targetPdf > 0.0f ? target(0, 1) / prev.targetPdf : 0.0f;
              if (!(ratio >= 0.1f && ratio <= 10.0f)) continue;
            }
          }
          if (pg.objectId[pi] != g.objectId[i]) crossObject.local() += 1;
          GrisInput inputs[2];
          inputs[0] = GrisInput{cur.HasSample(), cur.W, cur.confidence, cur.visibility};
          inputs[1] = GrisInput{prev.HasSample(), prev.W, std::min(prev.confidence, tp.maxHistory), prev.visibility};
          const RngKey key{in.seed, in.frame, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kTemporal)};
          const float u[2] = {UniformFloat(key, 0), UniformFloat(key, 1)};
          const GrisResult gr = GrisCombine(family, inputs, 2, target, u, CarryFor(settings_.shade.visibility));
          guarded.local() += static_cast<uint64_t>(gr.guarded);
          Reservoir out;
          out.confidence = gr.confidence;
          if (gr.selected >= 0) {
            out.sample = samples[gr.selected];
            out.targetPdf = target(0, gr.selected);
            out.W = gr.W;
            out.weightSum = gr.weightSum;
            out.visibility = gr.visibility;
          }
          cur = out;
          result.temporalAccepted[i] = 1;
        }
      });
    }
    result.crossObjectReuse = crossObject.combine(std::plus<uint64_t>());
    result.passes.push_back({"temporal", MsSince(t0), trays.combine(std::plus<uint64_t>())});
  }

  // Spatial reuse (DESIGN §4): k random neighbours in a disk, similarity-tested, combined by GRIS with the
  // pixel's own reservoir as the canonical input; more neighbours where temporal reuse failed.
  if (spp.enabled) {
    tbb::combinable<uint64_t> srays([] { return uint64_t{0}; });
    t0 = std::chrono::steady_clock::now();
    const MisFamily family = EffectiveFamily(spp.mis, spp.bias);
    const bool stochastic = family == MisFamily::kStochasticPairwise;
    for (int iteration = 0; iteration < spp.iterations; ++iteration) {
      spatialInput_ = reservoirs_;
      if (stochastic) BuildCells(g, spatialInput_);
      ForEachRow(h, [&](int y) {
        uint64_t& localRays = srays.local();
        for (int x = 0; x < w; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i)) continue;
          if (stochastic) {
            Sampler s(RngKey{in.seed, in.frame, static_cast<uint32_t>(i),
                             static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)});
            const Domain self{ShadingPointAt(g, i, camera, *in.materials), &lights, SceneFrame::kCurrent};
            StochasticPairwiseReuse(in, i, x, y, self, s, localRays, guarded.local());
            continue;
          }
          const bool boost = tp.enabled && !result.temporalAccepted[i];
          const int k = std::min(boost ? spp.disocclusionNeighbours : spp.neighbours, kMaxGrisInputs - 1);
          Sampler s(RngKey{in.seed, in.frame, static_cast<uint32_t>(i),
                           static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)});
          Domain domains[kMaxGrisInputs];
          LightSample samples[kMaxGrisInputs];
          GrisInput inputs[kMaxGrisInputs];
          domains[0] = Domain{ShadingPointAt(g, i, camera, *in.materials), &lights, SceneFrame::kCurrent};
          const Reservoir& self = spatialInput_[i];
          samples[0] = self.sample;
          inputs[0] = GrisInput{self.HasSample(), self.W, self.confidence, self.visibility};
          int count = 1;
          for (int t = 0; t < k; ++t) {
            // Uniform point in a disk of the given radius (polar map), rounded to a pixel.
            const float r = spp.radius * std::sqrt(s.Next());
            const float phi = 2.0f * kPi * s.Next();
            const int nx = x + static_cast<int>(std::lround(r * std::cos(phi)));
            const int ny = y + static_cast<int>(std::lround(r * std::sin(phi)));
            if (nx < 0 || ny < 0 || nx >= w || ny >= h || (nx == x && ny == y)) continue;
            const size_t ni = static_cast<size_t>(ny) * w + nx;
            if (!g.IsSurface(ni) || !SimilarSurface(g, i, g, ni, spp.normalThreshold, spp.depthThreshold)) continue;
            const Reservoir& nr = spatialInput_[ni];
            if (!FiniteReservoir(nr)) continue;
            domains[count] = Domain{ShadingPointAt(g, ni, camera, *in.materials), &lights, SceneFrame::kCurrent};
            samples[count] = nr.sample;
            inputs[count] = GrisInput{nr.HasSample(), nr.W, nr.confidence, nr.visibility};
            // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
            if (carryVisibility && nr.HasSample()) {
              localRays += 1;
              inputs[count].visibility =
                  ShadowRayOccluded(*in.scene, domains[0].sp, nr.sample.position) ? 0.0f : 1.0f;
            }
            ++count;
          }
          if (count == 1) continue;
          TargetMatrix target(domains, samples, count, spp.bias == BiasCorrection::kRayTraced, *in.scene,
                              localRays);
          float u[kMaxGrisInputs];
          for (int t = 0; t < count; ++t) u[t] = s.Next();
          const GrisResult gr = GrisCombine(family, inputs, count, target, u, CarryFor(settings_.shade.visibility));
          guarded.local() += static_cast<uint64_t>(gr.guarded);
          Reservoir out;
          out.confidence = gr.confidence;
          if (gr.selected >= 0) {
            out.sample = samples[gr.selected];
            out.targetPdf = target(0, gr.selected);
            out.W = gr.W;
            out.weightSum = gr.weightSum;
            out.visibility = gr.visibility;
          }
          reservoirs_[i] = out;
        }
      });
    }
    result.passes.push_back({"spatial", MsSince(t0), srays.combine(std::plus<uint64_t>())});
  }

  // Shading: f(Y) W with a final shadow ray, or f_unshadowed(Y) V W with the carried visibility (seed 000
  // Algorithm 1), plus what the primary ray sees directly.
  tbb::combinable<uint64_t> shadeRays([] { return uint64_t{0}; });
  t0 = std::chrono::steady_clock::now();
  ForEachRow(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      Vec3 c = DirectEmission(g, i, lights);
      const Reservoir& r = reservoirs_[i];
      if (g.IsSurface(i) && r.HasSample() && r.sample.lightId < lights.size()) {
        const ShadingPoint sp = ShadingPointAt(g, i, camera, *in.materials);
        LightSample lit = r.sample;
        lit.radiance = lights[lit.lightId].radiance;
        Vec3 f = UnshadowedContribution(sp, lit);
        if (carryVisibility) {
          f *= r.visibility;
        } else if (f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) {
          shadeRays.local() += 1;
          if (ShadowRayOccluded(*in.scene, sp, r.sample.position)) f = Vec3(0.0f);
        }
        c += f * r.W;
      }
      if (!IsFinite(c)) {
        guarded.local() += 1;
        c = Vec3(0.0f);
      }
      result.image.pixels[i] = c;
    }
  });
  result.passes.push_back({"shade", MsSince(t0), shadeRays.combine(std::plus<uint64_t>())});
  result.guardedEvents = guarded.combine(std::plus<uint64_t>());

  // Counters, in pixel order (deterministic).
  size_t surfaces = 0, accepted = 0;
  double confidence = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!g.IsSurface(i)) continue;
    ++surfaces;
    accepted += result.temporalAccepted[i];
    confidence += reservoirs_[i].confidence;
  }
  result.temporalAcceptance = surfaces ? double(accepted) / double(surfaces) : 0.0;
  result.meanConfidence = surfaces ? confidence / double(surfaces) : 0.0;
  std::swap(previousReservoirs_, reservoirs_);
  return result;
}

}  // namespace restir
