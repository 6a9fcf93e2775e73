#include "sim/reference/reference_paths.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <functional>
#include <limits>

#include "core/bsdf.h"
#include "core/light_sampler.h"
#include "core/shading.h"
#include "core/shadow_ray.h"
#include "sim/assets/texture.h"
#include "sim/scene/shading_point.h"
#include "sim/scene/sky_frame.h"

namespace restir {

namespace {

// Each light triangle's share of the frame's power (core/light_sampler.h); empty where no light has power.
std::vector<float> PowerPmf(const std::vector<LightTriangle>& lights) {
  const LightSampler power(lights, LightSelection::kPower);
  std::vector<float> pmf;
  for (uint32_t l = 0; l < lights.size() && !power.Empty(); ++l) pmf.push_back(power.SelectionPmf(l));
  return pmf;
}

// Per light group, the cumulative of its triangles' shares of the power.
std::vector<float> CumulativePower(const std::vector<float>& pmf, const LightGroups& groups) {
  std::vector<float> cdf = pmf.empty() ? std::vector<float>() : GroupShares(pmf, groups);
  float sum = 0.0f;
  for (float& c : cdf) c = sum += c;
  return cdf;
}

}  // namespace

PathScene::PathScene(const Sequence& sequence, const EmbreeScene& scene, const Sky& sky)
    : sequence_(sequence),
      scene_(scene),
      lights_(scene.LightTriangles()),
      sky_(sky),
      summary_(sky.Empty() ? SkySummary{} : SummarizeSky(sky)),
      materialBsdfs_(MaterialBsdfs(sequence)),
      groups_(MakeLightGroups(lights_)) {
  const std::vector<float> pmf = PowerPmf(lights_);
  powerCdf_ = CumulativePower(pmf, groups_);
  powerDistribution_ = PixelLightDistribution(powerCdf_.data(), &groups_, -1.0f);
  if (!pmf.empty() && groups_.first.size() <= kMaxVertexSelectionGroups)
    selection_ = MakeSelectionLights(lights_, groups_, pmf);
}

PixelLightDistribution PathScene::VertexDistribution(const ShadingPoint& x, std::vector<float>& cdf) const {
  if (selection_.empty()) return powerDistribution_;
  const size_t n = selection_.size();
  cdf.resize(2 * n);
  float* w = cdf.data() + n;
  double total = 0.0;
  for (size_t g = 0; g < n; ++g) {
    const SelectionLight& light = selection_[g];
    const float cosX = glm::dot(x.shadingNormal, glm::normalize(light.centroid - x.position));
    w[g] = TileLightWeight(x.position, light) * std::max(0.0f, cosX);
    if (!(w[g] <= std::numeric_limits<float>::max())) w[g] = 0.0f;
    total += w[g];
  }
  if (!(total > 0.0)) return powerDistribution_;
  const float keep = 1.0f - kDefensivePowerShare;
  float sum = 0.0f;
  for (size_t g = 0; g < n; ++g)
    cdf[g] = sum += keep * static_cast<float>(w[g] / total) + kDefensivePowerShare * selection_[g].powerPmf;
  return PixelLightDistribution(cdf.data(), &groups_, -1.0f);
}

ShadingPoint PathScene::Vertex(const SurfaceHit& hit, const Vec3& dir) const {
  ShadingPoint sp;
  sp.position = hit.position;
  sp.geometricNormal = hit.geometricNormal;
  sp.shadingNormal = hit.shadingNormal;
  sp.wo = -dir;
  sp.errorScale = hit.errorScale;
  const Material& m = sequence_.materials[static_cast<size_t>(hit.materialId)];
  const int32_t t = m.baseColorTexture;
  sp.bsdf = t >= 0 && static_cast<size_t>(t) < sequence_.textures.size()
                ? MaterialBsdf(m, m.albedo * SampleBilinear(sequence_.textures[static_cast<size_t>(t)],
                                                            hit.texcoord.x, hit.texcoord.y))
                : materialBsdfs_[static_cast<size_t>(hit.materialId)];
  return sp;
}

namespace {

// The direction a step takes from x and its solid-angle density: by x's BSDF, or by the one-sample mixture of the
// BSDF and a guide (kGuideBsdfShare: ub[0] below it draws by the BSDF, rescaled; above it by the guide). The
// mixture's density is the same function of the direction whichever strategy drew it.
BsdfSample StepDirection(const ShadingPoint& x, const float* ub, const DirectionGuide* guide) {
  if (!guide || guide->Empty()) return SampleBsdf(x.bsdf, x.shadingNormal, x.wo, ub[0], ub[1]);
  BsdfSample s;
  if (ub[0] < kGuideBsdfShare) {
    s = SampleBsdf(x.bsdf, x.shadingNormal, x.wo, ub[0] / kGuideBsdfShare, ub[1]);
    if (!(s.pdf > 0.0f)) return s;
  } else {
    s.wi = guide->Sample(std::min((ub[0] - kGuideBsdfShare) / (1.0f - kGuideBsdfShare), 0.99999994f), ub[1]);
  }
  s.pdf = kGuideBsdfShare * PdfBsdf(x.bsdf, x.shadingNormal, x.wo, s.wi) +
          (1.0f - kGuideBsdfShare) * guide->Pdf(s.wi);
  return s;
}

}  // namespace

bool PathScene::Step(ShadingPoint& x, const float* ub, Vec3& throughput, float* pdfArea, uint64_t& rays,
                     const DirectionGuide* guide, Vec3* direction) const {
  const BsdfSample bs = StepDirection(x, ub, guide);
  if (!(bs.pdf > 0.0f) || !(glm::dot(x.geometricNormal, bs.wi) > 0.0f)) return false;
  if (direction) *direction = bs.wi;
  const float cosRay = glm::dot(x.shadingNormal, bs.wi);
  if (!(cosRay > 0.0f)) return false;
  const Vec3 fRay = EvalBsdf(x.bsdf, x.shadingNormal, x.wo, bs.wi);
  if (!(fRay.x > 0.0f || fRay.y > 0.0f || fRay.z > 0.0f)) return false;
  const Vec3 org = OffsetRayOrigin(x.position, x.geometricNormal, x.errorScale, bs.wi);
  const SurfaceHit hit = scene_.Intersect(org, bs.wi, std::numeric_limits<float>::infinity());
  ++rays;
  // What an escape or an emitter sends along the ray is x's direct light, which x's own next-event sample (or, at
  // x₁, the direct-light reference) takes: never added here. An emitter with a material is a surface as well, and
  // the path goes on from it (Light::material); one without, and an escape, end the path.
  if (!hit.hit || hit.materialId < 0) return false;
  // The ray left from the spawn offset, not from x (1 mm off at 1 km from the origin): the vertex it found has
  // the area density p_ω |n_y · ω| / ‖y − org‖², and the step's value is the integrand of the vertices x and y
  // themselves, f_r(x, ω_xy) cos θ_x |n_y · ω_xy| / ‖y − x‖² (area measure). Weighing the ray's direction as if
  // it had left x instead biases a path by the offset over the scene's size: measured +0.4% at 1 km and +3% at
  // 10 km in a 1 m integrating sphere (tests/sim/reference/reference_paths_test.cpp).
  const Vec3 fromOrigin = hit.position - org, fromX = hit.position - x.position;
  const float rayD2 = glm::dot(fromOrigin, fromOrigin), d2 = glm::dot(fromX, fromX);
  const float d = std::sqrt(d2);
  if (!(d > kMinLightDistance) || !(rayD2 > 0.0f)) return false;
  const Vec3 w = fromX / d;
  const float cosX = glm::dot(x.shadingNormal, w);
  const float cosYRay = std::fabs(glm::dot(hit.geometricNormal, bs.wi));
  const float cosY = std::fabs(glm::dot(hit.geometricNormal, w));
  if (!(cosX > 0.0f) || !(glm::dot(x.geometricNormal, w) > 0.0f) || !(cosYRay > 0.0f)) return false;
  const float density = bs.pdf * cosYRay / rayD2;
  throughput *= EvalBsdf(x.bsdf, x.shadingNormal, x.wo, w) * ((cosX * cosY / d2) / density);
  if (!(throughput.x > 0.0f || throughput.y > 0.0f || throughput.z > 0.0f)) return false;
  if (pdfArea) *pdfArea = density;
  x = Vertex(hit, w);
  return true;
}

bool PathScene::NextEvent(const ShadingPoint& x, const float* u, SampleBatch& scratch, Vec3& value,
                          uint64_t& rays) const {
  const bool hasLocal = !powerCdf_.empty() && powerCdf_.back() > 0.0f;
  SkySampling sampling;
  if (!sky_.Empty()) {
    sampling.sky = &sky_;
    const float sunEstimate = SunEstimate(x, sky_, summary_);
    const float environmentEstimate = EnvironmentEstimate(x, sky_, summary_);
    const float skyEstimate = std::max(0.0f, sunEstimate) + std::max(0.0f, environmentEstimate);
    sampling.mixture = MixLightStrategies(hasLocal ? skyEstimate : -1.0f, sunEstimate, environmentEstimate);
  } else if (!hasLocal) {
    return false;
  }
  // SkySamples' layout: coordinate j of its one sample at u[j].
  float v[3] = {0.0f, 0.0f, 0.0f};
  float* const out[3] = {&v[0], &v[1], &v[2]};
  SkySamples(x, scene_, lights_, VertexDistribution(x, scratch.vertexCdf), sampling, u, 1, scratch, out, rays);
  value = Vec3(v[0], v[1], v[2]);
  return true;
}

Vec3 PathScene::IndirectSample(const ShadingPoint& x1, int bounces, const float* u, SampleBatch& scratch,
                               uint64_t& rays, const DirectionGuide* guide, Vec3* firstDirection) const {
  Vec3 sum(0.0f), throughput(1.0f), light(0.0f);
  ShadingPoint x = x1;
  for (int bounce = 0; bounce < bounces; ++bounce) {
    const float* ub = u + static_cast<size_t>(bounce) * kBounceDims;
    // The next vertex by the BSDF at x (throughput f cos θ / p, the path's weight in solid angle; the first by the
    // guide's mixture where there is one), then its direct light: one sample of the reference's light and BSDF
    // strategies, combined by the power heuristic.
    const bool first = bounce == 0;
    if (!Step(x, ub, throughput, nullptr, rays, first ? guide : nullptr, first ? firstDirection : nullptr) ||
        !NextEvent(x, ub + 2, scratch, light, rays))
      break;
    sum += throughput * light;
  }
  return sum;
}

PathScene::FirstVertex PathScene::SecondaryVertexSample(const ShadingPoint& x1, int bounces, const float* u,
                                                        SampleBatch& scratch, uint64_t& rays) const {
  FirstVertex v;
  ShadingPoint x = x1;
  float pdfArea = 0.0f;
  Vec3 first(1.0f);
  if (bounces <= 0 || !Step(x, u, first, &pdfArea, rays)) return v;
  v.throughput = first;
  // x is x₂: what the rest of the path delivers there, in the same operations as IndirectSample from x₂ on.
  v.vertex.position = x.position;
  v.vertex.normal = x.geometricNormal;
  v.vertex.shadingNormal = x.shadingNormal;
  v.vertex.errorScale = x.errorScale;
  v.vertex.pdfArea = pdfArea;
  v.reconnectable = Reconnectable(x.bsdf);
  // A Lambertian x₂ reflects the same towards every direction in front of its shading hemisphere: L_o is taken
  // for that front (as seen along the shading normal), and whether x₁ or a pixel the vertex is shifted to lies in
  // front is asked of each receiver (InFrontOfVertex). The path's own value is then the same: 0 behind.
  if (v.reconnectable) x.wo = x.shadingNormal;
  Vec3 throughput(1.0f), light(0.0f);
  for (int bounce = 0; bounce < bounces; ++bounce) {
    const float* ub = u + static_cast<size_t>(bounce) * kBounceDims;
    if (bounce > 0 && !Step(x, ub, throughput, nullptr, rays)) break;
    if (!NextEvent(x, ub + 2, scratch, light, rays)) break;
    v.vertex.radiance += throughput * light;
  }
  return v;
}

namespace {

// One path a pixel over the frame's surface pixels (RngPass::kIndirect, keyed by seed, frame and pixel): `body(paths,
// x1, u, scratch, rays, i)` for each, rows in parallel. Counts the rays.
template <typename Body>
void ForEachPixelPath(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene, const GBuffer& g,
                      int bounces, uint32_t seed, uint32_t frame, uint64_t& rays, Body&& body) {
  const Sky sky = MakeSky(sequence, state);
  const PathScene paths(sequence, scene, sky);
  const BsdfSoa bsdfs = FrameBsdfTable(MaterialBsdfs(sequence), sequence.materials, g, nullptr);
  tbb::combinable<uint64_t> rayCount{[] { return uint64_t{0}; }};
  tbb::parallel_for(tbb::blocked_range<int>(0, g.height), [&](const tbb::blocked_range<int>& rows) {
    SampleBatch scratch;
    std::vector<float> u(static_cast<size_t>(bounces) * kBounceDims);
    uint64_t& r = rayCount.local();
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < g.width; ++x) {
        const size_t i = static_cast<size_t>(y) * g.width + x;
        if (!g.IsSurface(i)) continue;
        PathRandomNumbers(seed, frame, static_cast<uint32_t>(i), 0, RngPass::kIndirect, bounces, u.data());
        body(paths, ShadingPointAt(g, i, state.camera.position, bsdfs), u.data(), scratch, r, i);
      }
  });
  rays += rayCount.combine(std::plus<uint64_t>());
}

}  // namespace

ImageRgb IndirectImage(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                       const GBuffer& g, int bounces, uint32_t seed, uint32_t frame, uint64_t& rays) {
  ImageRgb image(g.width, g.height);
  if (bounces <= 0) return image;
  bounces = std::min(bounces, kMaxIndirectBounces);
  ForEachPixelPath(sequence, state, scene, g, bounces, seed, frame, rays,
                   [&](const PathScene& paths, const ShadingPoint& x1, const float* u, SampleBatch& scratch,
                       uint64_t& r, size_t i) { image.pixels[i] = paths.IndirectSample(x1, bounces, u, scratch, r); });
  return image;
}

IndirectVertices SecondaryVertices(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                                   const GBuffer& g, int bounces, uint32_t seed, uint32_t frame, uint64_t& rays) {
  IndirectVertices out;
  out.vertices.assign(g.Size(), SecondaryVertex{});
  out.unshifted = ImageRgb(g.width, g.height);
  if (bounces <= 0) return out;
  bounces = std::min(bounces, kMaxIndirectBounces);
  ForEachPixelPath(sequence, state, scene, g, bounces, seed, frame, rays,
                   [&](const PathScene& paths, const ShadingPoint& x1, const float* u, SampleBatch& scratch,
                       uint64_t& r, size_t i) {
                     const PathScene::FirstVertex v = paths.SecondaryVertexSample(x1, bounces, u, scratch, r);
                     if (v.reconnectable)
                       out.vertices[i] = v.vertex;
                     else
                       out.unshifted.pixels[i] = v.throughput * v.vertex.radiance;
                   });
  return out;
}

void PathRandomNumbers(uint32_t seed, uint32_t stateKey, uint32_t pixel, uint32_t path, RngPass pass,
                       int bounces, float* u) {
  // The path's index moves the key's frame word by an odd constant: a bijection of the index for a fixed
  // state, so no two paths of a frame share a key.
  const RngKey key{seed, stateKey + path * 0x9E3779B9u, pixel, static_cast<uint32_t>(pass)};
  const int n = bounces * kBounceDims;
  for (int j = 0; j < n; ++j) u[j] = UniformFloat(key, static_cast<uint32_t>(j));
}

}  // namespace restir
