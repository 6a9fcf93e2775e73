#include "sim/pipeline.h"

#include <stdexcept>

#include "core/gris.h"

namespace restir {

Pipeline::Pipeline(const PipelineSettings& settings) : settings_(settings) {
  const StochasticPairwiseParams& sp = settings.spatial.stochastic;
  if (sp.cellSearchIterations < 1 || sp.cellSearchIterations > kMaxCellSearchIterations || sp.cellTile < 1 ||
      sp.cellTile > kMaxCellTile || sp.draws < 1 || sp.draws > kMaxGrisInputs - 1 || sp.canonicalDraws < 1 ||
      sp.canonicalDraws > kMaxGrisInputs - 1)
    throw std::invalid_argument("Pipeline: spatial settings outside their validated bounds");
}

FrameView MakeFrameView(const FrameInputs& in, const BsdfSoa& materials) {
  FrameView v;
  v.gbuffer = in.gbuffer;
  v.previousGbuffer = in.previousState ? in.previousGbuffer : nullptr;
  v.scene = in.scene;
  v.lights = in.lights;
  v.previousLights = in.previousLights;
  v.eye = in.state->camera.position;
  if (in.previousState) v.previousEye = in.previousState->camera.position;
  v.materials = &materials;
  v.seed = in.seed;
  v.frame = in.frame;
  return v;
}

FrameResult Pipeline::RenderFrame(const FrameInputs& in) {
  const BsdfSoa materials = MakeBsdfSoa(*in.materials);
  const FrameView view = MakeFrameView(in, materials);
  const VisibilityReuse visibility = settings_.shade.visibility;
  FrameResult result;
  auto run = [&](auto&& pass) { pass(result.passes.emplace_back()); };

  run([&](PassStats& s) { InitialSampling(settings_.initial, view, reservoirs_, s); });
  if (settings_.temporal.enabled)
    run([&](PassStats& s) {
      TemporalReuse(settings_.temporal, visibility, view, previousReservoirs_, reservoirs_, result.temporalAccepted, s);
    });
  else
    result.temporalAccepted.assign(in.gbuffer->Size(), 0);
  if (settings_.spatial.enabled && settings_.spatial.mis == MisFamily::kStochasticPairwise)
    run([&](PassStats& s) {
      StochasticPairwiseReuse(settings_.spatial, visibility, view, reservoirs_, previousReservoirs_, cells_, s);
    });
  else if (settings_.spatial.enabled)
    run([&](PassStats& s) {
      SpatialReuse(settings_.spatial, visibility, view, settings_.temporal.enabled ? &result.temporalAccepted : nullptr,
                   reservoirs_, previousReservoirs_, s);
    });
  run([&](PassStats& s) { Shade(settings_.shade, view, reservoirs_, result.image, s); });

  // Counters, in pixel order (deterministic).
  const GBuffer& g = *in.gbuffer;
  size_t surfaces = 0, accepted = 0;
  double confidence = 0.0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    ++surfaces;
    accepted += result.temporalAccepted[i];
    confidence += reservoirs_[i].confidence;
  }
  for (const PassStats& s : result.passes) result.guardedEvents += s.guarded, result.crossObjectReuse += s.crossObjectReuse;
  result.temporalAcceptance = surfaces ? double(accepted) / double(surfaces) : 0.0;
  result.meanConfidence = surfaces ? confidence / double(surfaces) : 0.0;
  std::swap(previousReservoirs_, reservoirs_);
  return result;
}

}  // namespace restir
