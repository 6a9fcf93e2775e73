// ReSTIR GI's frame (Pipeline::RenderIndirect; Ouyang et al. 2021; DESIGN §4 "Path reuse"): the secondary
// vertices of the frame's paths become points the direct light's passes resample as they resample points on
// lights.
#include <tbb/combinable.h>

#include <limits>

#include "core/shading.h"
#include "sim/estimator/passes/batching.h"
#include "sim/estimator/pipeline.h"
#include "sim/scene/shading_point.h"
#include "sim/util/clock.h"

namespace restir {

namespace {

// A secondary vertex as a point its reservoirs' passes evaluate like a point on a light (LightPointAt): its
// position and geometric normal are in the reservoir, its radiance, error scale and shading normal (the side it
// sends light to) here. The triangle's corner, edges and area stay 0 (IsVertexPoint): nothing samples it.
LightTriangle VertexPoint(const Vec3& shadingNormal, const Vec3& radiance, float errorScale) {
  LightTriangle t;
  t.p0 = t.e1 = t.e2 = Vec3(0.0f);
  t.area = 0.0f;
  t.normal = shadingNormal;
  t.radiance = radiance;
  t.errorScale = errorScale;
  return t;
}

// The initial reservoirs: pixel i's own vertex x₂, one candidate drawn with density p_A(x₂), so W = 1 / p_A
// (seed 003 §1 with M = 1: w = p̂ / p_A, W = w / p̂). Confidence 1 at every surface pixel, whether its path found
// a vertex or not: the pixel's sampler ran and could have produced any vertex its target reaches, so it keeps its
// share of the MIS weights (with confidence 0, an empty pixel's share would go to its neighbours' samples and
// their sum would overshoot: measured, +66% on the sunlit-wall floor). x₂ was found by a ray from x₁, so its
// carried visibility is 1. A vertex whose target is 0 at its own pixel (its light is 0, or x₁'s shading normal
// turns from it) gives an empty reservoir: its path contributes 0 there.
void InitialVertices(const FrameView& view, const std::vector<SecondaryVertex>& vertices, ReservoirBuffer& out,
                     PassStats& stats) {
  const GBuffer& g = *view.gbuffer;
  out.assign(g.Size(), StoredReservoir{});
  tbb::combinable<uint64_t> targets([] { return uint64_t{0}; });
  ForEachRow(g.height, [&](int y) {
    uint64_t& count = targets.local();
    for (int x = 0; x < g.width; ++x) {
      const size_t i = static_cast<size_t>(y) * g.width + x;
      const SecondaryVertex& v = vertices[i];
      if (!g.IsSurface(i)) continue;
      out[i].confidence = 1.0f;
      if (!(v.pdfArea > 0.0f)) continue;
      const ShadingPoint sp = ShadingPointAt(g, i, view.eye, *view.materials);
      if (!InFrontOfVertex(v.shadingNormal, v.position, sp.position)) continue;  // x₂ sends x₁ nothing
      LightSample sample;
      sample.lightId = static_cast<uint32_t>(i);
      sample.position = v.position;
      sample.normal = v.normal;
      sample.radiance = v.radiance;
      sample.pdfArea = v.pdfArea;
      const float target = TargetFunction(UnshadowedContribution(sp, sample));
      ++count;
      if (!(target > 0.0f) || !std::isfinite(target)) continue;
      StoredReservoir& r = out[i];
      r.lightId = sample.lightId;
      r.position = v.position;
      r.normal = v.normal;
      r.targetPdf = target;
      r.W = 1.0f / v.pdfArea;
      r.confidence = 1.0f;
      r.visibility = 1.0f;
      if (!std::isfinite(r.W)) r.W = 0.0f, r.targetPdf = 0.0f;
    }
  });
  stats.targets += targets.combine(std::plus<uint64_t>());
}

// What the next frame keeps: the vertices the output reservoirs hold, each once, in pixel order (deterministic),
// and the reservoirs pointed at them.
std::vector<HeldVertex> KeepHeldVertices(const std::vector<LightTriangle>& points, ReservoirBuffer& reservoirs) {
  std::vector<HeldVertex> kept;
  std::vector<uint32_t> index(points.size(), std::numeric_limits<uint32_t>::max());
  for (StoredReservoir& r : reservoirs) {
    if (!r.HasSample()) {
      r.lightId = 0;  // an empty reservoir keeps its confidence, and no vertex
      continue;
    }
    if (r.lightId >= points.size()) {  // not reachable: every pass keeps a sample's index
      r = StoredReservoir{};
      continue;
    }
    uint32_t& k = index[r.lightId];
    if (k == std::numeric_limits<uint32_t>::max()) {
      k = static_cast<uint32_t>(kept.size());
      const LightTriangle& t = points[r.lightId];
      kept.push_back(HeldVertex{t.normal, t.radiance, t.errorScale});
    }
    r.lightId = k;
  }
  return kept;
}

// The passes' statistics folded into one, "indirect" (metrics.csv has one column set per pass name).
void Accumulate(const PassStats& s, PassStats& total) {
  total.ms += s.ms;
  total.rays += s.rays;
  total.risPixels += s.risPixels;
  total.targets += s.targets;
  total.combinations += s.combinations;
  total.guarded += s.guarded;
  total.crossObjectReuse += s.crossObjectReuse;
  total.reservoirReads += s.reservoirReads;
  total.failed += s.failed;
  total.visited += s.visited;
  total.contributing = s.contributing;
}

}  // namespace

FrameResult Pipeline::RenderIndirect(const FrameInputs& in, const std::vector<SecondaryVertex>& vertices) {
  const auto t0 = Clock::now();
  const BsdfSoa materials = FrameMaterials(in);
  const GBuffer& g = *in.gbuffer;
  const size_t pixels = g.Size();
  // The points of this frame: pixel i's vertex at index i, then the vertices last frame's reservoirs hold, whose
  // indices move up by the pixel count.
  const bool history = in.previousState != nullptr && in.previousGbuffer != nullptr && gi_.previous.size() == pixels;
  std::vector<LightTriangle> points;
  points.reserve(pixels + (history ? gi_.vertices.size() : 0));  // one buffer, no copy: the memory estimate counts one
  for (size_t i = 0; i < pixels; ++i)
    points.push_back(VertexPoint(vertices[i].shadingNormal, vertices[i].radiance, vertices[i].errorScale));
  if (history) {
    for (const HeldVertex& v : gi_.vertices) points.push_back(VertexPoint(v.shadingNormal, v.radiance, v.errorScale));
    for (StoredReservoir& r : gi_.previous)
      if (r.HasSample()) r.lightId += static_cast<uint32_t>(pixels);
  } else {
    gi_.previous.assign(pixels, StoredReservoir{});
  }

  FrameView view = MakeFrameView(in, materials);
  view.lightList = &points;
  view.previousLights = history ? &points : nullptr;  // a vertex sends the same L_o in both frames' domains
  view.sky = Sky{};
  view.previousSky = Sky{};
  view.primaryEmission = false;
  // The passes key their random numbers by (seed, frame, pixel, pass): the GI passes get a seed of their own, an
  // odd-multiplier bijection of the run's, so that they never draw the direct light's numbers (DESIGN §3: one
  // stream per pass).
  view.seed = in.seed * 0x9E3779B1u + 0x47493131u;

  const PipelineSettings& s = giPasses_;
  FrameResult r;
  r.temporalAccepted.assign(pixels, 0);
  // The GI reservoirs' contributing shares after each pass, as RenderFrame measures the direct light's.
  const auto contributing = [&] {
    if (!in.measureReservoirs) return Contributing{};
    const auto m0 = Clock::now();
    const Contributing c = ContributingFraction(g, gi_.current, in.diagnosticsRegion);
    r.msDiagnostics += MsSince(m0);
    return c;
  };
  PassStats initial;
  InitialVertices(view, vertices, gi_.current, initial);
  initial.ms = MsSince(t0);
  r.passes.push_back(initial);
  const Contributing initialShare = contributing();
  if (s.temporal.enabled)
    TemporalReuse(s.temporal, view, gi_.previous, gi_.current, r.temporalAccepted, r.passes.emplace_back());
  const Contributing temporalShare = s.temporal.enabled ? contributing() : initialShare;
  if (s.spatial.enabled) {
    // The cells are the pass's scratch, not state: no later frame reads them (the direct light's are kept for its
    // tests), so a GI reservoir's memory between frames is its two reservoirs and its held vertex.
    CellGrid cells;
    SpatialPass(s.spatial, view, gi_.current, gi_.previous, cells, r);
    r.indirectSpatial = r.passes.back();
  }
  const Contributing spatialShare = s.spatial.enabled ? contributing() : temporalShare;
  RecordContributing(initialShare, temporalShare, spatialShare, r.diagnostics);
  Shade(s.shade, view, gi_.current, r.image, r.passes.emplace_back());
  if (in.measureReservoirs) {
    const auto m0 = Clock::now();
    MeasureOutputReservoirs(g, gi_.current, r.diagnostics);
    r.msDiagnostics += MsSince(m0);
  }
  gi_.vertices = KeepHeldVertices(points, gi_.current);
  std::swap(gi_.previous, gi_.current);
  PassStats total;
  total.name = "indirect";
  for (const PassStats& p : r.passes) Accumulate(p, total);
  r.passes.assign(1, total);
  r.guardedEvents = total.guarded;
  r.crossObjectReuse = total.crossObjectReuse;
  size_t surfaces = 0, accepted = 0;
  for (size_t i = 0; i < pixels; ++i) surfaces += g.IsSurface(i), accepted += g.IsSurface(i) && r.temporalAccepted[i];
  r.temporalAcceptance = surfaces ? double(accepted) / double(surfaces) : 0.0;
  r.diagnostics.contributingShaded = surfaces ? double(total.contributing) / double(surfaces) : 0.0;
  return r;
}

}  // namespace restir
