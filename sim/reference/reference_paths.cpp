#include "sim/reference/reference_paths.h"

#include <limits>

#include "core/bsdf.h"
#include "core/shadow_ray.h"
#include "sim/assets/texture.h"
#include "sim/scene/shading_point.h"

namespace restir {

namespace {

std::vector<float> CumulativePower(const std::vector<float>& groupPowerPmf) {
  std::vector<float> cdf(groupPowerPmf.size());
  float sum = 0.0f;
  for (size_t g = 0; g < groupPowerPmf.size(); ++g) cdf[g] = sum += groupPowerPmf[g];
  return cdf;
}

}  // namespace

PathScene::PathScene(const Sequence& sequence, const EmbreeScene& scene, const LightGroups& groups,
                     const std::vector<float>& groupPowerPmf, const Sky& sky, const SkySummary& summary)
    : sequence_(sequence),
      scene_(scene),
      lights_(scene.LightTriangles()),
      sky_(sky),
      summary_(summary),
      materialBsdfs_(MaterialBsdfs(sequence)),
      powerCdf_(CumulativePower(groupPowerPmf)),
      powerDistribution_(powerCdf_.data(), &groups, -1.0f) {}

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

Vec3 PathScene::IndirectSample(const ShadingPoint& x1, int bounces, const float* u, SampleBatch& scratch,
                               uint64_t& rays) const {
  const bool hasLocal = !powerCdf_.empty() && powerCdf_.back() > 0.0f;
  const bool hasSky = !sky_.Empty();
  Vec3 sum(0.0f), throughput(1.0f);
  ShadingPoint x = x1;
  for (int bounce = 0; bounce < bounces; ++bounce) {
    const float* ub = u + static_cast<size_t>(bounce) * kBounceDims;
    // The next vertex by the BSDF at x (throughput f cos θ / p, the path's weight in solid angle).
    const BsdfSample bs = SampleBsdf(x.bsdf, x.shadingNormal, x.wo, ub[0], ub[1]);
    if (!(bs.pdf > 0.0f) || !(glm::dot(x.geometricNormal, bs.wi) > 0.0f)) break;
    const float cosX = glm::dot(x.shadingNormal, bs.wi);
    if (!(cosX > 0.0f)) break;
    throughput *= EvalBsdf(x.bsdf, x.shadingNormal, x.wo, bs.wi) * (cosX / bs.pdf);
    if (!(throughput.x > 0.0f || throughput.y > 0.0f || throughput.z > 0.0f)) break;
    const Vec3 org = OffsetRayOrigin(x.position, x.geometricNormal, x.errorScale, bs.wi);
    const SurfaceHit hit = scene_.Intersect(org, bs.wi, std::numeric_limits<float>::infinity());
    ++rays;
    // An escape or an emitter: what it sends along the ray is x's direct light, which x's own next-event sample
    // (or, at x₁, the direct-light reference) takes; neither reflects.
    if (!hit.hit || hit.materialId < 0) break;
    x = Vertex(hit, bs.wi);
    // x's direct light: one sample of the reference's light and BSDF strategies, combined by the power heuristic.
    SkySampling sampling;
    if (hasSky) {
      sampling.sky = &sky_;
      const float sunEstimate = SunEstimate(x, sky_, summary_);
      const float environmentEstimate = EnvironmentEstimate(x, sky_, summary_);
      const float skyEstimate = std::max(0.0f, sunEstimate) + std::max(0.0f, environmentEstimate);
      sampling.mixture = MixLightStrategies(hasLocal ? skyEstimate : -1.0f, sunEstimate, environmentEstimate);
    } else if (!hasLocal) {
      break;
    }
    // SkySamples' layout: coordinate j of its one sample at u[j].
    float value[3] = {0.0f, 0.0f, 0.0f};
    float* const out[3] = {&value[0], &value[1], &value[2]};
    SkySamples(x, scene_, lights_, powerDistribution_, sampling, ub + 2, 1, scratch, out, rays);
    sum += throughput * Vec3(value[0], value[1], value[2]);
  }
  return sum;
}

void PathRandomNumbers(uint32_t seed, uint32_t stateKey, uint32_t pixel, uint32_t path, RngPass pass, int bounces,
                       float* u) {
  // The path's index moves the key's frame word by an odd constant: a bijection of the index for a fixed state,
  // so no two paths of a frame share a key.
  const RngKey key{seed, stateKey + path * 0x9E3779B9u, pixel, static_cast<uint32_t>(pass)};
  const int n = bounces * kBounceDims;
  for (int j = 0; j < n; ++j) u[j] = UniformFloat(key, static_cast<uint32_t>(j));
}

}  // namespace restir
