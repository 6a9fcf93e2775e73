// The batching machinery the passes share (issue 6): pixels go through the passes in batches of up to
// kBatchPixels of a row; a batch's target entries p̂_j(Y_i) go through the SIMD target kernel in one call, its
// shadow rays through Embree's packet interface in one call per scene frame, and its GRIS combinations through
// the SIMD combination kernel. Every value is the one evaluating each entry on its own would give, so the batch
// size never changes a bit.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/gris.h"
#include "core/gris_kernel.h"
#include "core/target_kernel.h"
#include "sim/util/clock.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

// Pixels per batch: small enough that a batch's combinations stay in cache.
inline constexpr int kBatchPixels = 64;
// A combination's domains: its inputs, plus (stochastic pairwise) the pixels its canonical draws picked.
inline constexpr int kMaxDomains = 2 * kMaxGrisInputs;

// Rows are the unit of parallel work of the row passes: every pixel is independent, so the result does not
// depend on the split.
template <typename F>
void ForEachRow(int height, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y) f(y);
  });
}

// Batches of up to kBatchPixels pixels of a row, in order: f(y, x0, x1).
template <typename F>
void ForEachBatch(int width, int height, F&& f) {
  const int batchesPerRow = (width + kBatchPixels - 1) / kBatchPixels;
  tbb::parallel_for(tbb::blocked_range<int>(0, height * batchesPerRow), [&](const tbb::blocked_range<int>& r) {
    for (int b = r.begin(); b < r.end(); ++b) {
      const int y = b / batchesPerRow, x0 = (b % batchesPerRow) * kBatchPixels;
      f(y, x0, std::min(width, x0 + kBatchPixels));
    }
  });
}

// Starts loading the G-buffer lines of pixel p that the similarity test and the target kernel read, for a pixel
// picked at random (a neighbour, a cell's draw), so that the misses overlap instead of stalling one at a time.
inline void PrefetchSurface(const GBuffer& g, size_t p) {
  for (const auto* a : {&g.posX, &g.posY, &g.posZ, &g.ngX, &g.ngY, &g.ngZ, &g.nsX, &g.nsY, &g.nsZ, &g.depth})
    __builtin_prefetch(a->data() + p);
  __builtin_prefetch(g.objectId.data() + p);
  __builtin_prefetch(g.materialId.data() + p);
  __builtin_prefetch(g.bsdfId.data() + p);
}

// The frame a combination's domain lives in: its G-buffer, camera, light list and scene (DESIGN §4 "p̂ from i").
struct DomainFrame {
  const GBuffer* gbuffer = nullptr;
  Vec3 eye{0.0f};
  const std::vector<LightTriangle>* lights = nullptr;
  SceneFrame scene = SceneFrame::kCurrent;
  const Sky* sky = nullptr;  // that frame's sky (null or empty: none), for samples that are directions
};

// (receiver, light point) pairs gathered structure-of-arrays for the target kernel (core/target_kernel.h).
class TargetPairBuffer {
 public:
  void Clear() { size_ = 0; }
  // The receiver at G-buffer pixel `p`, seen from `eye`, and a light point with the radiance it has there. Inline
  // and into arrays that keep their size from batch to batch: it runs once per target entry, the passes' most
  // frequent operation.
  void Add(const Vec3& eye, const GBuffer& g, size_t p, const Vec3& lightPosition, const Vec3& lightNormal,
           const Vec3& radiance) {
    if (size_ == material_.size()) Grow();
    const size_t k = size_;
    for (int c = 0; c < 3; ++c) {
      field_[c][k] = eye[c];
      field_[12 + c][k] = lightPosition[c];
      field_[15 + c][k] = lightNormal[c];
      field_[18 + c][k] = radiance[c];
    }
    field_[3][k] = g.posX[p], field_[4][k] = g.posY[p], field_[5][k] = g.posZ[p];
    field_[6][k] = g.ngX[p], field_[7][k] = g.ngY[p], field_[8][k] = g.ngZ[p];
    field_[9][k] = g.nsX[p], field_[10][k] = g.nsY[p], field_[11][k] = g.nsZ[p];
    material_[k] = g.bsdfId[p];  // the BSDF table index (FrameBsdfTable)
    ++size_;
  }
  size_t Size() const { return size_; }
  // p̂ of every pair into target[0, Size()), and L_e f_r G into contribution[c] when not null.
  void Evaluate(const BsdfSoa& materials, float* target, float* const* contribution = nullptr) const;

 private:
  void Grow();
  std::vector<float> field_[kTargetPairFields];  // MakeTargetPairs' order
  std::vector<int32_t> material_;
  size_t size_ = 0;  // pairs added since Clear (the arrays may be longer)
};

// Shadow rays of a batch of pixels, all in one scene frame: the queries gathered structure-of-arrays, set up by
// the SIMD kernel (core/shadow_ray_kernel.h; the same bits as ShadowRaySetup) and traced in one OccludedBatch
// call.
class ShadowRayBatch {
 public:
  void Clear() { size_ = 0; }
  // The segment from G-buffer pixel `pixel` to light point y on an emitter of normal lightNormal.
  void Add(const GBuffer& g, size_t pixel, const Vec3& y, const Vec3& lightNormal, float lightErrorScale);
  // The segment to a stored sample (a direction goes to its far point, core/sky.h SkyPointFor). The sample's light
  // must be in `lights` (or be the sky).
  void Add(const GBuffer& g, size_t pixel, const StoredReservoir& r, const std::vector<LightTriangle>& lights) {
    LightPoint y;
    LightPointAt(g.Position(pixel), r.lightId, r.position, r.normal, lights, nullptr, y);
    Add(g, pixel, y.position, y.normal, y.errorScale);
  }
  size_t Size() const { return size_; }
  // Traces every ray added since Clear; occluded[k] answers the k-th.
  const std::vector<uint8_t>& Trace(const EmbreeScene& scene, SceneFrame frame);

 private:
  size_t size_ = 0;
  // Queries: position, geometric normal, light position, light normal, the two error scales; rays: org, dir, tmax.
  std::vector<float> in_[14], out_[7];
  std::vector<ShadowRay> rays_;
  std::vector<uint8_t> occluded_;
};

enum class Entry : uint8_t { kUnknown, kQueued, kKnown };

// One pixel's GRIS combination while its batch is assembled: the inputs (input 0 canonical), the domains and
// the entries p̂_j(Y_i) evaluated so far.
struct Combination {
  uint32_t pixel = 0;
  int count = 0;    // inputs
  int domains = 0;  // count, plus any extra domains
  uint8_t view[kMaxDomains];            // DomainFrame of domain j
  uint32_t domainPixel[kMaxDomains];    // G-buffer pixel of domain j
  LightSample samples[kMaxGrisInputs];  // Y_i (radiance unused: each domain looks it up in its own frame)
  GrisInput inputs[kMaxGrisInputs];
  float u[kMaxGrisInputs];              // streaming-selection uniforms
  SampleHistory history[kMaxGrisInputs];  // StoredReservoir::history of input i as handed to this pixel
  float target[kMaxDomains][kMaxGrisInputs];
  Entry state[kMaxDomains][kMaxGrisInputs];
  void Reset(uint32_t p, int inputCount, int domainCount) {
    pixel = p;
    count = inputCount;
    domains = domainCount;
    for (int j = 0; j < domainCount; ++j)
      for (int i = 0; i < inputCount; ++i) state[j][i] = Entry::kUnknown;
    for (int i = 0; i < kMaxGrisInputs; ++i) history[i] = SampleHistory{};
  }
  void AddDomain(uint8_t v, uint32_t p) {
    view[domains] = v;
    domainPixel[domains] = p;
    for (int i = 0; i < count; ++i) state[domains][i] = Entry::kUnknown;
    ++domains;
  }
  // Appends input `slot` = count: its entries in the existing domains start unknown.
  int AddInput() {
    const int slot = count++;
    for (int j = 0; j < slot; ++j) state[j][slot] = Entry::kUnknown;
    return slot;
  }
  // The entry p̂_j(Y_i) if evaluated, else 0 (an entry a family never reads).
  float Known(int j, int i) const { return state[j][i] == Entry::kKnown ? target[j][i] : 0.0f; }
};

// Evaluates queued entries p̂_j(Y_i) of a batch of combinations: the unshadowed targets in one call of the SIMD
// kernel (core/target_kernel.h), then, with visibility, one shadow ray per positive entry, traced as a batch per
// frame. Also traces the visibility re-test of spatial neighbours (seed 000 Algorithm 1). The values are those of
// evaluating each entry on its own, so the batch size never changes the bits.
class TargetEvaluator {
 public:
  // Sets what the next batches evaluate against (the buffers are kept from batch to batch).
  // With `previousSampleVisible` (RTXDI's temporal visibility shortcut), entry (1, 1), the previous frame's sample
  // at its own surface, keeps its unshadowed value: no ray.
  void Bind(const DomainFrame* views, const BsdfSoa& materials, const EmbreeScene& scene, bool visibility,
            bool previousSampleVisible = false);
  // Queues p̂_j(Y_i) of `c` unless it is known or queued (inline: called for every entry a combination reads).
  void Request(Combination& c, int j, int i) {
    if (c.state[j][i] != Entry::kUnknown) return;
    c.state[j][i] = Entry::kQueued;
    const DomainFrame& v = views_[c.view[j]];
    if (!IsSkySample(c.samples[i].lightId) && c.samples[i].lightId >= v.lights->size()) {  // removed that frame
      c.target[j][i] = 0.0f;
      c.state[j][i] = Entry::kKnown;
      return;
    }
    pending_.push_back({&c, static_cast<uint8_t>(j), static_cast<uint8_t>(i)});
  }
  // Queues a shadow ray from input 0's surface to Y_i; Resolve sets input i's visibility from it.
  void RequestVisibility(Combination& c, int i) { visibilityPending_.push_back({&c, 0, static_cast<uint8_t>(i)}); }
  // Evaluates everything queued. `rays` counts the shadow rays traced.
  void Resolve(uint64_t& rays);
  uint64_t Evaluated() const { return evaluated_; }  // pairs handed to the target kernel so far

 private:
  struct Pending {
    Combination* c;
    uint8_t j, i;
  };
  const DomainFrame* views_ = nullptr;
  const BsdfSoa* materials_ = nullptr;
  const EmbreeScene* scene_ = nullptr;
  bool visibility_ = false;
  bool previousSampleVisible_ = false;
  uint64_t evaluated_ = 0;
  std::vector<Pending> pending_, visibilityPending_;
  TargetPairBuffer pairs_;
  std::vector<float> values_;
  ShadowRayBatch rays_[2];           // current frame, previous frame
  std::vector<int64_t> rayRefs_[2];  // >= 0: pending entry; < 0: -1 - visibility request
};

// Queues the canonical targets p̂_c(Y_i) that GrisCombine reads first: inputs that can contribute.
void RequestCanonicalTargets(Combination& c, TargetEvaluator& ev);

// Queues every other entry GrisCombine will read. Once the canonical targets are known, which entries a family
// reads depends on them alone (pairwise: p̂_j(Y_0) and p̂_i(Y_i) where p̂_c > 0; balance: column i where
// p̂_c(Y_i) > 0; Z: the selected column, and the selection uses c_i and p̂_c only), so a dry run of the
// combination with the unknown entries at 0 names them exactly: no ray is traced that the scalar order would not
// trace.
void RequestFamilyTargets(Combination& c, MisFamily family, VisibilityCarry carry, TargetEvaluator& ev);

// A batch's combinations laid out for the GRIS kernel (core/gris_kernel.h): one lane per combination.
class CombineBatch {
 public:
  // Lays out combos[order[0..count)] (order null: combos[0..count)). With `matrix`, the known target entries
  // (every entry the family reads, see RequestFamilyTargets; the rest are never read and stay 0).
  void Fill(const Combination* combos, const int* order, int count, bool matrix);
  // The laid-out arrays, for kernels that fill the MIS weights and canonical targets GrisResampleBatch reads.
  GrisBatchArrays& Arrays() { return arrays_; }
  // GrisCombine of every lane (family weights from the matrix) or GrisResample (given weights).
  void Combine(MisFamily family, VisibilityCarry carry);
  void Resample(VisibilityCarry carry);
  uint64_t Combined() const { return combined_; }  // combinations handed to the GRIS kernel so far
  GrisResult Result(int k) const;

 private:
  GrisBatchOutput Output() { return GrisBatchOutput{selected_, weightSum_, W_, confidence_, visibility_, guarded_}; }
  GrisBatchArrays arrays_;
  uint64_t combined_ = 0;
  int32_t selected_[kBatchPixels], guarded_[kBatchPixels];
  float weightSum_[kBatchPixels], W_[kBatchPixels], confidence_[kBatchPixels], visibility_[kBatchPixels];
};

// The output reservoir of a combination (the selected sample with its canonical target).
StoredReservoir OutputOf(const Combination& c, const GrisResult& gr, float confidence);

// The MIS family a reuse pass runs: `none` bias correction means uniform weights whatever the family.
inline MisFamily EffectiveFamily(MisFamily family, BiasCorrection bias) {
  return bias == BiasCorrection::kNone ? MisFamily::kUniform : family;
}

// How a combination carries visibility for the shading pass to use.
inline VisibilityCarry CarryFor(VisibilityReuse v) {
  return v == VisibilityReuse::kWeighted ? VisibilityCarry::kWeighted : VisibilityCarry::kSelected;
}

// Neighbour similarity (DESIGN §4): surface pixel j of `b` is usable for pixel i of `a` when its geometric normal
// is within normalThreshold (dot) and its view depth within depthThreshold (relative).
bool SimilarSurface(const GBuffer& a, size_t i, const GBuffer& b, size_t j, float normalThreshold,
                    float depthThreshold);

// A stored reservoir's sample and its GRIS input.
LightSample SampleOf(const StoredReservoir& r);
inline GrisInput InputOf(const StoredReservoir& r, float confidence) {
  return GrisInput{r.HasSample(), r.W, confidence, r.visibility};
}

// Per-thread scratch of a reuse pass's batches, reused from batch to batch.
struct BatchScratch {
  std::vector<Combination> combinations = std::vector<Combination>(kBatchPixels);
  std::vector<int> order = std::vector<int>(kBatchPixels);  // the batch's combinations still in play
  TargetEvaluator evaluator;
  CombineBatch combine;
};

// The deterministic-family combination of a batch, as the temporal and k-neighbour passes run it: the canonical
// targets, then the entries the family reads (RequestFamilyTargets), each round resolved as one batch, then the
// GRIS kernel over sc.combinations[order[0..count)] (order null: [0..count)). `rays` counts the shadow rays.
void CombineFamilyBatch(BatchScratch& sc, const int* order, int count, MisFamily family, VisibilityCarry carry,
                        uint64_t& rays);

// A reuse pass's statistics from its per-thread counters and scratch (Scratch: BatchScratch or a derived one).
template <typename Scratch>
void FinishReusePass(const char* name, Clock::time_point start, tbb::combinable<uint64_t>& rays,
                     tbb::combinable<uint64_t>& guarded, const tbb::enumerable_thread_specific<Scratch>& scratch,
                     PassStats& stats) {
  stats.name = name;
  stats.ms = MsSince(start);
  stats.rays = rays.combine(std::plus<uint64_t>());
  stats.guarded = guarded.combine(std::plus<uint64_t>());
  for (const Scratch& sc : scratch)
    stats.targets += sc.evaluator.Evaluated(), stats.combinations += sc.combine.Combined();
}

}  // namespace restir
