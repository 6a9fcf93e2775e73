// A frame's estimator (DESIGN §2): initial sampling, temporal reuse, spatial reuse, shading, each a pass of
// sim/estimator/passes/ taking its parameter struct. A preset is a named bundle of the structs
// (sim/estimator/presets.cpp).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/bsdf.h"
#include "core/light_sampler.h"
#include "core/reconnection_shift.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/util/image.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/passes/initial_sampling.h"
#include "sim/estimator/passes/shade.h"
#include "sim/estimator/passes/spatial_reuse.h"
#include "sim/estimator/passes/stochastic_pairwise_reuse.h"
#include "sim/estimator/passes/temporal_reuse.h"
#include "sim/estimator/reservoir_diagnostics.h"
#include "sim/estimator/settings.h"  // PipelineSettings
#include "sim/scene/sequence.h"

namespace restir {

class InitialSamplingShare;

// The settings as the passes read them: `settings` with the facts one pass decides for another copied into the
// other's struct (TemporalParams::visibility and SpatialParams::visibility from shade.visibility,
// SpatialParams::disocclusionBoost from temporal.enabled), so each pass takes only its own struct.
PipelineSettings PassSettings(const PipelineSettings& settings);
// The settings ReSTIR GI's passes read: indirect.temporal, spatial and shade in the places of the direct light's,
// through PassSettings.
PipelineSettings IndirectPassSettings(const PipelineSettings& settings);

// Everything a frame reads about the current and previous frame. Owned by the frame loop; passes never write it.
struct FrameInputs {
  const FrameState* state = nullptr;
  const EmbreeScene* scene = nullptr;              // current frame; the previous one via SceneFrame::kPrevious
  const GBuffer* gbuffer = nullptr;
  const LightSampler* lights = nullptr;            // built on the scene's current light triangles
  const std::vector<Bsdf>* materials = nullptr;    // one per Sequence::materials
  // The sequence's materials, for the BSDFs of textured receivers (FrameBsdfTable); null: no textures.
  const std::vector<Material>* sceneMaterials = nullptr;
  const FrameState* previousState = nullptr;       // null on the first frame of a run
  const GBuffer* previousGbuffer = nullptr;        // null on the first frame of a run
  const std::vector<LightTriangle>* previousLights = nullptr;  // the previous frame's light list
  Sky sky;                                         // this frame's sky (sim/scene/sky_frame.h MakeSky); empty: none
  Sky previousSky;                                 // the previous frame's
  uint32_t seed = 0;
  uint32_t frame = 0;
  // Fill FrameResult::diagnostics beyond contributingShaded: a pass over the reservoirs after each pass and a
  // 5×5 window per pixel, about 6 ms a 640×360 frame (12% of ris's), so only the runner's reported frame asks,
  // not ensemble members or benchmarks. Never changes the image.
  bool measureReservoirs = false;
  // Pixels whose contributing fractions the diagnostics also report apart (the runner passes its 4-frame
  // disocclusion window); null: none.
  const std::vector<uint8_t>* diagnosticsRegion = nullptr;
  // Initial sampling's outputs of this frame already computed for other presets, reused where the parameters and
  // seed are equal; null: always compute. Never changes a result (InitialSamplingShare below).
  InitialSamplingShare* initialShare = nullptr;
};

struct FrameResult {
  ImageRgb image;
  std::vector<PassStats> passes;
  uint64_t guardedEvents = 0;      // non-finite values caught and reset (DESIGN §10)
  double temporalAcceptance = 0;   // fraction of surface pixels whose previous reservoir entered the combination
  // The reservoirs after each pass and at the end (issue 20): contributingShaded always, the rest when
  // FrameInputs::measureReservoirs.
  ReservoirDiagnostics diagnostics;
  uint64_t crossObjectReuse = 0;   // temporal inputs whose previous surface had another object id (must be 0)
  std::vector<uint8_t> temporalAccepted;  // per pixel: the previous reservoir was used
  // ReSTIR GI's reservoirs (RenderIndirect: the same measures as `diagnostics`, over the GI reservoirs) and its
  // spatial pass alone (the "indirect" pass folds every GI pass into one); set by FrameLoop::RenderPreset for a
  // preset that reuses paths, null otherwise.
  std::optional<ReservoirDiagnostics> indirectDiagnostics;
  std::optional<PassStats> indirectSpatial;
  // Wall time RenderIndirect spent measuring its reservoirs (FrameInputs::measureReservoirs): not the method's, so
  // FrameLoop::RenderPreset leaves it out of the "indirect" pass's time, as the direct light's passes leave out theirs.
  double msDiagnostics = 0.0;
};

// One frame's initial-sampling outputs, shared by the presets of a run. InitialSampling reads its parameters and the
// frame (FrameView: G-buffer, scene, lights, seed, frame number) and nothing of a preset's history, so presets whose
// InitialSamplingParams and seed are equal draw the same reservoirs, bit for bit: the first computes them, the
// others copy them with the pass's statistics (its time and rays, what the pass costs each preset that runs it).
// Six of `--preset all`'s nine presets have the same initial pass. Holds one frame: Clear() when the frame changes,
// and keep the FrameInputs otherwise equal (the runner's presets share one FrameLoop::Inputs).
class InitialSamplingShare {
 public:
  struct Entry {
    InitialSamplingParams params;  // the pass's parameters
    uint32_t seed = 0;             // FrameInputs::seed (ensemble members differ)
    ReservoirBuffer reservoirs;    // the pass's output
    PassStats stats;               // the pass's statistics when it ran
    // The contributing fractions after the pass, when measured, and the region they were measured over.
    std::optional<Contributing> contributing;
    const std::vector<uint8_t>* region = nullptr;
  };
  const Entry* Find(const InitialSamplingParams& params, uint32_t seed) const;
  Entry& Add(const InitialSamplingParams& params, uint32_t seed);
  void Clear() { entries_.clear(); }
  size_t Entries() const { return entries_.size(); }

 private:
  std::vector<Entry> entries_;  // a handful: one per distinct initial configuration and seed
};

// A secondary vertex that last frame's GI reservoirs hold, as the next frame needs it beyond what each reservoir
// stores of it (its position and geometric normal): 28 bytes, where a frame's points are whole light triangles
// (68). The frame rebuilds its point from this (nothing of the point is lost: LightPointAt reads no more).
struct HeldVertex {
  Vec3 shadingNormal{0.0f};  // the side x₂ sends L_o to (core/reconnection_shift.h InFrontOfVertex)
  Vec3 radiance{0.0f};       // L_o(x₂), what the rest of the path sends back
  float errorScale = 0.0f;   // x₂'s, for spawning the reconnection ray's far end (core/shadow_ray.h)
};
static_assert(sizeof(HeldVertex) == 28);

// Per-preset estimator state across frames: the reservoirs of this frame and of the last one, ping-ponged.
class Pipeline {
 public:
  // Throws std::invalid_argument for settings outside the bounds sim/estimator/settings.cpp validates (per-batch
  // scratch is sized by them).
  explicit Pipeline(const PipelineSettings& settings);
  FrameResult RenderFrame(const FrameInputs& in);
  // ReSTIR GI's frame (Ouyang et al. 2021; DESIGN §4 "Path reuse"), where Settings().indirect.reuse: each pixel's
  // path vertex x₂ (`vertices`, per pixel, from the frame loop's paths: sim/reference/reference_paths.h
  // SecondaryVertices) is its initial reservoir, W = 1 / p_A(x₂); then the direct light's own temporal reuse,
  // spatial reuse and shading passes with indirect.temporal/spatial/shade, on a view whose "lights" are the
  // secondary vertices as points sending L_o(x₂): in area measure at x₂ the reconnection shift is the identity,
  // so every MIS family, bias correction and SIMD kernel of the direct light applies as it is, Jacobian 1. The
  // image is the GI estimate alone (no emission); its passes' statistics are in `passes`.
  FrameResult RenderIndirect(const FrameInputs& in, const std::vector<SecondaryVertex>& vertices);
  const PipelineSettings& Settings() const { return settings_; }
  // The state carried to the next frame (the last output reservoirs), for checkpoints (--resume).
  const ReservoirBuffer& History() const { return previousReservoirs_; }
  ReservoirBuffer& History() { return previousReservoirs_; }
  // Reservoir buffers the pipeline holds (per pixel): this frame's and last frame's. A spatial iteration writes
  // into last frame's buffer once temporal reuse has read it, so no third buffer exists.
  static constexpr int kReservoirBuffers = 2;
  // The cells of the last stochastic pairwise iteration (tests, memory accounting).
  const CellGrid& Cells() const { return cells_; }
  // ReSTIR GI's state carried to the next frame: the output reservoirs and the vertices they hold (their lightIds
  // index it).
  const ReservoirBuffer& IndirectHistory() const { return gi_.previous; }
  ReservoirBuffer& IndirectHistory() { return gi_.previous; }
  const std::vector<HeldVertex>& IndirectVertices() const { return gi_.vertices; }
  std::vector<HeldVertex>& IndirectVertices() { return gi_.vertices; }

 private:
  // ReSTIR GI's reservoirs with their history (the direct light's are the members below, as they were).
  struct ReservoirState {
    ReservoirBuffer current;   // this frame's reservoirs
    ReservoirBuffer previous;  // last frame's output (temporal input), then spatial scratch
    std::vector<HeldVertex> vertices;  // the secondary vertices `previous` holds (RenderIndirect)
  };

  Contributing InitialPass(const FrameInputs& in, const FrameView& view, FrameResult& r);
  static void SpatialPass(const SpatialParams& spatial, const FrameView& view, ReservoirBuffer& current,
                          ReservoirBuffer& scratch, CellGrid& cells, FrameResult& r);

  PipelineSettings settings_;
  // What the passes read: settings_ with the cross-pass facts filled in once, when the pipeline is built (why: a
  // pass's inputs all sit in its struct, and no frame can hand a pass a fact that disagrees with another pass).
  PipelineSettings passes_ = PassSettings(settings_);
  ReservoirBuffer reservoirs_;          // this frame's reservoirs
  ReservoirBuffer previousReservoirs_;  // last frame's output (temporal input), then spatial scratch
  CellGrid cells_;
  // ReSTIR GI's passes (settings_.indirect's temporal, spatial and shade as PassSettings fills them) and state.
  PipelineSettings giPasses_ = IndirectPassSettings(settings_);
  ReservoirState gi_;
};

// The frame's materials as the kernels read them: one BSDF per material, and one per textured receiver when the
// scene has textures (GBuffer::bsdfId indexes it).
BsdfSoa FrameMaterials(const FrameInputs& in);

// The passes' view of a frame's inputs, with the materials as the kernels read them.
FrameView MakeFrameView(const FrameInputs& in, const BsdfSoa& materials);

}  // namespace restir
