#include "sim/estimator/passes/candidate_sources.h"

#include "core/rng.h"
#include "core/shadow_ray.h"

namespace restir {

namespace {

// Dimensions of RngPass::kInitialSources per candidate: a sun direction takes 3, an environment direction 5, a
// BSDF direction 3. Each source starts at its own multiple of kSourceStride, so changing one count never moves
// another source's numbers (the local lights' come from the RIS kernel's own pass).
constexpr uint32_t kSourceStride = 1u << 16;
constexpr uint32_t kSunBase = kSourceStride, kEnvironmentBase = 2 * kSourceStride, kBrdfBase = 3 * kSourceStride;

// p_bsdf of the direction to a light point (0 when the BSDF cannot produce it).
float BsdfPdfTowards(const ShadingPoint& sp, const Vec3& wi) { return PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, wi); }

// Σ_t M_t p_t(y) of a point on local light `lightId` seen from the receiver (core/candidates.h MixedPointPdf).
float PointPdf(const ShadingPoint& sp, const CandidateCounts& m, float brdfCutoff, const LightSampler& lights,
               uint32_t lightId, const Vec3& position, const Vec3& normal) {
  const float lightPdf = m.local > 0 ? lights.PdfArea(lightId) : 0.0f;
  float brdfPdf = 0.0f;
  if (m.brdf > 0) {
    const LightPath path = ConnectToLight(sp, position, normal);
    if (path.geometry > 0.0f)
      brdfPdf = BrdfAreaPdf(BsdfPdfTowards(sp, path.wi), -glm::dot(normal, path.wi), path.distance, brdfCutoff);
  }
  return MixedPointPdf(m, lightPdf, brdfPdf);
}

// Σ_t M_t p_t(ω) of a direction to the sky (core/candidates.h MixedDirectionPdf).
float DirectionPdf(const ShadingPoint& sp, const CandidateCounts& m, const Sky& sky, const Vec3& w) {
  const float sun = m.sun > 0 ? sky.SunPdf(w) : 0.0f;
  const float environment = m.environment > 0 ? sky.EnvironmentPdf(w) : 0.0f;
  const float bsdf = m.brdf > 0 ? BsdfPdfTowards(sp, w) : 0.0f;
  return MixedDirectionPdf(m, sun, environment, bsdf);
}

// Streams candidate y (its target p̂ computed here) with weight p̂ / mixedPdf.
void Stream(Reservoir& r, const ShadingPoint& sp, const LightSample& y, float mixedPdf, float u) {
  const float target = TargetFunction(UnshadowedContribution(sp, y));
  StreamCandidate(r, y, target, MixedRisWeight(target, mixedPdf), u);
}

// Streams the sky direction ω: its target on the far point (core/sky.h SkyPointFor), the reservoir keeping the
// direction itself (StoredReservoir's position is ω for a sky sample; every pass rebuilds its own far point).
void StreamDirection(Reservoir& r, const ShadingPoint& sp, const Sky& sky, const Vec3& w, float mixedPdf, float u) {
  const Vec3 radiance = sky.Radiance(w);
  const float target = TargetFunction(UnshadowedContribution(sp, SkyPointFor(sp.position, w, radiance)));
  LightSample y;
  y.lightId = kSkyLightId;
  y.position = w;
  y.normal = -w;
  y.radiance = radiance;
  StreamCandidate(r, y, target, MixedRisWeight(target, mixedPdf), u);
}

}  // namespace

bool NeedsCandidateSources(const CandidateCounts& m) { return m.sun > 0 || m.environment > 0 || m.brdf > 0; }

Reservoir SampleCandidateSources(const FrameView& view, const LightSampler& lights, const CandidateCounts& m,
                                 float brdfCutoff, const ShadingPoint& sp, uint32_t pixel,
                                 const Reservoir* kernelLocal, uint64_t& rays) {
  const RngKey key{view.seed, view.frame, pixel, static_cast<uint32_t>(RngPass::kInitialSources)};
  auto u = [&](uint32_t d) { return UniformFloat(key, d); };
  const Sky& sky = view.sky;
  Reservoir r;
  // Local lights: the kernel's reservoir as one GRIS input (seed 000 Eq. 1-2; Lin et al. 2022). Its sample X has
  // the unbiased contribution weight W_l = wSum / (M_l p̂(X)); it enters with the MIS weight m_l(X) = M_l p_area(X) /
  // (M_l p_area(X) + M_b p_bsdf(X)), each BSDF candidate y with m_b(y) = p_bsdf(y) / (M_l p_area(y) + M_b p_bsdf(y)):
  // a partition of unity over the inputs that can produce a point (m_l + M_b m_b = 1), so the combination stays
  // unbiased, and p_bsdf is needed at one local point per pixel, not at every candidate. Its resampling weight
  // m_l(X) p̂(X) W_l = wSum p_area(X) / (M_l p_area(X) + M_b p_bsdf(X)), which is wSum / M_l without BSDF candidates.
  if (kernelLocal != nullptr && kernelLocal->weightSum > 0.0f && m.local > 0) {
    r.sample = kernelLocal->sample;
    r.targetPdf = kernelLocal->targetPdf;
    if (m.brdf == 0) {
      r.weightSum = kernelLocal->weightSum / static_cast<float>(m.local);
    } else {
      const LightSample& x = kernelLocal->sample;
      const float mixed = PointPdf(sp, m, brdfCutoff, lights, x.lightId, x.position, x.normal);
      r.weightSum = mixed > 0.0f ? kernelLocal->weightSum * (lights.PdfArea(x.lightId) / mixed) : 0.0f;
    }
  }
  for (int j = 0; j < m.sun; ++j) {
    const uint32_t d = kSunBase + 3u * static_cast<uint32_t>(j);
    float pdf;
    const Vec3 w = sky.SampleSun(u(d), u(d + 1), pdf);
    if (pdf > 0.0f) StreamDirection(r, sp, sky, w, DirectionPdf(sp, m, sky, w), u(d + 2));
  }
  for (int j = 0; j < m.environment; ++j) {
    const uint32_t d = kEnvironmentBase + 5u * static_cast<uint32_t>(j);
    float pdf;
    const Vec3 w = sky.SampleEnvironment(u(d), u(d + 1), u(d + 2), u(d + 3), pdf);
    if (pdf > 0.0f) StreamDirection(r, sp, sky, w, DirectionPdf(sp, m, sky, w), u(d + 4));
  }
  for (int j = 0; j < m.brdf; ++j) {
    const uint32_t d = kBrdfBase + 3u * static_cast<uint32_t>(j);
    const BsdfSample bs = SampleBsdf(sp.bsdf, sp.shadingNormal, sp.wo, u(d), u(d + 1));
    // A direction below the geometric surface cannot leave it: no candidate, but it counts in M_b.
    if (!(bs.pdf > 0.0f) || !(glm::dot(sp.geometricNormal, bs.wi) > 0.0f)) continue;
    const float maxDistance = BrdfRayMaxDistance(brdfCutoff, bs.pdf);
    ++rays;
    const Vec3 origin = OffsetRayOrigin(sp.position, sp.geometricNormal, sp.errorScale, bs.wi);
    const SurfaceHit hit = view.scene->Intersect(origin, bs.wi, maxDistance);
    if (hit.hit) {
      // An emitter seen from its front is a point on a local light; anything else hides what lies beyond.
      if (hit.lightId < 0 || !hit.frontFace) continue;
      const uint32_t id = static_cast<uint32_t>(hit.lightId);
      const LightTriangle& t = view.Lights()[id];
      LightSample y;
      y.lightId = id;
      y.position = hit.position;
      y.normal = t.normal;
      y.radiance = t.radiance;
      Stream(r, sp, y, PointPdf(sp, m, brdfCutoff, lights, id, y.position, y.normal), u(d + 2));
    } else if (!sky.Empty()) {
      StreamDirection(r, sp, sky, bs.wi, DirectionPdf(sp, m, sky, bs.wi), u(d + 2));
    }
  }
  r.W = MixedRisContributionWeight(r.weightSum, r.targetPdf);
  return r;
}

}  // namespace restir
