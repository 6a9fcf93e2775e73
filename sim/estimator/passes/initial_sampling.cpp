#include "sim/estimator/passes/initial_sampling.h"

#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <optional>
#include <vector>

#include "core/ris_kernel.h"
#include "core/rng.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/batching.h"
#include "sim/estimator/passes/candidate_sources.h"
#include "sim/scene/shading_point.h"

namespace restir {

namespace {

// The effective counts of a frame: a source with nothing to sample draws nothing (core/candidates.h).
CandidateCounts EffectiveCounts(const InitialSamplingParams& params, const FrameView& view) {
  CandidateCounts m;
  m.local = view.lights->Empty() ? 0 : params.candidates;
  m.sun = view.sky.hasSun ? params.sunCandidates : 0;
  m.environment = view.sky.HasEnvironment() ? params.environmentCandidates : 0;
  m.brdf = view.HasLight() ? params.brdfCandidates : 0;
  return m;
}

// What every row of the pass reads, decided once per frame.
struct InitialFrame {
  const InitialSamplingParams& params;  // the pass's parameters
  const FrameView& view;                // the frame
  const LightSampler& sampler;  // the lights the kernel and the other sources select from
  RisParams risParams;          // the RIS kernel's RNG key and candidate count
  CandidateCounts counts;       // the frame's effective counts per source
  bool mixed;                   // sources beyond local lights: the reservoir combines them (candidate_sources.cpp)
  bool runKernel;               // local lights to stream: the kernel runs in every configuration
  float confidence;             // an initial reservoir's confidence
};

// A row's inputs of the RIS kernel that the G-buffer does not hold as arrays (wo and the surface mask), and the
// kernel's outputs, one entry per pixel.
struct RisRow {
  explicit RisRow(size_t width) : active(width, 0), lightId(width) {
    for (auto& v : wo) v.resize(width);
    for (auto& v : out) v.resize(width);
  }
  std::vector<float> wo[3];      // unit direction towards the viewer (RisPixels::wo)
  std::vector<uint8_t> active;   // a surface in a frame with something to sample
  std::vector<int32_t> lightId;  // RisOutput::lightId
  std::vector<float> out[12];    // RisOutput's position, normal, radiance (3 each), pdfArea, weightSum, targetPdf

  // The row's wo and surface mask.
  void Gather(const FrameView& view, size_t rowStart) {
    const GBuffer& g = *view.gbuffer;
    for (size_t x = 0; x < active.size(); ++x) {
      const size_t i = rowStart + x;
      if (!g.IsSurface(i) || !view.HasLight()) continue;
      active[x] = 1;
      const Vec3 w = ViewDirection(view.eye, g.Position(i));
      for (int c = 0; c < 3; ++c) wo[c][x] = w[c];
    }
  }
  // The kernel's inputs: the G-buffer's arrays from rowStart, and the row's own.
  RisPixels Pixels(const GBuffer& g, size_t rowStart) const {
    RisPixels px;
    px.position[0] = g.posX.data() + rowStart, px.position[1] = g.posY.data() + rowStart;
    px.position[2] = g.posZ.data() + rowStart;
    px.geometricNormal[0] = g.ngX.data() + rowStart, px.geometricNormal[1] = g.ngY.data() + rowStart;
    px.geometricNormal[2] = g.ngZ.data() + rowStart;
    px.shadingNormal[0] = g.nsX.data() + rowStart, px.shadingNormal[1] = g.nsY.data() + rowStart;
    px.shadingNormal[2] = g.nsZ.data() + rowStart;
    for (int c = 0; c < 3; ++c) px.wo[c] = wo[c].data();
    px.materialId = g.bsdfId.data() + rowStart;  // the BSDF table index (textured receivers have their own)
    px.active = active.data();
    px.pixelBase = static_cast<uint32_t>(rowStart);
    px.count = active.size();
    return px;
  }
  RisOutput Output() {
    RisOutput ro;
    ro.lightId = lightId.data();
    for (int c = 0; c < 3; ++c) {
      ro.position[c] = out[c].data();
      ro.normal[c] = out[3 + c].data();
      ro.radiance[c] = out[6 + c].data();
    }
    ro.pdfArea = out[9].data();
    ro.weightSum = out[10].data();
    ro.targetPdf = out[11].data();
    return ro;
  }
  // Pixel x's streamed reservoir, before FinalizeRis, into r's sample, weight sum and target.
  void Read(size_t x, Reservoir& r) const {
    r.sample.lightId = static_cast<uint32_t>(lightId[x]);
    r.sample.position = Vec3(out[0][x], out[1][x], out[2][x]);
    r.sample.normal = Vec3(out[3][x], out[4][x], out[5][x]);
    r.sample.radiance = Vec3(out[6][x], out[7][x], out[8][x]);
    r.sample.pdfArea = out[9][x];
    r.weightSum = out[10][x];
    r.targetPdf = out[11][x];
  }
};

// Active pixel x's reservoir before visibility: the kernel's, finalised over the local candidates, or the
// combination of every source with it (SampleCandidateSources); it counts one frame of history (DESIGN §4), or its
// candidates (seed 003).
void SelectSample(const InitialFrame& f, const RisRow& ris, size_t rowStart, size_t x, Reservoir& r,
                  uint64_t& rays) {
  if (f.runKernel) ris.Read(x, r);
  if (f.mixed) {
    const ShadingPoint sp = ShadingPointAt(*f.view.gbuffer, rowStart + x, f.view.eye, *f.view.materials);
    r = SampleCandidateSources(f.view, f.sampler, f.counts, f.params.brdfCutoff, sp,
                               static_cast<uint32_t>(rowStart + x), f.runKernel ? &r : nullptr, rays);
  } else {
    FinalizeRis(r, static_cast<float>(f.params.candidates));
  }
  r.confidence = f.confidence;
}

// One row: the RIS kernel over its pixels, each pixel's reservoir, the visibility rays of the selected samples
// (with params.visibility) traced as one batch, then the reservoirs stored, non-finite ones reset.
void SampleRow(const InitialFrame& f, int y, ShadowRayBatch& shadowRays, ReservoirBuffer& out, uint64_t& rays,
               uint64_t& risPixels, uint64_t& guarded) {
  const GBuffer& g = *f.view.gbuffer;
  const size_t rowStart = static_cast<size_t>(y) * g.width;
  const size_t rw = static_cast<size_t>(g.width);
  RisRow ris(rw);
  ris.Gather(f.view, rowStart);
  if (f.runKernel) RisInitialSampling(ris.Pixels(g, rowStart), f.sampler.Soa(), *f.view.materials, f.risParams,
                                      ris.Output());
  risPixels += static_cast<uint64_t>(std::count(ris.active.begin(), ris.active.end(), uint8_t{1}));
  std::vector<Reservoir> row(rw);
  shadowRays.Clear();
  std::vector<uint32_t> rayPixel;
  for (size_t x = 0; x < rw; ++x) {
    if (!ris.active[x]) continue;
    Reservoir& r = row[x];
    SelectSample(f, ris, rowStart, x, r, rays);
    if (f.params.visibility && r.HasSample()) {
      LightPoint lp;
      LightPointAt(g.Position(rowStart + x), r.sample.lightId, r.sample.position, r.sample.normal, f.view.Lights(),
                   nullptr, lp);
      shadowRays.Add(g, rowStart + x, lp.position, lp.normal, lp.errorScale);
      rayPixel.push_back(static_cast<uint32_t>(x));
    }
  }
  if (shadowRays.Size() > 0) {
    const std::vector<uint8_t>& occluded = shadowRays.Trace(*f.view.scene, SceneFrame::kCurrent);
    rays += occluded.size();
    for (size_t k = 0; k < occluded.size(); ++k)
      if (occluded[k]) row[rayPixel[k]].W = 0.0f, row[rayPixel[k]].visibility = 0.0f;
  }
  for (size_t x = 0; x < rw; ++x) {
    if (!ris.active[x]) continue;
    Reservoir& r = row[x];
    if (!FiniteReservoir(r)) {
      guarded += 1;
      r = Reservoir{};
      r.confidence = f.confidence;
    }
    out[rowStart + x] = Store(r);
  }
}

}  // namespace

void InitialSampling(const InitialSamplingParams& params, const FrameView& view, ReservoirBuffer& out,
                     PassStats& stats) {
  const auto t0 = Clock::now();
  const GBuffer& g = *view.gbuffer;
  out.assign(g.Size(), StoredReservoir{});
  // The frame's sampler selects lights by power; a uniform selection gets its own sampler (a pass over the lights).
  std::optional<LightSampler> uniformLights;
  if (params.lightSelection == LightSelection::kUniform) uniformLights.emplace(view.Lights(), LightSelection::kUniform);
  const LightSampler& sampler = uniformLights ? *uniformLights : *view.lights;
  const CandidateCounts counts = EffectiveCounts(params, view);
  const bool mixed = NeedsCandidateSources(counts);
  const float confidence = params.countCandidates ? static_cast<float>(mixed ? counts.Total() : params.candidates)
                                                  : 1.0f;
  // The kernel streams the local candidates in every configuration; with other sources its reservoir is one input
  // of their combination (sim/estimator/passes/candidate_sources.cpp).
  const InitialFrame f{params, view, sampler,
                       RisParams{view.seed, view.frame, static_cast<uint32_t>(RngPass::kInitial), params.candidates},
                       counts, mixed, /*runKernel=*/!sampler.Empty(), confidence};
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> risPixels([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<ShadowRayBatch> shadowRayBatches;
  // The RIS itself runs in the SIMD kernel a row at a time, on the target core/simd.h selects; every target gives
  // the same bits.
  ForEachRow(g.height, [&](int y) {
    SampleRow(f, y, shadowRayBatches.local(), out, rays.local(), risPixels.local(), guarded.local());
  });
  stats.name = "initial";
  stats.ms = MsSince(t0);
  stats.rays = rays.combine(std::plus<uint64_t>());
  stats.risPixels = risPixels.combine(std::plus<uint64_t>());
  stats.guarded = guarded.combine(std::plus<uint64_t>());
}

}  // namespace restir
