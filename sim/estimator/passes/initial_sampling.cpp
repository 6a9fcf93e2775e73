#include "sim/estimator/passes/initial_sampling.h"

#include <tbb/combinable.h>

#include <optional>
#include <tbb/enumerable_thread_specific.h>

#include "core/ris_kernel.h"
#include "core/rng.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"
#include "sim/estimator/passes/candidate_sources.h"
#include "sim/scene/shading_point.h"

namespace restir {

// The effective counts of a frame: a source with nothing to sample draws nothing (core/candidates.h).
static CandidateCounts EffectiveCounts(const InitialSamplingParams& params, const FrameView& view) {
  CandidateCounts m;
  m.local = view.lights->Empty() ? 0 : params.candidates;
  m.sun = view.sky.hasSun ? params.sunCandidates : 0;
  m.environment = view.sky.HasEnvironment() ? params.environmentCandidates : 0;
  m.brdf = view.HasLight() ? params.brdfCandidates : 0;
  return m;
}


void InitialSampling(const InitialSamplingParams& params, const FrameView& view, ReservoirBuffer& out,
                     PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  const int w = g.width, h = g.height;
  out.assign(g.Size(), StoredReservoir{});
  const std::vector<LightTriangle>& lights = view.Lights();
  const RisParams risParams{view.seed, view.frame, static_cast<uint32_t>(RngPass::kInitial), params.candidates};
  // The frame's sampler selects lights by power; a uniform selection gets its own sampler (a pass over the lights).
  std::optional<LightSampler> uniformLights;
  if (params.lightSelection == LightSelection::kUniform) uniformLights.emplace(lights, LightSelection::kUniform);
  const LightSampler& sampler = uniformLights ? *uniformLights : *view.lights;
  const bool haveLights = !sampler.Empty();
  const CandidateCounts counts = EffectiveCounts(params, view);
  const bool mixed = NeedsCandidateSources(counts);
  // The kernel streams the local candidates in every configuration; with other sources its reservoir is one input
  // of their combination (sim/estimator/passes/candidate_sources.cpp).
  const bool runKernel = haveLights;
  const float confidence = params.countCandidates ? static_cast<float>(mixed ? counts.Total() : params.candidates)
                                                  : 1.0f;
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> risPixels([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<ShadowRayBatch> shadowRayBatches;
  // The RIS itself runs in the SIMD kernel a row at a time, on the target core/simd.h selects; every target gives
  // the same bits.
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    const size_t rw = static_cast<size_t>(w);
    // Row inputs the G-buffer does not hold as arrays: wo and the surface mask.
    std::vector<float> woRow[3];
    for (auto& v : woRow) v.resize(rw);
    std::vector<uint8_t> activeRow(rw, 0);
    for (size_t x = 0; x < rw; ++x) {
      const size_t i = rowStart + x;
      if (!g.IsSurface(i) || !view.HasLight()) continue;
      activeRow[x] = 1;
      const Vec3 wo = ViewDirection(view.eye, g.Position(i));
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
    px.materialId = g.bsdfId.data() + rowStart;  // the BSDF table index (textured receivers have their own)
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
    if (runKernel) RisInitialSampling(px, sampler.Soa(), *view.materials, risParams, ro);
    risPixels.local() += static_cast<uint64_t>(std::count(activeRow.begin(), activeRow.end(), uint8_t{1}));
    std::vector<Reservoir> row(rw);
    ShadowRayBatch& shadowRays = shadowRayBatches.local();
    shadowRays.Clear();
    std::vector<uint32_t> rayPixel;
    for (size_t x = 0; x < rw; ++x) {
      if (!activeRow[x]) continue;
      Reservoir& r = row[x];
      if (runKernel) {
        r.sample.lightId = static_cast<uint32_t>(outId[x]);
        r.sample.position = Vec3(outF[0][x], outF[1][x], outF[2][x]);
        r.sample.normal = Vec3(outF[3][x], outF[4][x], outF[5][x]);
        r.sample.radiance = Vec3(outF[6][x], outF[7][x], outF[8][x]);
        r.sample.pdfArea = outF[9][x];
        r.weightSum = outF[10][x];
        r.targetPdf = outF[11][x];
      }
      if (mixed) {
        const ShadingPoint sp = ShadingPointAt(g, rowStart + x, view.eye, *view.materials);
        r = SampleCandidateSources(view, sampler, counts, params.brdfCutoff, sp, static_cast<uint32_t>(rowStart + x),
                                   runKernel ? &r : nullptr, rays.local());
      } else {
        FinalizeRis(r, static_cast<float>(params.candidates));
      }
      // An initial reservoir counts one frame of history (DESIGN §4), or its candidates (seed 003).
      r.confidence = confidence;
      if (params.visibility && r.HasSample()) {
        LightPoint y;
        LightPointAt(g.Position(rowStart + x), r.sample.lightId, r.sample.position, r.sample.normal, lights, nullptr, y);
        shadowRays.Add(g, rowStart + x, y.position, y.normal, y.errorScale);
        rayPixel.push_back(static_cast<uint32_t>(x));
      }
    }
    if (shadowRays.Size() > 0) {
      const std::vector<uint8_t>& occluded = shadowRays.Trace(*view.scene, SceneFrame::kCurrent);
      rays.local() += occluded.size();
      for (size_t k = 0; k < occluded.size(); ++k)
        if (occluded[k]) row[rayPixel[k]].W = 0.0f, row[rayPixel[k]].visibility = 0.0f;
    }
    for (size_t x = 0; x < rw; ++x) {
      if (!activeRow[x]) continue;
      Reservoir& r = row[x];
      if (!FiniteReservoir(r)) {
        guarded.local() += 1;
        r = Reservoir{};
        r.confidence = confidence;
      }
      out[rowStart + x] = Store(r);
    }
  });
  stats.name = "initial";
  stats.ms = MsSince(t0);
  stats.rays = rays.combine(std::plus<uint64_t>());
  stats.risPixels = risPixels.combine(std::plus<uint64_t>());
  stats.guarded = guarded.combine(std::plus<uint64_t>());
}

}  // namespace restir
