#include "sim/estimator/passes/shade.h"

#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>

#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"
#include "sim/scene/shading_point.h"

namespace restir {

void Shade(const ShadeParams& params, const FrameView& view, ReservoirBuffer& reservoirs, ImageRgb& image,
           PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  const int w = g.width, h = g.height;
  image = ImageRgb(w, h);
  const std::vector<LightTriangle>& lights = view.Lights();
  const bool carryVisibility = params.visibility != VisibilityReuse::kNone;
  tbb::combinable<uint64_t> targets([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> contributing([] { return uint64_t{0}; });
  struct RowScratch {
    TargetPairBuffer pairs;
    std::vector<float> target, f[3];
    std::vector<uint32_t> pixelOf, rayOf;
    ShadowRayBatch shadowRays;
  };
  tbb::enumerable_thread_specific<RowScratch> scratch;
  // f comes from the target kernel, a row's shadow rays go to Embree as one batch.
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    RowScratch& sc = scratch.local();
    sc.pairs.Clear();
    sc.pixelOf.clear();
    sc.rayOf.clear();
    sc.shadowRays.Clear();
    for (int x = 0; x < w; ++x) {
      const size_t i = rowStart + static_cast<size_t>(x);
      const StoredReservoir& r = reservoirs[i];
      LightPoint y;
      if (!(g.IsSurface(i) && r.HasSample() &&
            LightPointAt(g.Position(i), r.lightId, r.position, r.normal, lights, &view.sky, y)))
        continue;
      sc.pairs.Add(view.eye, g, i, y.position, y.normal, y.radiance);
      sc.pixelOf.push_back(static_cast<uint32_t>(x));
    }
    const size_t m = sc.pixelOf.size();
    targets.local() += m;
    sc.target.resize(m);
    for (auto& v : sc.f) v.resize(m);
    float* contribution[3] = {sc.f[0].data(), sc.f[1].data(), sc.f[2].data()};
    sc.pairs.Evaluate(*view.materials, sc.target.data(), contribution);
    if (!carryVisibility) {
      for (size_t k = 0; k < m; ++k) {
        if (!(sc.f[0][k] > 0.0f || sc.f[1][k] > 0.0f || sc.f[2][k] > 0.0f)) continue;
        const size_t i = rowStart + sc.pixelOf[k];
        StoredReservoir& r = reservoirs[i];
        if (params.reuseFinalVisibility && StoredVisibilityUsable(r.history, params)) {
          for (auto& f : sc.f) f[k] *= r.visibility;
          continue;
        }
        sc.shadowRays.Add(g, i, r, lights);
        sc.rayOf.push_back(static_cast<uint32_t>(k));
      }
      const std::vector<uint8_t>& occluded = sc.shadowRays.Trace(*view.scene, SceneFrame::kCurrent);
      rays.local() += occluded.size();
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
    size_t k = 0;
    for (int x = 0; x < w; ++x) {
      const size_t i = rowStart + static_cast<size_t>(x);
      Vec3 c = view.camera ? DirectEmission(g, i, lights, view.sky, *view.camera) : DirectEmission(g, i, lights);
      if (k < m && sc.pixelOf[k] == static_cast<uint32_t>(x)) {
        const StoredReservoir& r = reservoirs[i];
        Vec3 fx(sc.f[0][k], sc.f[1][k], sc.f[2][k]);
        if (carryVisibility) fx *= r.visibility;
        const Vec3 e = fx * r.W;
        if (e.x > 0.0f || e.y > 0.0f || e.z > 0.0f) contributing.local() += 1;
        c += e;
        ++k;
      }
      if (!IsFinite(c)) {
        guarded.local() += 1;
        c = Vec3(0.0f);
      }
      image.pixels[i] = c;
    }
  });
  stats.name = "shade";
  stats.ms = MsSince(t0);
  stats.rays = rays.combine(std::plus<uint64_t>());
  stats.targets = targets.combine(std::plus<uint64_t>());
  stats.guarded = guarded.combine(std::plus<uint64_t>());
  stats.contributing = contributing.combine(std::plus<uint64_t>());
}

}  // namespace restir
