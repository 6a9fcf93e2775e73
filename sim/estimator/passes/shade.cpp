#include "sim/estimator/passes/shade.h"

#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>

#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"
#include "sim/scene/shading_point.h"

namespace restir {

namespace {

// Per-thread scratch of a row, kept from row to row.
struct RowScratch {
  TargetPairBuffer pairs;              // (receiver, light point) of each pixel with a sample to shade
  std::vector<float> target, f[3];     // per pair: p̂, and f = L_e f_r G per channel (then times V)
  std::vector<uint32_t> pixelOf;       // per pair: its pixel's x
  std::vector<uint32_t> rayOf;         // per shadow ray: its pair
  ShadowRayBatch shadowRays;           // the row's final shadow rays
};

// What every row reads, decided once per frame.
struct ShadeFrame {
  const ShadeParams& params;                 // the pass's parameters
  const FrameView& view;                     // the frame
  const GBuffer& g;                          // *view.gbuffer
  const std::vector<LightTriangle>& lights;  // view.Lights()
  bool carryVisibility;                      // shade with the reservoirs' carried V, no final ray
};

// The row's pixels with a sample to shade as (receiver, light point) pairs, and f of each from the target kernel.
// Returns the pairs.
size_t EvaluateRow(const ShadeFrame& sf, const ReservoirBuffer& reservoirs, size_t rowStart, RowScratch& sc) {
  const GBuffer& g = sf.g;
  for (int x = 0; x < g.width; ++x) {
    const size_t i = rowStart + static_cast<size_t>(x);
    const StoredReservoir& r = reservoirs[i];
    LightPoint y;
    if (!(g.IsSurface(i) && r.HasSample() &&
          LightPointAt(g.Position(i), r.lightId, r.position, r.normal, sf.lights, &sf.view.sky, y)))
      continue;
    sc.pairs.Add(sf.view.eye, g, i, y.position, y.normal, y.radiance);
    sc.pixelOf.push_back(static_cast<uint32_t>(x));
  }
  const size_t m = sc.pixelOf.size();
  sc.target.resize(m);
  for (auto& v : sc.f) v.resize(m);
  float* contribution[3] = {sc.f[0].data(), sc.f[1].data(), sc.f[2].data()};
  sc.pairs.Evaluate(*sf.view.materials, sc.target.data(), contribution);
  return m;
}

// The final shadow rays of the row's m pairs with f > 0, as one batch (or, with final-visibility reuse, the stored
// visibility where it is usable); an occluded pair's f becomes 0. RTXDI's write-backs into `reservoirs`:
// discardInvisibleSamples empties an occluded sample, reuseFinalVisibility stores what the ray found.
void TraceFinalVisibility(const ShadeFrame& sf, ReservoirBuffer& reservoirs, size_t rowStart, size_t m,
                          RowScratch& sc, uint64_t& rays) {
  const ShadeParams& params = sf.params;
  for (size_t k = 0; k < m; ++k) {
    if (!(sc.f[0][k] > 0.0f || sc.f[1][k] > 0.0f || sc.f[2][k] > 0.0f)) continue;
    const size_t i = rowStart + sc.pixelOf[k];
    StoredReservoir& r = reservoirs[i];
    if (params.reuseFinalVisibility && StoredVisibilityUsable(r.history, params)) {
      for (auto& f : sc.f) f[k] *= r.visibility;
      continue;
    }
    sc.shadowRays.Add(sf.g, i, r, sf.lights);
    sc.rayOf.push_back(static_cast<uint32_t>(k));
  }
  const std::vector<uint8_t>& occluded = sc.shadowRays.Trace(*sf.view.scene, SceneFrame::kCurrent);
  rays += occluded.size();
  for (size_t r = 0; r < occluded.size(); ++r) {
    const uint32_t k = sc.rayOf[r];
    StoredReservoir& stored = reservoirs[rowStart + sc.pixelOf[k]];
    if (occluded[r]) sc.f[0][k] = sc.f[1][k] = sc.f[2][k] = 0.0f;
    if (occluded[r] && params.discardInvisibleSamples) {  // its f is 0 already: the image keeps its value
      stored.W = 0.0f;
      stored.confidence = 0.0f;
    }
    if (params.reuseFinalVisibility) {  // RTXDI_StoreVisibilityInDIReservoir
      stored.visibility = occluded[r] ? 0.0f : 1.0f;
      stored.history.visibilityAge = 0;
      stored.history.distanceX = stored.history.distanceY = 0;
    }
  }
}

// The row's pixels: what the primary ray sees directly, plus f V W of the pixels with a pair (V carried, or in f
// from the final ray); a non-finite pixel is written as 0 and counted.
void WriteRow(const ShadeFrame& sf, const ReservoirBuffer& reservoirs, size_t rowStart, size_t m,
              const RowScratch& sc, ImageRgb& image, uint64_t& contributing, uint64_t& guarded) {
  const GBuffer& g = sf.g;
  const FrameView& view = sf.view;
  size_t k = 0;
  for (int x = 0; x < g.width; ++x) {
    const size_t i = rowStart + static_cast<size_t>(x);
    Vec3 c = !view.primaryEmission ? Vec3(0.0f)
             : view.camera         ? DirectEmission(g, i, sf.lights, view.sky, *view.camera)
                                   : DirectEmission(g, i, sf.lights);
    if (k < m && sc.pixelOf[k] == static_cast<uint32_t>(x)) {
      const StoredReservoir& r = reservoirs[i];
      Vec3 fx(sc.f[0][k], sc.f[1][k], sc.f[2][k]);
      if (sf.carryVisibility) fx *= r.visibility;
      const Vec3 e = fx * r.W;
      if (e.x > 0.0f || e.y > 0.0f || e.z > 0.0f) contributing += 1;
      c += e;
      ++k;
    }
    if (!IsFinite(c)) {
      guarded += 1;
      c = Vec3(0.0f);
    }
    image.pixels[i] = c;
  }
}

}  // namespace

void Shade(const ShadeParams& params, const FrameView& view, ReservoirBuffer& reservoirs, ImageRgb& image,
           PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  const int w = g.width, h = g.height;
  image = ImageRgb(w, h);
  const ShadeFrame sf{params, view, g, view.Lights(), params.visibility != VisibilityReuse::kNone};
  tbb::combinable<uint64_t> targets([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> contributing([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<RowScratch> scratch;
  // f comes from the target kernel, a row's shadow rays go to Embree as one batch.
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    RowScratch& sc = scratch.local();
    sc.pairs.Clear();
    sc.pixelOf.clear();
    sc.rayOf.clear();
    sc.shadowRays.Clear();
    const size_t m = EvaluateRow(sf, reservoirs, rowStart, sc);
    targets.local() += m;
    if (!sf.carryVisibility) TraceFinalVisibility(sf, reservoirs, rowStart, m, sc, rays.local());
    WriteRow(sf, reservoirs, rowStart, m, sc, image, contributing.local(), guarded.local());
  });
  stats.name = "shade";
  stats.ms = MsSince(t0);
  stats.rays = rays.combine(std::plus<uint64_t>());
  stats.targets = targets.combine(std::plus<uint64_t>());
  stats.guarded = guarded.combine(std::plus<uint64_t>());
  stats.contributing = contributing.combine(std::plus<uint64_t>());
}

}  // namespace restir
