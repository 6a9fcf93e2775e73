// A frame's estimator passes (DESIGN §2): initial sampling, then shading. One parameter struct per pass; a
// preset is a named bundle of them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/bsdf.h"
#include "core/mis.h"
#include "core/light_sampler.h"
#include "core/reservoir.h"
#include "core/rng.h"
#include "core/shading.h"
#include "sim/embree_scene.h"
#include "sim/gbuffer.h"
#include "sim/image.h"
#include "sim/sequence.h"

namespace restir {

// How the ReSTIR passes evaluate the targets p̂_i that enter MIS weights (DESIGN §4 "Bias correction").
enum class BiasCorrection : uint8_t {
  kNone,       // uniform MIS weights whatever the family, unshadowed targets: fast, darkens
  kBasic,      // the family's weights with unshadowed targets of each input's own surface
  kRayTraced,  // targets include visibility traced from each input's surface, in that input's frame
};

// What visibility the shading pass uses (DESIGN §4 "Visibility").
enum class VisibilityReuse : uint8_t {
  kNone,      // trace a final shadow ray for the selected sample
  kSelected,  // shade with the carried V of the selected sample, no final ray (Wyman & Panteleev 2021)
  kWeighted,  // shade with V_X = Σ V_i w_i / Σ w_i, no final ray (seed 000 Eq. 4, Algorithm 1)
};

struct InitialSamplingParams {
  int candidates = 32;                                     // M light candidates per pixel (streaming RIS)
  LightSelection lightSelection = LightSelection::kPower;  // source distribution over lights
  bool visibility = false;                                 // trace the selected sample; occluded -> W = 0, V = 0
  bool countCandidates = false;  // confidence counts candidates (seed 003 representedM) instead of 1 per frame
};

struct TemporalParams {
  bool enabled = false;                          // reuse the previous frame's reservoir
  MisFamily mis = MisFamily::kUniform;           // MIS family of the two-input combination
  BiasCorrection bias = BiasCorrection::kBasic;  // how targets enter the MIS weights
  float maxHistory = 20.0f;                      // cap on the previous reservoir's confidence (seed 003 §4.3)
  bool sampleChecks = true;    // seed 003's sample tests: reject an empty previous reservoir or p̂_c(Y_prev) = 0
                               // (they depend on the sample, so unbiased presets turn them off)
  bool targetRatioClamp = false;  // also reject unless p̂_c(Y_prev) / p̂_prev(Y_prev) is in [0.1, 10]
  bool permutation = false;       // RTXDI permutation sampling: read a per-frame XOR-permuted previous pixel
};

struct SpatialParams {
  bool enabled = false;                          // reuse from screen-space neighbours
  MisFamily mis = MisFamily::kUniform;           // MIS family of the (1 + k)-input combination
  BiasCorrection bias = BiasCorrection::kBasic;  // how targets enter the MIS weights
  int neighbours = 5;                            // k neighbours per pixel
  int disocclusionNeighbours = 10;               // k where temporal reuse failed (disocclusion boost)
  float radius = 30.0f;                          // neighbour radius in pixels
  int iterations = 1;                            // passes, each reading a copy of the previous one's output
  float normalThreshold = 0.9f;                  // minimum dot of the neighbour's and the pixel's normals
  float depthThreshold = 0.1f;                   // maximum relative view-depth difference
  // Stochastic pairwise MIS over screen-space cells (mis = stochastic-pairwise; seed 004):
  int draws = 5;                   // N: non-canonical draws with replacement, P(i) ∝ c_i p̂_i(X_i) W_i (Eq. 17)
  int canonicalDraws = 5;          // N_c: uniform draws estimating the canonical weight (Eq. 18-19)
  int cellTile = 8;                // tile size in pixels; a cell is a tile's pixels with one object and normal bin
  int normalBins = 4;              // octahedral normal quantisation: bins x bins orientation classes
  int cellSearchIterations = 12;   // weighted-reservoir neighbour-cell search iterations (§5.1)
  float cellSearchRadius = 30.0f;  // first search radius in pixels
  float cellSearchGrowth = 1.25f;  // radius factor per iteration
  bool confidenceScaling = true;   // scale non-canonical confidences (and c̄) by N/M (§4.3)
};

struct ShadeParams {
  VisibilityReuse visibility = VisibilityReuse::kNone;  // final shadow ray, or the carried visibility
};

struct PipelineSettings {
  InitialSamplingParams initial;  // the initial-sampling pass
  TemporalParams temporal;        // the temporal-reuse pass
  SpatialParams spatial;          // the spatial-reuse pass
  ShadeParams shade;              // the shading pass
};

// Everything a pass reads about the current and previous frame. Owned by the runner; passes never write it.
struct FrameInputs {
  const Sequence* sequence = nullptr;
  const FrameState* state = nullptr;
  const EmbreeScene* scene = nullptr;              // current frame; the previous one via SceneFrame::kPrevious
  const GBuffer* gbuffer = nullptr;
  const LightSampler* lights = nullptr;
  const std::vector<Bsdf>* materials = nullptr;    // one per Sequence::materials
  const FrameState* previousState = nullptr;       // null on the first frame of a run
  const GBuffer* previousGbuffer = nullptr;        // null on the first frame of a run
  const std::vector<LightTriangle>* previousLights = nullptr;  // the previous frame's light list
  uint32_t seed = 0;
  uint32_t frame = 0;
};

// The passes of a frame in order; metrics.csv has a column per pass for every preset.
inline constexpr const char* kPassNames[] = {"initial", "temporal", "spatial", "shade"};

// What one pass did, for metrics.csv.
struct PassStats {
  std::string name;     // initial, temporal, spatial, shade
  double ms = 0.0;      // wall time of the pass
  uint64_t rays = 0;    // rays traced by the pass
  // Work the pass handed to its SIMD kernels (bench/frame_bench.cpp prices it at the kernels_bench rates):
  uint64_t risPixels = 0;     // pixels through the RIS kernel (core/ris_kernel.h)
  uint64_t targets = 0;       // (receiver, light point) pairs through the target kernel (core/target_kernel.h)
  uint64_t combinations = 0;  // combinations through the GRIS kernel (core/gris_kernel.h)
};

struct FrameResult {
  ImageRgb image;
  std::vector<PassStats> passes;
  uint64_t guardedEvents = 0;      // non-finite values caught and reset (DESIGN §10)
  double temporalAcceptance = 0;   // fraction of surface pixels whose previous reservoir entered the combination
  double meanConfidence = 0;       // mean output confidence over surface pixels
  uint64_t crossObjectReuse = 0;   // temporal inputs whose previous surface had another object id (must be 0)
  std::vector<uint8_t> temporalAccepted;  // per pixel: the previous reservoir was used
};

// A reservoir as the pipeline stores it between passes and frames (issue 6 memory budget): the sample's light
// id, point and normal, and the reservoir's scalars. The emitted radiance is looked up from the light list of
// whichever frame evaluates the sample, so it is not stored; p_src and the running weight sum matter only while
// RIS streams candidates.
struct StoredReservoir {
  uint32_t lightId = 0;     // LightSample::lightId
  Vec3 position{0.0f};      // LightSample::position
  Vec3 normal{0.0f};        // LightSample::normal
  float targetPdf = 0.0f;   // Reservoir::targetPdf
  float W = 0.0f;           // Reservoir::W
  float confidence = 0.0f;  // Reservoir::confidence
  float visibility = 1.0f;  // Reservoir::visibility
  bool HasSample() const { return W > 0.0f; }
};
static_assert(sizeof(StoredReservoir) == 44);
StoredReservoir Store(const Reservoir& r);

struct SpatialWork;
inline constexpr int kMaxCellTile = 32;  // a cell holds at most kMaxCellTile² pixels
inline constexpr int kMaxCellPixels = kMaxCellTile * kMaxCellTile;
inline constexpr int kMaxCellSearchIterations = 64;  // bound on SpatialParams::cellSearchIterations

// Per-preset estimator state across frames (reservoir buffers are ping-ponged by later passes).
class Pipeline {
 public:
  // Throws std::invalid_argument for settings outside the bounds sim/settings.cpp validates (per-batch scratch
  // is sized by them).
  explicit Pipeline(const PipelineSettings& settings);
  FrameResult RenderFrame(const FrameInputs& in);
  const PipelineSettings& Settings() const { return settings_; }
  // The state carried to the next frame (the last output reservoirs), for checkpoints (--resume).
  const std::vector<StoredReservoir>& History() const { return previousReservoirs_; }
  std::vector<StoredReservoir>& History() { return previousReservoirs_; }
  void RestoreHistory(std::vector<StoredReservoir> reservoirs) { previousReservoirs_ = std::move(reservoirs); }
  // Reservoir buffers the pipeline holds (per pixel): this frame's and last frame's. A spatial iteration writes
  // into last frame's buffer once temporal reuse has read it, so no third buffer exists.
  static constexpr int kReservoirBuffers = 2;

 private:
  PipelineSettings settings_;
  std::vector<StoredReservoir> reservoirs_;          // this frame's reservoirs
  std::vector<StoredReservoir> previousReservoirs_;  // last frame's output (temporal input), then spatial scratch
  // Screen-space cells of the current spatial iteration (stochastic pairwise MIS).
  struct Cell {
    int32_t objectId = -1;   // shared object id of its pixels
    uint32_t key = 0;        // PCG hash of (tile, object id, quantised normal)
    Vec3 normal{0.0f};       // normalised mean geometric normal
    uint32_t first = 0;      // its pixels: cellPixels_[first, first + count)
    uint32_t count = 0;
    float confidenceSum = 0; // Σ c_i over its pixels (weights the neighbour-cell search)
  };
  std::vector<Cell> cells_;
  std::vector<int32_t> pixelCell_;    // per pixel: its cell, or -1
  std::vector<uint32_t> cellPixels_;  // pixel indices grouped by cell, in scan order within a cell
  void BuildCells(const GBuffer& g, const std::vector<StoredReservoir>& reservoirs);
  // Stochastic pairwise reuse (seed 004 §5.1): the neighbour cell chosen among the cells under the search
  // positions (cell index or -1 per search iteration, with its uniform), or -1.
  int32_t ChooseCell(size_t pixel, const GBuffer& g, const int32_t* searchCell, const float* searchPick) const;
  // Then the chosen cell's draws and the canonical draws (the rest of the pixel's random numbers). False when
  // the pixel keeps its reservoir.
  bool StochasticPairwiseDraws(size_t pixel, int32_t chosen, const std::vector<StoredReservoir>& input, Sampler& s,
                               SpatialWork& work) const;
 public:
  // Read-only views for tests (cells of the last spatial iteration).
  const std::vector<int32_t>& PixelCells() const { return pixelCell_; }
  const std::vector<uint32_t>& CellPixels() const { return cellPixels_; }
  size_t CellCount() const { return cells_.size(); }
};

// Materials of a sequence as BSDFs (GGX alpha = roughness^2).
std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence);

// The receiver at a G-buffer pixel; valid only where gbuffer.IsSurface(i).
ShadingPoint ShadingPointAt(const GBuffer& gbuffer, size_t i, const Camera& camera, const std::vector<Bsdf>& bsdfs);

// Radiance a primary ray sees directly at pixel i: an emitter's front face, else zero.
Vec3 DirectEmission(const GBuffer& gbuffer, size_t i, const std::vector<LightTriangle>& lights);

// True when the segment from the receiver to a light point (on an emitter of normal lightNormal and error scale
// lightErrorScale) is blocked: core/shadow_ray.h ShadowRaySetup, both ends spawned off their surfaces.
bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame = SceneFrame::kCurrent);

}  // namespace restir
