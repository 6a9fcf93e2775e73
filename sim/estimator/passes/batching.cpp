#include "sim/estimator/passes/batching.h"

#include "core/shadow_ray_kernel.h"

namespace restir {

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

LightSample SampleOf(const StoredReservoir& r) {
  LightSample y;
  y.lightId = r.lightId;
  y.position = r.position;
  y.normal = r.normal;
  y.radiance = Vec3(0.0f);
  return y;
}

bool SimilarSurface(const GBuffer& a, size_t i, const GBuffer& b, size_t j, float normalThreshold,
                    float depthThreshold) {
  if (b.objectId[j] < 0 || b.materialId[j] < 0) return false;
  if (glm::dot(a.GeometricNormal(i), b.GeometricNormal(j)) < normalThreshold) return false;
  const float da = a.depth[i], db = b.depth[j];
  return std::abs(da - db) <= depthThreshold * std::max(da, db);
}

// ---- TargetPairBuffer

void TargetPairBuffer::Grow() {
  const size_t n = std::max<size_t>(256, 2 * material_.size());
  for (auto& f : field_) f.resize(n);
  material_.resize(n);
}

void TargetPairBuffer::Evaluate(const BsdfSoa& materials, float* target, float* const* contribution) const {
  if (Size() == 0) return;
  const float* fields[kTargetPairFields];
  for (int f = 0; f < kTargetPairFields; ++f) fields[f] = field_[f].data();
  TargetResults results;
  results.target = target;
  if (contribution)
    for (int c = 0; c < 3; ++c) results.contribution[c] = contribution[c];
  EvaluateTargets(MakeTargetPairs(fields, material_.data(), Size()), materials, results);
}

// ---- ShadowRayBatch

void ShadowRayBatch::Add(const GBuffer& g, size_t pixel, const Vec3& y, const Vec3& lightNormal,
                         float lightErrorScale) {
  if (size_ == in_[0].size())  // grow all arrays together; they keep their capacity from batch to batch
    for (auto& v : in_) v.resize(std::max<size_t>(256, 2 * size_));
  const size_t k = size_++;
  in_[0][k] = g.posX[pixel], in_[1][k] = g.posY[pixel], in_[2][k] = g.posZ[pixel];
  in_[3][k] = g.ngX[pixel], in_[4][k] = g.ngY[pixel], in_[5][k] = g.ngZ[pixel];
  in_[6][k] = y.x, in_[7][k] = y.y, in_[8][k] = y.z;
  in_[9][k] = lightNormal.x, in_[10][k] = lightNormal.y, in_[11][k] = lightNormal.z;
  in_[12][k] = g.errorScale[pixel], in_[13][k] = lightErrorScale;
}

const std::vector<uint8_t>& ShadowRayBatch::Trace(const EmbreeScene& scene, SceneFrame frame) {
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

// ---- TargetEvaluator

void TargetEvaluator::Bind(const DomainFrame* views, const BsdfSoa& materials, const EmbreeScene& scene,
                           bool visibility, bool previousSampleVisible) {
  views_ = views;
  materials_ = &materials;
  scene_ = &scene;
  visibility_ = visibility;
  previousSampleVisible_ = previousSampleVisible;
  pending_.clear();
  visibilityPending_.clear();
}

void TargetEvaluator::Resolve(uint64_t& rays) {
  const size_t n = pending_.size();
  evaluated_ += n;
  pairs_.Clear();
  for (const Pending& e : pending_) {
    const DomainFrame& v = views_[e.c->view[e.j]];
    const LightSample& y = e.c->samples[e.i];
    const size_t p = e.c->domainPixel[e.j];
    LightPoint lp{};  // always filled: Request queues only samples whose light this frame has
    LightPointAt(v.gbuffer->Position(p), y.lightId, y.position, y.normal, *v.lights, v.sky, lp);
    pairs_.Add(v.eye, *v.gbuffer, p, lp.position, lp.normal, lp.radiance);
  }
  values_.resize(n);
  pairs_.Evaluate(*materials_, values_.data());
  // Shadow rays: positive entries when targets include visibility, and the neighbours' visibility re-tests.
  for (int f = 0; f < 2; ++f) rays_[f].Clear(), rayRefs_[f].clear();
  for (size_t k = 0; k < n; ++k) {
    if (!(visibility_ && values_[k] > 0.0f)) continue;
    const Pending& e = pending_[k];
    if (previousSampleVisible_ && e.j == 1 && e.i == 1) continue;
    const DomainFrame& v = views_[e.c->view[e.j]];
    const int f = v.scene == SceneFrame::kCurrent ? 0 : 1;
    const LightSample& y = e.c->samples[e.i];
    const size_t p = e.c->domainPixel[e.j];
    LightPoint lp{};  // always filled, as above
    LightPointAt(v.gbuffer->Position(p), y.lightId, y.position, y.normal, *v.lights, nullptr, lp);
    rays_[f].Add(*v.gbuffer, p, lp.position, lp.normal, lp.errorScale);
    rayRefs_[f].push_back(static_cast<int64_t>(k));
  }
  for (size_t k = 0; k < visibilityPending_.size(); ++k) {
    const Pending& e = visibilityPending_[k];
    const DomainFrame& v = views_[e.c->view[0]];
    const LightSample& y = e.c->samples[e.i];
    const size_t p = e.c->domainPixel[0];
    LightPoint lp;
    if (!LightPointAt(v.gbuffer->Position(p), y.lightId, y.position, y.normal, *v.lights, nullptr, lp)) {
      e.c->inputs[e.i].visibility = 0.0f;  // a light removed in that frame: nothing to see
      continue;
    }
    rays_[0].Add(*v.gbuffer, p, lp.position, lp.normal, lp.errorScale);
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

void RequestCanonicalTargets(Combination& c, TargetEvaluator& ev) {
  for (int i = 0; i < c.count; ++i) {
    const GrisInput& in = c.inputs[i];
    if (in.hasSample && in.W > 0.0f && IsFiniteWeight(in.W)) ev.Request(c, 0, i);
  }
}

void RequestFamilyTargets(Combination& c, MisFamily family, VisibilityCarry carry, TargetEvaluator& ev) {
  auto record = [&](int j, int i) {
    if (c.state[j][i] == Entry::kKnown) return c.target[j][i];
    ev.Request(c, j, i);
    return 0.0f;
  };
  GrisCombine(family, c.inputs, c.count, record, c.u, carry);
}

void CombineFamilyBatch(BatchScratch& sc, const int* order, int count, MisFamily family, VisibilityCarry carry,
                        uint64_t& rays) {
  std::vector<Combination>& combos = sc.combinations;
  TargetEvaluator& ev = sc.evaluator;
  for (int k = 0; k < count; ++k) RequestCanonicalTargets(combos[order ? order[k] : k], ev);
  ev.Resolve(rays);
  for (int k = 0; k < count; ++k) RequestFamilyTargets(combos[order ? order[k] : k], family, carry, ev);
  ev.Resolve(rays);
  sc.combine.Fill(combos.data(), order, count, true);
  sc.combine.Combine(family, carry);
}

// ---- CombineBatch

void CombineBatch::Fill(const Combination* combos, const int* order, int count, bool matrix) {
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

void CombineBatch::Combine(MisFamily family, VisibilityCarry carry) {
  combined_ += arrays_.count;
  GrisCombineBatch(family, carry, arrays_.View(), Output());
}

void CombineBatch::Resample(VisibilityCarry carry) {
  combined_ += arrays_.count;
  GrisResampleBatch(carry, arrays_.View(), Output());
}

GrisResult CombineBatch::Result(int k) const {
  GrisResult r;
  r.selected = selected_[k];
  r.weightSum = weightSum_[k];
  r.W = W_[k];
  r.confidence = confidence_[k];
  r.visibility = visibility_[k];
  r.guarded = guarded_[k];
  return r;
}

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
    out.history = c.history[gr.selected];
  }
  return out;
}

}  // namespace restir
