#include "sim/estimator/pipeline.h"

#include <stdexcept>

#include "core/gris.h"
#include "sim/scene/shading_point.h"

namespace restir {

Pipeline::Pipeline(const PipelineSettings& settings) : settings_(settings) {
  if (const SettingBound* b = BrokenBound(settings, BoundsScope::kPipeline))
    throw std::invalid_argument("Pipeline: " + b->key + " outside its validated bounds (" + b->reason + ")");
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
  v.sky = in.sky;
  v.previousSky = in.previousSky;
  v.camera = &in.state->camera;
  v.materials = &materials;
  v.seed = in.seed;
  v.frame = in.frame;
  return v;
}

const InitialSamplingShare::Entry* InitialSamplingShare::Find(const InitialSamplingParams& params,
                                                             uint32_t seed) const {
  for (const Entry& e : entries_)
    if (e.seed == seed && e.params == params) return &e;
  return nullptr;
}

InitialSamplingShare::Entry& InitialSamplingShare::Add(const InitialSamplingParams& params, uint32_t seed) {
  Entry& e = entries_.emplace_back();
  e.params = params;
  e.seed = seed;
  return e;
}

namespace {

// The frame's counters, in pixel order (deterministic).
void Tally(const GBuffer& g, const ReservoirBuffer& reservoirs, bool measureReservoirs, FrameResult& r) {
  size_t surfaces = 0, accepted = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    ++surfaces;
    accepted += r.temporalAccepted[i];
  }
  for (const PassStats& s : r.passes) r.guardedEvents += s.guarded, r.crossObjectReuse += s.crossObjectReuse;
  r.temporalAcceptance = surfaces ? double(accepted) / double(surfaces) : 0.0;
  r.diagnostics.contributingShaded = surfaces ? double(r.passes.back().contributing) / double(surfaces) : 0.0;
  if (measureReservoirs) MeasureOutputReservoirs(g, reservoirs, r.diagnostics);
}


// The share of pixels whose reservoir contributes, in the whole frame and in the diagnostics region; zero when the
// run does not measure reservoirs.
Contributing MeasureContributing(const FrameInputs& in, const ReservoirBuffer& reservoirs) {
  return in.measureReservoirs ? ContributingFraction(*in.gbuffer, reservoirs, in.diagnosticsRegion) : Contributing{};
}

}  // namespace

BsdfSoa FrameMaterials(const FrameInputs& in) {
  return in.sceneMaterials ? FrameBsdfTable(*in.materials, *in.sceneMaterials, *in.gbuffer,
                                            in.previousState ? in.previousGbuffer : nullptr)
                           : MakeBsdfSoa(*in.materials);
}

PipelineSettings PassSettings(const PipelineSettings& settings) {
  PipelineSettings s = settings;
  s.temporal.visibility = settings.shade.visibility;
  s.spatial.visibility = settings.shade.visibility;
  s.spatial.disocclusionBoost = settings.temporal.enabled;
  return s;
}

// Initial sampling, or its reservoirs and statistics taken from a preset of this frame with the same parameters
// and seed (FrameInputs::initialShare): the same bits, computed once.
Contributing Pipeline::InitialPass(const FrameInputs& in, const FrameView& view, FrameResult& r) {
  const InitialSamplingShare::Entry* shared =
      in.initialShare ? in.initialShare->Find(settings_.initial, in.seed) : nullptr;
  if (shared) {
    reservoirs_ = shared->reservoirs;
    r.passes.push_back(shared->stats);
    const bool sameMeasure = in.measureReservoirs && shared->contributing && shared->region == in.diagnosticsRegion;
    return sameMeasure ? *shared->contributing : MeasureContributing(in, reservoirs_);
  }
  InitialSampling(settings_.initial, view, reservoirs_, r.passes.emplace_back());
  const Contributing initial = MeasureContributing(in, reservoirs_);
  if (in.initialShare) {
    InitialSamplingShare::Entry& e = in.initialShare->Add(settings_.initial, in.seed);
    e.reservoirs = reservoirs_;
    e.stats = r.passes.back();
    if (in.measureReservoirs) e.contributing = initial, e.region = in.diagnosticsRegion;
  }
  return initial;
}

PipelineSettings IndirectPassSettings(const PipelineSettings& settings) {
  PipelineSettings s = settings;
  s.temporal = settings.indirect.temporal;
  s.spatial = settings.indirect.spatial;
  s.shade = settings.indirect.shade;
  return PassSettings(s);
}

// The spatial pass the MIS family selects: stochastic pairwise over cells (seed 004), else k neighbours.
void Pipeline::SpatialPass(const SpatialParams& spatial, const FrameView& view, ReservoirBuffer& current,
                           ReservoirBuffer& scratch, CellGrid& cells, FrameResult& r) {
  if (spatial.mis == MisFamily::kStochasticPairwise)
    StochasticPairwiseReuse(spatial, view, r.temporalAccepted, current, scratch, cells, r.passes.emplace_back());
  else
    SpatialReuse(spatial, view, r.temporalAccepted, current, scratch, r.passes.emplace_back());
}

// DESIGN §2, from InitialSampling to Shade. A pass the preset lacks leaves the contributing share as it was.
FrameResult Pipeline::RenderFrame(const FrameInputs& in) {
  const BsdfSoa materials = FrameMaterials(in);
  const FrameView view = MakeFrameView(in, materials);
  const PipelineSettings& s = passes_;
  FrameResult r;
  r.temporalAccepted.assign(in.gbuffer->Size(), 0);
  const Contributing initial = InitialPass(in, view, r);
  if (s.temporal.enabled)
    TemporalReuse(s.temporal, view, previousReservoirs_, reservoirs_, r.temporalAccepted,
                  r.passes.emplace_back());
  const Contributing temporal = s.temporal.enabled ? MeasureContributing(in, reservoirs_) : initial;
  if (s.spatial.enabled) SpatialPass(s.spatial, view, reservoirs_, previousReservoirs_, cells_, r);
  const Contributing spatial = s.spatial.enabled ? MeasureContributing(in, reservoirs_) : temporal;
  RecordContributing(initial, temporal, spatial, r.diagnostics);
  Shade(s.shade, view, reservoirs_, r.image, r.passes.emplace_back());
  Tally(*in.gbuffer, reservoirs_, in.measureReservoirs, r);
  std::swap(previousReservoirs_, reservoirs_);  // this frame's output is the next frame's temporal input
  return r;
}

}  // namespace restir
