#include "sim/pipeline.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "core/gris.h"
#include "core/gris_kernel.h"
#include "core/ris_kernel.h"
#include "core/rng.h"
#include "core/shadow_ray_kernel.h"
#include "core/spmis.h"
#include "core/spmis_kernel.h"
#include "core/target_kernel.h"

namespace restir {

namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Rows are the unit of parallel work: every pixel is independent, so the result does not depend on the split.
template <typename F>
void ForEachRow(int height, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y) f(y);
  });
}

}  // namespace

Pipeline::Pipeline(const PipelineSettings& settings) : settings_(settings) {
  const SpatialParams& sp = settings.spatial;
  if (sp.cellSearchIterations < 1 || sp.cellSearchIterations > kMaxCellSearchIterations || sp.cellTile < 1 ||
      sp.cellTile > kMaxCellTile || sp.draws < 1 || sp.draws > kMaxGrisInputs - 1 || sp.canonicalDraws < 1 ||
      sp.canonicalDraws > kMaxGrisInputs - 1)
    throw std::invalid_argument("Pipeline: spatial settings outside their validated bounds");
}

std::vector<Bsdf> MaterialBsdfs(const Sequence& sequence) {
  std::vector<Bsdf> out;
  out.reserve(sequence.materials.size());
  for (const Material& m : sequence.materials) {
    Bsdf b;
    b.type = m.type == MaterialType::kGgx ? BsdfType::kGgx : BsdfType::kDiffuse;
    b.albedo = m.albedo;
    b.alpha = m.roughness * m.roughness;
    out.push_back(b);
  }
  return out;
}

ShadingPoint ShadingPointAt(const GBuffer& g, size_t i, const Camera& camera, const std::vector<Bsdf>& bsdfs) {
  ShadingPoint sp;
  sp.position = g.Position(i);
  sp.geometricNormal = g.GeometricNormal(i);
  sp.shadingNormal = g.ShadingNormal(i);
  sp.wo = glm::normalize(camera.position - sp.position);
  sp.bsdf = bsdfs[static_cast<size_t>(g.materialId[i])];
  sp.errorScale = g.errorScale[i];
  return sp;
}

Vec3 DirectEmission(const GBuffer& g, size_t i, const std::vector<LightTriangle>& lights) {
  const int32_t id = g.lightId[i];
  if (id < 0) return Vec3(0.0f);
  const LightTriangle& t = lights[static_cast<size_t>(id)];
  // The G-buffer normal faces the camera; the emitter is seen from its front when its own normal does too.
  return glm::dot(t.normal, g.GeometricNormal(i)) > 0.0f ? t.radiance : Vec3(0.0f);
}

bool ShadowRayOccluded(const EmbreeScene& scene, const ShadingPoint& sp, const Vec3& lightPosition,
                       const Vec3& lightNormal, float lightErrorScale, SceneFrame frame) {
  const ShadowRaySegment ray =
      ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, lightPosition, lightNormal, lightErrorScale);
  return scene.Occluded(ray.org, ray.dir, ray.tmax, frame);
}

StoredReservoir Store(const Reservoir& r) {
  StoredReservoir s;
  s.lightId = r.sample.lightId;
  s.position = r.sample.position;
  s.normal = r.sample.normal;
  s.targetPdf = r.targetPdf;
  s.W = r.W;
  s.confidence = r.confidence;
  s.visibility = r.visibility;
  return s;
}

namespace {

// Pixels per batch: a batch's target entries go through the SIMD kernel in one call and its shadow rays through
// Embree's packet interface in one call per frame. Small enough that a batch's combinations stay in cache.
constexpr int kBatchPixels = 64;
// A combination's domains: its inputs, plus (stochastic pairwise) the pixels its canonical draws picked.
constexpr int kMaxDomains = 2 * kMaxGrisInputs;

// A frame a domain lives in: its G-buffer, camera, light list and scene (DESIGN §4 "p̂ from i").
struct FrameView {
  const GBuffer* gbuffer = nullptr;
  Vec3 eye{0.0f};
  const std::vector<LightTriangle>* lights = nullptr;
  SceneFrame scene = SceneFrame::kCurrent;
};

// Shadow rays of a batch of pixels, all in one scene frame: the queries gathered structure-of-arrays, set up by
// the SIMD kernel (core/shadow_ray_kernel.h; the same bits as ShadowRaySetup) and traced in one OccludedBatch
// call.
class ShadowRayBatch {
 public:
  void Clear() { size_ = 0; }
  // The segment from G-buffer pixel `pixel` to light point y on an emitter of normal lightNormal.
  void Add(const GBuffer& g, size_t pixel, const Vec3& y, const Vec3& lightNormal, float lightErrorScale) {
    if (size_ == in_[0].size())  // grow all arrays together; they keep their capacity from batch to batch
      for (auto& v : in_) v.resize(std::max<size_t>(256, 2 * size_));
    const size_t k = size_++;
    in_[0][k] = g.posX[pixel], in_[1][k] = g.posY[pixel], in_[2][k] = g.posZ[pixel];
    in_[3][k] = g.ngX[pixel], in_[4][k] = g.ngY[pixel], in_[5][k] = g.ngZ[pixel];
    in_[6][k] = y.x, in_[7][k] = y.y, in_[8][k] = y.z;
    in_[9][k] = lightNormal.x, in_[10][k] = lightNormal.y, in_[11][k] = lightNormal.z;
    in_[12][k] = g.errorScale[pixel], in_[13][k] = lightErrorScale;
  }
  void Add(const GBuffer& g, size_t pixel, const StoredReservoir& r, const std::vector<LightTriangle>& lights) {
    Add(g, pixel, r.position, r.normal, lights[r.lightId].errorScale);
  }
  size_t Size() const { return size_; }
  // Traces every ray added since Clear; occluded[k] answers the k-th.
  const std::vector<uint8_t>& Trace(const EmbreeScene& scene, SceneFrame frame) {
    const size_t n = Size();
    for (auto& v : out_) v.resize(n);
    ShadowRayInputs in;
    ShadowRayOutputs out;
    for (int c = 0; c < 3; ++c) {
      in.position[c] = in_[c].data();
      in.geometricNormal[c] = in_[3 + c].data();
      in.lightPosition[c] = in_[6 + c].data();
      in.lightNormal[c] = in_[9 + c].data();
      out.org[c] = out_[c].data();
      out.dir[c] = out_[3 + c].data();
    }
    in.errorScale = in_[12].data();
    in.lightErrorScale = in_[13].data();
    in.count = n;
    out.tmax = out_[6].data();
    SetupShadowRays(in, out);
    rays_.resize(n);
    for (size_t k = 0; k < n; ++k)
      rays_[k] = ShadowRay{Vec3(out_[0][k], out_[1][k], out_[2][k]), Vec3(out_[3][k], out_[4][k], out_[5][k]),
                           out_[6][k]};
    occluded_.resize(n);
    if (n > 0) scene.OccludedBatch(rays_.data(), occluded_.data(), n, frame);
    return occluded_;
  }

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
  uint8_t view[kMaxDomains];            // FrameView of domain j
  uint32_t domainPixel[kMaxDomains];    // G-buffer pixel of domain j
  LightSample samples[kMaxGrisInputs];  // Y_i (radiance unused: each domain looks it up in its own frame)
  GrisInput inputs[kMaxGrisInputs];
  float u[kMaxGrisInputs];              // streaming-selection uniforms
  float target[kMaxDomains][kMaxGrisInputs];
  Entry state[kMaxDomains][kMaxGrisInputs];
  void Reset(uint32_t p, int inputCount, int domainCount) {
    pixel = p;
    count = inputCount;
    domains = domainCount;
    for (int j = 0; j < domainCount; ++j)
      for (int i = 0; i < inputCount; ++i) state[j][i] = Entry::kUnknown;
  }
  void AddDomain(uint8_t v, uint32_t p) {
    view[domains] = v;
    domainPixel[domains] = p;
    for (int i = 0; i < count; ++i) state[domains][i] = Entry::kUnknown;
    ++domains;
  }
};

// Evaluates queued entries p̂_j(Y_i) of a batch of combinations: the unshadowed targets in one call of the SIMD
// kernel (core/target_kernel.h), then, with visibility, one shadow ray per positive entry, traced as a batch per
// frame. Also traces the visibility re-test of spatial neighbours (seed 000 Algorithm 1). The values are those of
// evaluating each entry on its own, so the batch size never changes the bits.
class TargetEvaluator {
 public:
  // Sets what the next batches evaluate against (the buffers are kept from batch to batch).
  void Bind(const FrameView* views, const RisMaterials& materials, const EmbreeScene& scene, bool visibility) {
    views_ = views;
    materials_ = &materials;
    scene_ = &scene;
    visibility_ = visibility;
    pending_.clear();
    visibilityPending_.clear();
  }

  // Queues p̂_j(Y_i) of `c` unless it is known or queued.
  void Request(Combination& c, int j, int i) {
    if (c.state[j][i] != Entry::kUnknown) return;
    c.state[j][i] = Entry::kQueued;
    const FrameView& v = views_[c.view[j]];
    if (c.samples[i].lightId >= v.lights->size()) {  // a light removed in that frame
      c.target[j][i] = 0.0f;
      c.state[j][i] = Entry::kKnown;
      return;
    }
    pending_.push_back({&c, static_cast<uint8_t>(j), static_cast<uint8_t>(i)});
  }
  uint64_t Evaluated() const { return evaluated_; }
  // Queues a shadow ray from input 0's surface to Y_i; Resolve sets input i's visibility from it.
  void RequestVisibility(Combination& c, int i) { visibilityPending_.push_back({&c, 0, static_cast<uint8_t>(i)}); }

  // Evaluates everything queued. `rays` counts the shadow rays traced.
  void Resolve(uint64_t& rays) {
    const size_t n = pending_.size();
    evaluated_ += n;
    if (n > 0) {
      for (auto& a : soa_) a.resize(n);
      mat_.resize(n);
      values_.resize(n);
      float* field[kTargetPairFields];
      for (int f = 0; f < kTargetPairFields; ++f) field[f] = soa_[f].data();
      for (size_t k = 0; k < n; ++k) {
        const Pending& e = pending_[k];
        const FrameView& v = views_[e.c->view[e.j]];
        const GBuffer& g = *v.gbuffer;
        const size_t p = e.c->domainPixel[e.j];
        const LightSample& y = e.c->samples[e.i];
        const Vec3& radiance = (*v.lights)[y.lightId].radiance;
        for (int c = 0; c < 3; ++c) {
          field[c][k] = v.eye[c];
          field[12 + c][k] = y.position[c];
          field[15 + c][k] = y.normal[c];
          field[18 + c][k] = radiance[c];
        }
        field[3][k] = g.posX[p], field[4][k] = g.posY[p], field[5][k] = g.posZ[p];
        field[6][k] = g.ngX[p], field[7][k] = g.ngY[p], field[8][k] = g.ngZ[p];
        field[9][k] = g.nsX[p], field[10][k] = g.nsY[p], field[11][k] = g.nsZ[p];
        mat_[k] = g.materialId[p];
      }
      const TargetPairs pairs = MakeTargetPairs(field, mat_.data(), n);
      TargetResults results;
      results.target = values_.data();
      EvaluateTargets(pairs, *materials_, results);
    }
    // Shadow rays: positive entries when targets include visibility, and the neighbours' visibility re-tests.
    for (int f = 0; f < 2; ++f) rays_[f].Clear(), rayRefs_[f].clear();
    for (size_t k = 0; k < n; ++k) {
      if (!(visibility_ && values_[k] > 0.0f)) continue;
      const Pending& e = pending_[k];
      const FrameView& v = views_[e.c->view[e.j]];
      const int f = v.scene == SceneFrame::kCurrent ? 0 : 1;
      const LightSample& y = e.c->samples[e.i];
      rays_[f].Add(*v.gbuffer, e.c->domainPixel[e.j], y.position, y.normal, (*v.lights)[y.lightId].errorScale);
      rayRefs_[f].push_back(static_cast<int64_t>(k));
    }
    for (size_t k = 0; k < visibilityPending_.size(); ++k) {
      const Pending& e = visibilityPending_[k];
      const FrameView& v = views_[e.c->view[0]];
      const LightSample& y = e.c->samples[e.i];
      if (y.lightId >= v.lights->size()) {  // a light removed in that frame: nothing to see
        e.c->inputs[e.i].visibility = 0.0f;
        continue;
      }
      rays_[0].Add(*v.gbuffer, e.c->domainPixel[0], y.position, y.normal, (*v.lights)[y.lightId].errorScale);
      rayRefs_[0].push_back(-1 - static_cast<int64_t>(k));
    }
    for (int f = 0; f < 2; ++f) {
      if (rays_[f].Size() == 0) continue;
      const std::vector<uint8_t>& occluded =
          rays_[f].Trace(*scene_, f == 0 ? SceneFrame::kCurrent : SceneFrame::kPrevious);
      rays += rays_[f].Size();
      for (size_t r = 0; r < occluded.size(); ++r) {
        const int64_t ref = rayRefs_[f][r];
        if (ref >= 0) {
          if (occluded[r]) values_[static_cast<size_t>(ref)] = 0.0f;
        } else {
          const Pending& e = visibilityPending_[static_cast<size_t>(-1 - ref)];
          e.c->inputs[e.i].visibility = occluded[r] ? 0.0f : 1.0f;
        }
      }
    }
    for (size_t k = 0; k < n; ++k) {
      const Pending& e = pending_[k];
      e.c->target[e.j][e.i] = values_[k];
      e.c->state[e.j][e.i] = Entry::kKnown;
    }
    pending_.clear();
    visibilityPending_.clear();
  }

 private:
  struct Pending {
    Combination* c;
    uint8_t j, i;
  };
  const FrameView* views_ = nullptr;
  const RisMaterials* materials_ = nullptr;
  const EmbreeScene* scene_ = nullptr;
  bool visibility_ = false;
  uint64_t evaluated_ = 0;  // pairs handed to the target kernel so far
  std::vector<Pending> pending_, visibilityPending_;
  std::vector<float> soa_[kTargetPairFields];
  std::vector<int32_t> mat_;
  std::vector<float> values_;
  ShadowRayBatch rays_[2];           // current frame, previous frame
  std::vector<int64_t> rayRefs_[2];  // >= 0: pending entry; < 0: -1 - visibility request
};

// Queues the canonical targets p̂_c(Y_i) that GrisCombine reads first: inputs that can contribute.
void RequestCanonicalTargets(Combination& c, TargetEvaluator& ev) {
  for (int i = 0; i < c.count; ++i) {
    const GrisInput& in = c.inputs[i];
    if (in.hasSample && in.W > 0.0f && IsFiniteWeight(in.W)) ev.Request(c, 0, i);
  }
}

// Queues every other entry GrisCombine will read. Once the canonical targets are known, which entries a
// family reads depends on them alone (pairwise: p̂_j(Y_0) and p̂_i(Y_i) where p̂_c > 0; balance: column i where
// p̂_c(Y_i) > 0; Z: the selected column, and the selection uses c_i and p̂_c only), so a dry run of the
// combination with the unknown entries at 0 names them exactly: no ray is traced that the scalar order would not
// trace.
void RequestFamilyTargets(Combination& c, MisFamily family, VisibilityCarry carry, TargetEvaluator& ev) {
  auto record = [&](int j, int i) {
    if (c.state[j][i] == Entry::kKnown) return c.target[j][i];
    ev.Request(c, j, i);
    return 0.0f;
  };
  GrisCombine(family, c.inputs, c.count, record, c.u, carry);
}

// A batch's combinations laid out for the GRIS kernel (core/gris_kernel.h): one lane per combination.
class CombineBatch {
 public:
  // Lays out combos[order[0..count)] (order null: combos[0..count)). With `matrix`, the known target entries
  // (every entry the family reads, see RequestFamilyTargets; the rest are never read and stay 0).
  void Fill(Combination* combos, const int* order, int count, bool matrix) {
    GrisBatchArrays& a = arrays_;
    a.count = static_cast<size_t>(count);
    a.stride = kBatchPixels;
    a.matrixSize = 1;
    for (int k = 0; k < count; ++k) a.matrixSize = std::max(a.matrixSize, combos[order ? order[k] : k].count);
    const size_t rows = static_cast<size_t>(a.matrixSize) * a.stride;
    a.inputs.assign(a.stride, 0);
    for (auto* v : {&a.W, &a.confidence, &a.visibility, &a.u, &a.mis, &a.canonicalTarget}) v->assign(rows, 0.0f);
    a.hasSample.assign(rows, 0);
    if (matrix) a.target.assign(rows * static_cast<size_t>(a.matrixSize), 0.0f);
    for (int k = 0; k < count; ++k) {
      const Combination& c = combos[order ? order[k] : k];
      a.inputs[k] = c.count;
      for (int i = 0; i < c.count; ++i) {
        const size_t e = a.At(i, static_cast<size_t>(k));
        a.hasSample[e] = c.inputs[i].hasSample ? 1 : 0;
        a.W[e] = c.inputs[i].W;
        a.confidence[e] = c.inputs[i].confidence;
        a.visibility[e] = c.inputs[i].visibility;
        a.u[e] = c.u[i];
      }
      if (!matrix) continue;
      for (int j = 0; j < c.count; ++j)
        for (int i = 0; i < c.count; ++i)
          if (c.state[j][i] == Entry::kKnown) a.target[a.TargetAt(j, i, static_cast<size_t>(k))] = c.target[j][i];
    }
  }
  // The laid-out arrays, for kernels that fill the MIS weights and canonical targets GrisResampleBatch reads.
  GrisBatchArrays& Arrays() { return arrays_; }

  // GrisCombine of every lane (family weights from the matrix) or GrisResample (given weights).
  void Combine(MisFamily family, VisibilityCarry carry) {
    combined_ += arrays_.count;
    GrisCombineBatch(family, carry, arrays_.View(), Output());
  }
  void Resample(VisibilityCarry carry) {
    combined_ += arrays_.count;
    GrisResampleBatch(carry, arrays_.View(), Output());
  }
  uint64_t Combined() const { return combined_; }
  GrisResult Result(int k) const {
    GrisResult r;
    r.selected = selected_[k];
    r.weightSum = weightSum_[k];
    r.W = W_[k];
    r.confidence = confidence_[k];
    r.visibility = visibility_[k];
    r.guarded = guarded_[k];
    return r;
  }

 private:
  GrisBatchOutput Output() {
    return GrisBatchOutput{selected_, weightSum_, W_, confidence_, visibility_, guarded_};
  }
  GrisBatchArrays arrays_;
  uint64_t combined_ = 0;  // combinations handed to the GRIS kernel so far
  int32_t selected_[kBatchPixels], guarded_[kBatchPixels];
  float weightSum_[kBatchPixels], W_[kBatchPixels], confidence_[kBatchPixels], visibility_[kBatchPixels];
};

// The output reservoir of a combination (the selected sample with its canonical target).
StoredReservoir OutputOf(const Combination& c, const GrisResult& gr, float confidence) {
  StoredReservoir out;
  out.confidence = confidence;
  if (gr.selected >= 0) {
    const LightSample& y = c.samples[gr.selected];
    out.lightId = y.lightId;
    out.position = y.position;
    out.normal = y.normal;
    out.targetPdf = c.target[0][gr.selected];
    out.W = gr.W;
    out.visibility = gr.visibility;
  }
  return out;
}

MisFamily EffectiveFamily(MisFamily family, BiasCorrection bias) {
  return bias == BiasCorrection::kNone ? MisFamily::kUniform : family;
}

VisibilityCarry CarryFor(VisibilityReuse v) {
  return v == VisibilityReuse::kWeighted ? VisibilityCarry::kWeighted : VisibilityCarry::kSelected;
}

bool SimilarSurface(const GBuffer& a, size_t i, const GBuffer& b, size_t j, float normalThreshold,
                    float depthThreshold) {
  if (b.objectId[j] < 0 || b.materialId[j] < 0) return false;
  if (glm::dot(a.GeometricNormal(i), b.GeometricNormal(j)) < normalThreshold) return false;
  const float da = a.depth[i], db = b.depth[j];
  return std::abs(da - db) <= depthThreshold * std::max(da, db);
}

// Reservoir or StoredReservoir.
template <typename R>
bool FiniteReservoir(const R& r) {
  return std::isfinite(r.W) && std::isfinite(r.confidence) && std::isfinite(r.visibility) && r.W >= 0.0f;
}

LightSample SampleOf(const StoredReservoir& r) {
  LightSample y;
  y.lightId = r.lightId;
  y.position = r.position;
  y.normal = r.normal;
  y.radiance = Vec3(0.0f);
  return y;
}

GrisInput InputOf(const StoredReservoir& r, float confidence) {
  return GrisInput{r.HasSample(), r.W, confidence, r.visibility};
}

// Per-thread scratch of a batch, reused across batches.
struct BatchScratch {
  std::vector<Combination> combinations = std::vector<Combination>(kBatchPixels);
  std::vector<int> order = std::vector<int>(kBatchPixels);  // the batch's combinations still in play
  TargetEvaluator evaluator;
  CombineBatch combine;
  StochasticPairwiseArrays spmis;
  // Stochastic pairwise cell search, per pixel of the batch: the cell (or -1) under each search position and its
  // uniform, and the chosen cell.
  std::vector<int32_t> searchCell = std::vector<int32_t>(kBatchPixels * kMaxCellSearchIterations);
  std::vector<float> searchPick = std::vector<float>(kBatchPixels * kMaxCellSearchIterations);
  std::vector<int32_t> chosenCell = std::vector<int32_t>(kBatchPixels);
};

}  // namespace

// What stochastic pairwise reuse carries from its draws to its weights, per pixel of a batch (seed 004 §3-5).
struct SpatialWork {
  float multiplicity[kMaxGrisInputs];  // K(i) of non-canonical input i
  float probability[kMaxGrisInputs];   // P(i)
  float drawnCount[kMaxGrisInputs];    // multiplicity of the d-th distinct canonical draw (domain count + d)
  uint32_t drawnPixel[kMaxGrisInputs];
  int distinct = 0;                    // distinct canonical draws
  float bigM = 0.0f;                   // M: the cell's candidates
  float scale = 1.0f;                  // N / M with confidence scaling, else 1 (§4.3)
  float cBar = 0.0f;                   // scaled Σ c_i over the cell
  Combination* c = nullptr;            // the pixel's combination
};

// Stochastic pairwise reuse, step 1 (seed 004 §3-5): pick a neighbour cell by weighted reservoir sampling, draw
// N contributing pixels of it by P(i) ∝ c_i p̂_i(X_i) W_i and N_c pixels uniformly. Consumes every random number
// of the pixel in a fixed layout; targets and rays come later, batched.
int32_t Pipeline::ChooseCell(size_t i, const GBuffer& g, const int32_t* searchCell, const float* searchPick) const {
  const SpatialParams& sp = settings_.spatial;
  const Vec3 n = g.GeometricNormal(i);
  // §5.1: similar cells under the search positions compete with weight = their confidence sum.
  int32_t chosen = -1;
  float cellWeightSum = 0.0f;
  for (int it = 0; it < sp.cellSearchIterations; ++it) {
    const int32_t c = searchCell[it];
    if (c < 0) continue;
    const Cell& cell = cells_[static_cast<size_t>(c)];
    if (cell.objectId != g.objectId[i] || glm::dot(cell.normal, n) < sp.normalThreshold) continue;
    if (!(cell.confidenceSum > 0.0f)) continue;
    cellWeightSum += cell.confidenceSum;
    if (searchPick[it] * cellWeightSum < cell.confidenceSum) chosen = c;
  }
  return chosen;
}

bool Pipeline::StochasticPairwiseDraws(size_t i, int32_t chosen, const std::vector<StoredReservoir>& input,
                                       Sampler& s, SpatialWork& work) const {
  const SpatialParams& sp = settings_.spatial;
  if (chosen < 0) return false;
  const Cell& cell = cells_[static_cast<size_t>(chosen)];

  // The cell's candidates, the current pixel excluded: all M of them, and the contributing ones with P(i).
  uint32_t candidates[kMaxCellPixels];
  float cumulative[kMaxCellPixels];
  uint32_t contributing[kMaxCellPixels];
  int m = 0, k = 0;
  float confidenceSum = 0.0f, contributionSum = 0.0f;
  for (uint32_t t = 0; t < cell.count; ++t) {
    const uint32_t p = cellPixels_[cell.first + t];
    if (p == i) continue;
    candidates[m++] = p;
    const StoredReservoir& r = input[p];
    confidenceSum += r.confidence;
    const float contribution = r.HasSample() ? r.confidence * r.targetPdf * r.W : 0.0f;  // Eq. 17
    if (contribution > 0.0f && std::isfinite(contribution)) {
      contributionSum += contribution;
      contributing[k] = p;
      cumulative[k++] = contributionSum;
    }
  }
  if (m == 0) return false;
  work.bigM = static_cast<float>(m);
  work.scale = sp.confidenceScaling ? static_cast<float>(sp.draws) / work.bigM : 1.0f;  // §4.3
  work.cBar = confidenceSum * work.scale;

  // Non-canonical: N draws with replacement by P(i); distinct draws become inputs with multiplicity K(i).
  Combination& c = *work.c;
  const StoredReservoir& self = input[i];
  c.Reset(static_cast<uint32_t>(i), 1, 0);
  c.AddDomain(0, static_cast<uint32_t>(i));
  c.samples[0] = SampleOf(self);
  c.inputs[0] = InputOf(self, self.confidence);
  for (int d = 0; d < sp.draws; ++d) {
    const float u = s.Next();
    if (k == 0) continue;
    const int idx = SampleCumulative(cumulative, k, u);
    const uint32_t p = contributing[idx];
    int slot = 1;
    while (slot < c.count && c.domainPixel[slot] != p) ++slot;
    if (slot == c.count) {
      const StoredReservoir& r = input[p];
      work.multiplicity[slot] = 0.0f;
      work.probability[slot] = (cumulative[idx] - (idx > 0 ? cumulative[idx - 1] : 0.0f)) / contributionSum;
      c.samples[slot] = SampleOf(r);
      c.inputs[slot] = InputOf(r, r.confidence * work.scale);
      ++c.count;
      for (int j = 0; j < slot; ++j) c.state[j][slot] = Entry::kUnknown;
      c.AddDomain(0, p);
    }
    work.multiplicity[slot] += 1.0f;
  }
  // Canonical: N_c uniform draws (P_c = 1/M), always consumed so every pixel's stream has the same layout.
  work.distinct = 0;
  for (int d = 0; d < sp.canonicalDraws; ++d) {
    const uint32_t p = candidates[std::min(m - 1, static_cast<int>(s.Next() * work.bigM))];
    int slot = 0;
    while (slot < work.distinct && work.drawnPixel[slot] != p) ++slot;
    if (slot == work.distinct) work.drawnPixel[work.distinct] = p, work.drawnCount[work.distinct++] = 0.0f;
    work.drawnCount[slot] += 1.0f;
  }
  for (int t = 0; t < c.count; ++t) c.u[t] = s.Next();
  return true;
}

// Screen-space cells (seed 004 §5): each tile's surface pixels grouped by (object id, quantised normal), built
// sequentially in tile and scan order so the lists never depend on the thread count.
void Pipeline::BuildCells(const GBuffer& g, const std::vector<StoredReservoir>& reservoirs) {
  const SpatialParams& sp = settings_.spatial;
  const int w = g.width, h = g.height, tile = std::max(1, sp.cellTile);
  const int tilesX = (w + tile - 1) / tile, tilesY = (h + tile - 1) / tile;
  cells_.clear();
  cellPixels_.clear();
  pixelCell_.assign(g.Size(), -1);
  std::vector<std::pair<uint32_t, uint32_t>> members;  // (cell, pixel) for one tile
  for (int ty = 0; ty < tilesY; ++ty) {
    for (int tx = 0; tx < tilesX; ++tx) {
      const uint32_t tileIndex = static_cast<uint32_t>(ty * tilesX + tx);
      const size_t firstCell = cells_.size();
      members.clear();
      for (int y = ty * tile; y < std::min(h, (ty + 1) * tile); ++y) {
        for (int x = tx * tile; x < std::min(w, (tx + 1) * tile); ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i)) continue;
          const uint32_t q = QuantiseNormal(g.GeometricNormal(i), static_cast<uint32_t>(sp.normalBins));
          const uint32_t key = CellKey(tileIndex, static_cast<uint32_t>(g.objectId[i]), q);
          size_t c = firstCell;
          while (c < cells_.size() && !(cells_[c].key == key && cells_[c].objectId == g.objectId[i])) ++c;
          if (c == cells_.size()) {
            Cell cell;
            cell.objectId = g.objectId[i];
            cell.key = key;
            cells_.push_back(cell);
          }
          cells_[c].normal += g.GeometricNormal(i);
          cells_[c].confidenceSum += reservoirs[i].confidence;
          cells_[c].count += 1;
          members.emplace_back(static_cast<uint32_t>(c), static_cast<uint32_t>(i));
        }
      }
      // Lay the tile's cells out contiguously, each in scan order.
      for (size_t c = firstCell; c < cells_.size(); ++c) {
        cells_[c].first = static_cast<uint32_t>(cellPixels_.size());
        cells_[c].normal = glm::normalize(cells_[c].normal);
        for (const auto& [cell, pixel] : members)
          if (cell == c) {
            cellPixels_.push_back(pixel);
            pixelCell_[pixel] = static_cast<int32_t>(c);
          }
      }
    }
  }
}

FrameResult Pipeline::RenderFrame(const FrameInputs& in) {
  const GBuffer& g = *in.gbuffer;
  const int w = g.width, h = g.height;
  const size_t n = g.Size();
  reservoirs_.assign(n, StoredReservoir{});
  FrameResult result;
  result.image = ImageRgb(w, h);
  result.temporalAccepted.assign(n, 0);
  const Camera& camera = in.state->camera;
  const InitialSamplingParams& ip = settings_.initial;
  const TemporalParams& tp = settings_.temporal;
  const SpatialParams& spp = settings_.spatial;
  const std::vector<LightTriangle>& lights = in.scene->LightTriangles();
  const bool carryVisibility = settings_.shade.visibility != VisibilityReuse::kNone;
  const VisibilityCarry carry = CarryFor(settings_.shade.visibility);
  const RisMaterials materials = MakeRisMaterials(*in.materials);
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  tbb::enumerable_thread_specific<BatchScratch> scratch;
  tbb::enumerable_thread_specific<ShadowRayBatch> initialRays;
  // The pass's share of the target and GRIS kernel work (the scratch's counters run across passes).
  uint64_t targetsSoFar = 0, combinedSoFar = 0;
  auto kernelWork = [&](PassStats& ps) {
    uint64_t targets = 0, combined = 0;
    for (const BatchScratch& sc : scratch) targets += sc.evaluator.Evaluated(), combined += sc.combine.Combined();
    ps.targets = targets - targetsSoFar;
    ps.combinations = combined - combinedSoFar;
    targetsSoFar = targets, combinedSoFar = combined;
  };
  tbb::combinable<uint64_t> risPixels([] { return uint64_t{0}; });

  // Initial sampling: streaming RIS over M candidates from the light sampler (seed 003 §1).
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  auto t0 = std::chrono::steady_clock::now();
  // The RIS itself runs in the SIMD kernel (core/ris_kernel.h) a row at a time, on the target core/simd.h
  // selects; every target gives the same bits. The row's visibility rays go to Embree as one batch.
  const RisParams risParams{in.seed, in.frame, static_cast<uint32_t>(RngPass::kInitial), ip.candidates};
  const bool haveLights = !in.lights->Empty();
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    const size_t rw = static_cast<size_t>(w);
    // Row inputs the G-buffer does not hold as arrays: wo and the surface mask.
    std::vector<float> woRow[3];
    for (auto& v : woRow) v.resize(rw);
    std::vector<uint8_t> activeRow(rw, 0);
    for (size_t x = 0; x < rw; ++x) {
      const size_t i = rowStart + x;
      if (!g.IsSurface(i) || !haveLights) continue;
      activeRow[x] = 1;
      const Vec3 wo = glm::normalize(camera.position - g.Position(i));  // as ShadingPointAt
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
    px.materialId = g.materialId.data() + rowStart;
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
    if (haveLights) RisInitialSampling(px, in.lights->Soa(), materials, risParams, ro);
    risPixels.local() += static_cast<uint64_t>(std::count(activeRow.begin(), activeRow.end(), uint8_t{1}));
    std::vector<Reservoir> row(rw);
    ShadowRayBatch& shadowRays = initialRays.local();
    shadowRays.Clear();
    std::vector<uint32_t> rayPixel;
    for (size_t x = 0; x < rw; ++x) {
      if (!activeRow[x]) continue;
      Reservoir& r = row[x];
      r.sample.lightId = static_cast<uint32_t>(outId[x]);
      r.sample.position = Vec3(outF[0][x], outF[1][x], outF[2][x]);
      r.sample.normal = Vec3(outF[3][x], outF[4][x], outF[5][x]);
      r.sample.radiance = Vec3(outF[6][x], outF[7][x], outF[8][x]);
      r.sample.pdfArea = outF[9][x];
      r.weightSum = outF[10][x];
      r.targetPdf = outF[11][x];
      FinalizeRis(r, static_cast<float>(ip.candidates));
      // An initial reservoir counts one frame of history (DESIGN §4), or its candidates (seed 003).
      if (!ip.countCandidates) r.confidence = 1.0f;
      if (ip.visibility && r.HasSample()) {
        const size_t i = rowStart + x;
        shadowRays.Add(g, i, r.sample.position, r.sample.normal, lights[r.sample.lightId].errorScale);
        rayPixel.push_back(static_cast<uint32_t>(x));
      }
    }
    if (shadowRays.Size() > 0) {
      const std::vector<uint8_t>& occluded = shadowRays.Trace(*in.scene, SceneFrame::kCurrent);
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
        r.confidence = ip.countCandidates ? static_cast<float>(ip.candidates) : 1.0f;
      }
      reservoirs_[rowStart + x] = Store(r);
    }
  });
  result.passes.push_back({"initial", MsSince(t0), rays.combine(std::plus<uint64_t>())});
  result.passes.back().risPixels = risPixels.combine(std::plus<uint64_t>());

  // Batches of up to kBatchPixels pixels of a row, in order.
  auto forEachBatch = [&](auto&& f) {
    const int batchesPerRow = (w + kBatchPixels - 1) / kBatchPixels;
    tbb::parallel_for(tbb::blocked_range<int>(0, h * batchesPerRow), [&](const tbb::blocked_range<int>& r) {
      for (int b = r.begin(); b < r.end(); ++b) {
        const int y = b / batchesPerRow, x0 = (b % batchesPerRow) * kBatchPixels;
        f(y, x0, std::min(w, x0 + kBatchPixels));
      }
    });
  };

  // Temporal reuse (seed 003 §3-5; DESIGN §4): the previous reservoir at the reprojected pixel, validated,
  // confidence-capped, combined with the current one by GRIS.
  const bool haveHistory = tp.enabled && in.previousGbuffer && in.previousState &&
                           previousReservoirs_.size() == n && in.previousGbuffer->Size() == n;
  if (tp.enabled) {
    tbb::combinable<uint64_t> trays([] { return uint64_t{0}; });
    tbb::combinable<uint64_t> crossObject([] { return uint64_t{0}; });
    t0 = std::chrono::steady_clock::now();
    // RTXDI permutation sampling: one XOR pattern per frame, so neighbouring pixels read different history.
    const RngKey frameKey{in.seed, in.frame, 0xFFFFFFFFu, static_cast<uint32_t>(RngPass::kTemporal)};
    const uint32_t permBits = tp.permutation ? (RandomBits(frameKey, 0) & 3u) : 0u;
    const MisFamily family = EffectiveFamily(tp.mis, tp.bias);
    if (haveHistory) {
      const GBuffer& pg = *in.previousGbuffer;
      const FrameView views[2] = {{&g, camera.position, &lights, SceneFrame::kCurrent},
                                  {&pg, in.previousState->camera.position, in.previousLights,
                                   SceneFrame::kPrevious}};
      forEachBatch([&](int y, int x0, int x1) {
        uint64_t& localRays = trays.local();
        BatchScratch& sc = scratch.local();
        std::vector<Combination>& combos = sc.combinations;
        std::vector<int>& order = sc.order;
        TargetEvaluator& ev = sc.evaluator;
        ev.Bind(views, materials, *in.scene, tp.bias == BiasCorrection::kRayTraced);
        int count = 0;
        for (int x = x0; x < x1; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!g.IsSurface(i) || !g.prevValid[i]) continue;
          int px = std::clamp(static_cast<int>(std::floor(g.prevX[i])), 0, w - 1);
          int py = std::clamp(static_cast<int>(std::floor(g.prevY[i])), 0, h - 1);
          size_t pi = static_cast<size_t>(py) * w + px;
          if (permBits) {
            const int qx = std::clamp(px ^ static_cast<int>(permBits & 1u), 0, w - 1);
            const int qy = std::clamp(py ^ static_cast<int>(permBits >> 1), 0, h - 1);
            const size_t qi = static_cast<size_t>(qy) * w + qx;
            if (pg.objectId[qi] == pg.objectId[pi] && SimilarSurface(pg, pi, pg, qi, 0.9f, 0.1f)) pi = qi;
          }
          const StoredReservoir& prev = previousReservoirs_[pi];
          if (!FiniteReservoir(prev) || !pg.IsSurface(pi)) continue;
          if (tp.sampleChecks && !prev.HasSample()) continue;
          const StoredReservoir& cur = reservoirs_[i];
          order[count] = count;
          Combination& c = combos[count++];
          c.Reset(static_cast<uint32_t>(i), 2, 0);
          c.AddDomain(0, static_cast<uint32_t>(i));
          c.AddDomain(1, static_cast<uint32_t>(pi));
          c.samples[0] = SampleOf(cur);
          c.samples[1] = SampleOf(prev);
          c.inputs[0] = InputOf(cur, cur.confidence);
          c.inputs[1] = InputOf(prev, std::min(prev.confidence, tp.maxHistory));
          const RngKey key{in.seed, in.frame, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kTemporal)};
          c.u[0] = UniformFloat(key, 0);
          c.u[1] = UniformFloat(key, 1);
          if (tp.sampleChecks) ev.Request(c, 0, 1);
        }
        // seed 003's sample tests need p̂_c(Y_prev) before anything else is evaluated.
        if (tp.sampleChecks) {
          ev.Resolve(localRays);
          int kept = 0;
          for (int k = 0; k < count; ++k) {
            const Combination& c = combos[order[k]];
            const float t01 = c.target[0][1];
            if (!(t01 > 0.0f)) continue;
            if (tp.targetRatioClamp) {
              const float prevTarget = previousReservoirs_[c.domainPixel[1]].targetPdf;
              const float ratio = prevTarget > 0.0f ? t01 / prevTarget : 0.0f;
              if (!(ratio >= 0.1f && ratio <= 10.0f)) continue;
            }
            order[kept++] = order[k];
          }
          count = kept;
        }
        for (int k = 0; k < count; ++k) RequestCanonicalTargets(combos[order[k]], ev);
        ev.Resolve(localRays);
        for (int k = 0; k < count; ++k) RequestFamilyTargets(combos[order[k]], family, carry, ev);
        ev.Resolve(localRays);
        sc.combine.Fill(combos.data(), order.data(), count, true);
        sc.combine.Combine(family, carry);
        for (int k = 0; k < count; ++k) {
          Combination& c = combos[order[k]];
          const size_t i = c.pixel;
          if (pg.objectId[c.domainPixel[1]] != g.objectId[i]) crossObject.local() += 1;
          const GrisResult gr = sc.combine.Result(k);
          guarded.local() += static_cast<uint64_t>(gr.guarded);
          reservoirs_[i] = OutputOf(c, gr, gr.confidence);
          result.temporalAccepted[i] = 1;
        }
      });
    }
    result.crossObjectReuse = crossObject.combine(std::plus<uint64_t>());
    result.passes.push_back({"temporal", MsSince(t0), trays.combine(std::plus<uint64_t>())});
    kernelWork(result.passes.back());
  }

  // Spatial reuse (DESIGN §4): k random neighbours in a disk, similarity-tested, combined by GRIS with the
  // pixel's own reservoir as the canonical input; more neighbours where temporal reuse failed. Each iteration
  // reads this frame's buffer and writes last frame's (temporal reuse has read it by now), then they swap.
  if (spp.enabled) {
    tbb::combinable<uint64_t> srays([] { return uint64_t{0}; });
    t0 = std::chrono::steady_clock::now();
    const MisFamily family = EffectiveFamily(spp.mis, spp.bias);
    const bool stochastic = family == MisFamily::kStochasticPairwise;
    const bool rayTraced = spp.bias == BiasCorrection::kRayTraced;
    const FrameView views[1] = {{&g, camera.position, &lights, SceneFrame::kCurrent}};
    std::vector<StoredReservoir>& output = previousReservoirs_;
    for (int iteration = 0; iteration < spp.iterations; ++iteration) {
      const std::vector<StoredReservoir>& input = reservoirs_;
      output.resize(n);
      if (stochastic) BuildCells(g, input);
      forEachBatch([&](int y, int x0, int x1) {
        uint64_t& localRays = srays.local();
        BatchScratch& sc = scratch.local();
        std::vector<Combination>& combos = sc.combinations;
        TargetEvaluator& ev = sc.evaluator;
        ev.Bind(views, materials, *in.scene, rayTraced);
        SpatialWork work[kBatchPixels];
        // Neighbours are random pixels up to `radius` away, so their G-buffer and reservoir lines miss the
        // cache: pick every pixel's neighbours first and prefetch their lines, so the misses overlap instead of
        // stalling the similarity tests one at a time.
        int32_t neighbour[kBatchPixels][kMaxGrisInputs];
        int neighbourCount[kBatchPixels];
        if (!stochastic) {
          for (int x = x0; x < x1; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            int& k = neighbourCount[x - x0];
            k = 0;
            if (!g.IsSurface(i)) continue;
            const bool boost = tp.enabled && !result.temporalAccepted[i];
            k = std::min(boost ? spp.disocclusionNeighbours : spp.neighbours, kMaxGrisInputs - 1);
            Sampler s(RngKey{in.seed, in.frame, static_cast<uint32_t>(i),
                             static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)});
            for (int t = 0; t < k; ++t) {
              // Uniform point in a disk of the given radius (polar map), rounded to a pixel.
              const float r = spp.radius * std::sqrt(s.Next());
              const float phi = 2.0f * kPi * s.Next();
              const int nx = x + static_cast<int>(std::lround(r * std::cos(phi)));
              const int ny = y + static_cast<int>(std::lround(r * std::sin(phi)));
              int32_t& ni = neighbour[x - x0][t];
              ni = -1;
              if (nx < 0 || ny < 0 || nx >= w || ny >= h || (nx == x && ny == y)) continue;
              ni = ny * w + nx;
              for (const auto* a : {&g.posX, &g.posY, &g.posZ, &g.ngX, &g.ngY, &g.ngZ, &g.nsX, &g.nsY, &g.nsZ,
                                    &g.depth})
                __builtin_prefetch(a->data() + ni);
              __builtin_prefetch(g.objectId.data() + ni);
              __builtin_prefetch(g.materialId.data() + ni);
              __builtin_prefetch(reinterpret_cast<const char*>(input.data() + ni));
              __builtin_prefetch(reinterpret_cast<const char*>(input.data() + ni) + sizeof(StoredReservoir) - 1);
            }
          }
        }
        if (stochastic) {
          // The cell search reads random pixels up to hundreds of pixels away, then their cells, then the chosen
          // cell's reservoirs: three dependent cache misses per search. Each stage runs over the whole batch and
          // prefetches what the next one reads, so the misses overlap.
          const int iterations = spp.cellSearchIterations;
          for (int x = x0; x < x1; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            int32_t* q = sc.searchCell.data() + static_cast<size_t>(x - x0) * iterations;
            float* pick = sc.searchPick.data() + static_cast<size_t>(x - x0) * iterations;
            if (!g.IsSurface(i)) continue;
            Sampler s(RngKey{in.seed, in.frame, static_cast<uint32_t>(i),
                             static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)});
            float radius = spp.cellSearchRadius;
            for (int it = 0; it < iterations; ++it, radius *= spp.cellSearchGrowth) {
              const float r = radius * std::sqrt(s.Next()), phi = 2.0f * kPi * s.Next();
              pick[it] = s.Next();
              const int qx = x + static_cast<int>(std::lround(r * std::cos(phi)));
              const int qy = y + static_cast<int>(std::lround(r * std::sin(phi)));
              q[it] = qx < 0 || qy < 0 || qx >= w || qy >= h ? -1 : qy * w + qx;
              if (q[it] >= 0) __builtin_prefetch(pixelCell_.data() + q[it]);
            }
          }
          for (int x = x0; x < x1; ++x) {
            if (!g.IsSurface(static_cast<size_t>(y) * w + x)) continue;
            int32_t* q = sc.searchCell.data() + static_cast<size_t>(x - x0) * iterations;
            for (int it = 0; it < iterations; ++it) {
              if (q[it] >= 0) q[it] = pixelCell_[static_cast<size_t>(q[it])];
              if (q[it] >= 0) __builtin_prefetch(cells_.data() + q[it]);
            }
          }
          for (int x = x0; x < x1; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            int32_t& chosen = sc.chosenCell[x - x0];
            chosen = -1;
            if (!g.IsSurface(i)) continue;
            chosen = ChooseCell(i, g, sc.searchCell.data() + static_cast<size_t>(x - x0) * iterations,
                                sc.searchPick.data() + static_cast<size_t>(x - x0) * iterations);
            if (chosen < 0) continue;
            const Cell& cell = cells_[static_cast<size_t>(chosen)];
            for (uint32_t t = 0; t < cell.count; ++t)
              __builtin_prefetch(reinterpret_cast<const char*>(input.data() + cellPixels_[cell.first + t]) +
                                 offsetof(StoredReservoir, targetPdf));
          }
        }
        int count = 0;
        for (int x = x0; x < x1; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          output[i] = input[i];  // kept unless a combination below replaces it
          if (!g.IsSurface(i)) continue;
          const RngKey key{in.seed, in.frame, static_cast<uint32_t>(i),
                           static_cast<uint32_t>(RngPass::kSpatial) + 16u * static_cast<uint32_t>(iteration)};
          Combination& c = combos[count];
          if (stochastic) {
            work[count].c = &c;
            // The search used the first three dimensions of each iteration.
            Sampler s(key, 3u * static_cast<uint32_t>(spp.cellSearchIterations));
            if (!StochasticPairwiseDraws(i, sc.chosenCell[x - x0], input, s, work[count])) continue;
            // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
            if (carryVisibility)
              for (int t = 1; t < c.count; ++t)
                if (c.inputs[t].hasSample) ev.RequestVisibility(c, t);
            ++count;
            continue;
          }
          const int k = neighbourCount[x - x0];
          const StoredReservoir& self = input[i];
          c.Reset(static_cast<uint32_t>(i), 1, 0);
          c.AddDomain(0, static_cast<uint32_t>(i));
          c.samples[0] = SampleOf(self);
          c.inputs[0] = InputOf(self, self.confidence);
          for (int t = 0; t < k; ++t) {
            if (neighbour[x - x0][t] < 0) continue;
            const size_t ni = static_cast<size_t>(neighbour[x - x0][t]);
            if (!g.IsSurface(ni) || !SimilarSurface(g, i, g, ni, spp.normalThreshold, spp.depthThreshold)) continue;
            const StoredReservoir& nr = input[ni];
            if (!FiniteReservoir(nr)) continue;
            const int slot = c.count++;
            for (int j = 0; j < slot; ++j) c.state[j][slot] = Entry::kUnknown;
            c.AddDomain(0, static_cast<uint32_t>(ni));
            c.samples[slot] = SampleOf(nr);
            c.inputs[slot] = InputOf(nr, nr.confidence);
            // Seed 000 Algorithm 1: a spatial neighbour's visibility is re-traced from this pixel.
            if (carryVisibility && nr.HasSample()) ev.RequestVisibility(c, slot);
          }
          if (c.count == 1) continue;
          Sampler s(key, 2u * static_cast<uint32_t>(k));  // after the neighbours' two dimensions each
          for (int t = 0; t < c.count; ++t) c.u[t] = s.Next();
          ++count;
        }
        if (!stochastic) {
          for (int k = 0; k < count; ++k) RequestCanonicalTargets(combos[k], ev);
          ev.Resolve(localRays);
          for (int k = 0; k < count; ++k) RequestFamilyTargets(combos[k], family, carry, ev);
          ev.Resolve(localRays);
          sc.combine.Fill(combos.data(), nullptr, count, true);
          sc.combine.Combine(family, carry);
          for (int k = 0; k < count; ++k) {
            Combination& c = combos[k];
            const GrisResult gr = sc.combine.Result(k);
            guarded.local() += static_cast<uint64_t>(gr.guarded);
            output[c.pixel] = OutputOf(c, gr, gr.confidence);
          }
          return;
        }
        // Stochastic pairwise (seed 004 Eq. 15-19): p̂_c of every input first; then, where the canonical sample
        // can contribute, its target in each canonically drawn pixel, and p̂_i(Y_i) where p̂_c(Y_i) > 0.
        for (int k = 0; k < count; ++k) {
          Combination& c = combos[k];
          for (int t = 0; t < c.count; ++t)
            if (c.inputs[t].hasSample) ev.Request(c, 0, t);
        }
        ev.Resolve(localRays);
        for (int k = 0; k < count; ++k) {
          Combination& c = combos[k];
          const SpatialWork& wk = work[k];
          if (c.inputs[0].hasSample && c.target[0][0] > 0.0f) {
            for (int d = 0; d < wk.distinct; ++d) {
              c.AddDomain(0, wk.drawnPixel[d]);
              ev.Request(c, c.domains - 1, 0);
            }
          }
          for (int t = 1; t < c.count; ++t)
            if (c.inputs[t].hasSample && c.target[0][t] > 0.0f) ev.Request(c, t, t);
        }
        ev.Resolve(localRays);
        // The weights of seed 004 Eq. 15-19 for the whole batch in the SIMD kernel (core/spmis_kernel.h), written
        // where the resampling kernel reads them.
        sc.combine.Fill(combos.data(), nullptr, count, false);
        GrisBatchArrays& a = sc.combine.Arrays();
        StochasticPairwiseArrays& sw = sc.spmis;
        sw.Resize(a, spp.canonicalDraws);
        auto known = [](const Combination& c, int j, int i) {
          return c.state[j][i] == Entry::kKnown ? c.target[j][i] : 0.0f;  // others are never read
        };
        for (int k = 0; k < count; ++k) {
          const Combination& c = combos[k];
          const SpatialWork& wk = work[k];
          sw.distinct[k] = wk.distinct;
          sw.cBar[k] = wk.cBar;
          sw.drawCount[k] = static_cast<float>(spp.draws);
          sw.canonicalDrawCount[k] = static_cast<float>(spp.canonicalDraws);
          sw.candidateCount[k] = wk.bigM;
          for (int t = 0; t < c.count; ++t) {
            const size_t e = sw.At(t, static_cast<size_t>(k));
            sw.canonicalTarget[e] = known(c, 0, t);
            if (t == 0) continue;
            sw.multiplicity[e] = wk.multiplicity[t];
            sw.probability[e] = wk.probability[t];
            sw.ownTarget[e] = known(c, t, t);
          }
          for (int d = 0; d < wk.distinct; ++d) {
            const size_t e = sw.DrawAt(d, static_cast<size_t>(k));
            sw.drawnMultiplicity[e] = wk.drawnCount[d];
            sw.drawnConfidence[e] = input[wk.drawnPixel[d]].confidence * wk.scale;
            sw.drawnTarget[e] = c.domains > c.count + d ? known(c, c.count + d, 0) : 0.0f;
          }
        }
        StochasticPairwiseWeights(sw.View(a), StochasticPairwiseOutputInto(a));
        sc.combine.Resample(carry);
        for (int k = 0; k < count; ++k) {
          const Combination& c = combos[k];
          const GrisResult gr = sc.combine.Result(k);
          guarded.local() += static_cast<uint64_t>(gr.guarded);
          // The canonical plus the (scaled) cell it stands for.
          output[c.pixel] = OutputOf(c, gr, c.inputs[0].confidence + work[k].cBar);
        }
      });
      std::swap(reservoirs_, output);
    }
    result.passes.push_back({"spatial", MsSince(t0), srays.combine(std::plus<uint64_t>())});
    kernelWork(result.passes.back());
  }

  // Shading: f(Y) W with a final shadow ray, or f_unshadowed(Y) V W with the carried visibility (seed 000
  // Algorithm 1), plus what the primary ray sees directly. f comes from the target kernel, the row's shadow rays
  // go to Embree as one batch.
  tbb::combinable<uint64_t> shadeTargets([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> shadeRays([] { return uint64_t{0}; });
  t0 = std::chrono::steady_clock::now();
  struct ShadeScratch {
    std::vector<float> soa[kTargetPairFields], target, f[3];
    std::vector<int32_t> mat;
    std::vector<uint32_t> pixelOf, rayOf;
    ShadowRayBatch shadowRays;
  };
  tbb::enumerable_thread_specific<ShadeScratch> shadeScratch;
  ForEachRow(h, [&](int y) {
    const size_t rowStart = static_cast<size_t>(y) * w;
    ShadeScratch& sc = shadeScratch.local();
    auto& [soa, target, f, mat, pixelOf, rayOf, shadowRays] = sc;
    for (auto& v : soa) v.clear();
    mat.clear();
    pixelOf.clear();
    rayOf.clear();
    shadowRays.Clear();
    for (int x = 0; x < w; ++x) {
      const size_t i = rowStart + static_cast<size_t>(x);
      const StoredReservoir& r = reservoirs_[i];
      if (!(g.IsSurface(i) && r.HasSample() && r.lightId < lights.size())) continue;
      const Vec3& radiance = lights[r.lightId].radiance;
      const float fields[kTargetPairFields] = {camera.position.x, camera.position.y, camera.position.z, g.posX[i], g.posY[i],
                                g.posZ[i],         g.ngX[i],          g.ngY[i],          g.ngZ[i],  g.nsX[i],
                                g.nsY[i],          g.nsZ[i],          r.position.x,      r.position.y, r.position.z,
                                r.normal.x,        r.normal.y,        r.normal.z,        radiance.x, radiance.y,
                                radiance.z};
      for (int f = 0; f < kTargetPairFields; ++f) soa[f].push_back(fields[f]);
      mat.push_back(g.materialId[i]);
      pixelOf.push_back(static_cast<uint32_t>(x));
    }
    const size_t m = pixelOf.size();
    shadeTargets.local() += m;
    target.resize(m);
    for (auto& v : f) v.resize(m);
    if (m > 0) {
      const float* fields[kTargetPairFields];
      for (int k = 0; k < kTargetPairFields; ++k) fields[k] = soa[k].data();
      const TargetPairs pairs = MakeTargetPairs(fields, mat.data(), m);
      TargetResults out;
      out.target = target.data();
      for (int c = 0; c < 3; ++c) out.contribution[c] = f[c].data();
      EvaluateTargets(pairs, materials, out);
    }
    if (!carryVisibility) {
      for (size_t k = 0; k < m; ++k) {
        if (!(f[0][k] > 0.0f || f[1][k] > 0.0f || f[2][k] > 0.0f)) continue;
        const size_t i = rowStart + pixelOf[k];
        shadowRays.Add(g, i, reservoirs_[i], lights);
        rayOf.push_back(static_cast<uint32_t>(k));
      }
      const std::vector<uint8_t>& occluded = shadowRays.Trace(*in.scene, SceneFrame::kCurrent);
      shadeRays.local() += occluded.size();
      for (size_t r = 0; r < occluded.size(); ++r)
        if (occluded[r]) f[0][rayOf[r]] = f[1][rayOf[r]] = f[2][rayOf[r]] = 0.0f;
    }
    size_t k = 0;
    for (int x = 0; x < w; ++x) {
      const size_t i = rowStart + static_cast<size_t>(x);
      Vec3 c = DirectEmission(g, i, lights);
      if (k < m && pixelOf[k] == static_cast<uint32_t>(x)) {
        const StoredReservoir& r = reservoirs_[i];
        Vec3 fx(f[0][k], f[1][k], f[2][k]);
        if (carryVisibility) fx *= r.visibility;
        c += fx * r.W;
        ++k;
      }
      if (!IsFinite(c)) {
        guarded.local() += 1;
        c = Vec3(0.0f);
      }
      result.image.pixels[i] = c;
    }
  });
  result.passes.push_back({"shade", MsSince(t0), shadeRays.combine(std::plus<uint64_t>())});
  result.passes.back().targets = shadeTargets.combine(std::plus<uint64_t>());
  result.guardedEvents = guarded.combine(std::plus<uint64_t>());

  // Counters, in pixel order (deterministic).
  size_t surfaces = 0, accepted = 0;
  double confidence = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!g.IsSurface(i)) continue;
    ++surfaces;
    accepted += result.temporalAccepted[i];
    confidence += reservoirs_[i].confidence;
  }
  result.temporalAcceptance = surfaces ? double(accepted) / double(surfaces) : 0.0;
  result.meanConfidence = surfaces ? confidence / double(surfaces) : 0.0;
  std::swap(previousReservoirs_, reservoirs_);
  return result;
}

}  // namespace restir
