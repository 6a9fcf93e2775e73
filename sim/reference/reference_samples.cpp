#include "sim/reference/reference_samples.h"

#include <algorithm>
#include <limits>

#include "core/bsdf_draw_kernel.h"
#include "core/light_draw_kernel.h"
#include "core/shading.h"
#include "core/shadow_ray.h"

namespace restir {

namespace {

// The receiver as the light-draw kernels take it: sp, whose material is materialId in the frame's BsdfSoa.
LightDrawReceiver ReceiverOf(const ShadingPoint& sp, int32_t materialId, bool bsdfMis) {
  LightDrawReceiver r;
  r.position = sp.position;
  r.geometricNormal = sp.geometricNormal;
  r.shadingNormal = sp.shadingNormal;
  r.wo = sp.wo;
  r.errorScale = sp.errorScale;
  r.materialId = materialId;
  r.bsdfMis = bsdfMis;
  return r;
}

// The BSDF-sampling term of one sample (a direction from the BSDF at (u0, u1), weighted by the power heuristic
// against the light strategies' density where its ray lands), 0 where the ray finds no light; counts the ray. With
// sky.differenceSun the sun's radiance is left out (the difference estimator takes the sun by light sampling
// alone); sunPart, where set, gets the luminance of the part of the term the sun's radiance gave.
Vec3 BsdfTerm(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
              const PixelLightDistribution& dist, const SkySampling& sky, float u0, float u1, uint64_t& rays,
              float* sunPart) {
  const LightMixture& mix = sky.mixture;
  const BsdfSample bs = SampleBsdf(sp.bsdf, sp.shadingNormal, sp.wo, u0, u1);
  if (!(bs.pdf > 0.0f && glm::dot(sp.geometricNormal, bs.wi) > 0.0f)) return Vec3(0.0f);
  ++rays;
  const Vec3 org = OffsetRayOrigin(sp.position, sp.geometricNormal, sp.errorScale, bs.wi);
  const SurfaceHit hit = scene.IntersectEmitter(org, bs.wi, std::numeric_limits<float>::infinity());
  const float cosX = glm::dot(sp.shadingNormal, bs.wi);
  if (hit.hit && hit.lightId >= 0 && hit.frontFace && mix.local > 0.0f) {
    // An emitter: the light technique's density of this point, converted to solid angle.
    const LightTriangle& t = lights[static_cast<size_t>(hit.lightId)];
    const float cosY = -glm::dot(t.normal, bs.wi);
    const float pLight = dist.AreaDensity(static_cast<uint32_t>(hit.lightId)) * mix.local * hit.t * hit.t / cosY;
    const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
    if (cosY > 0.0f) return t.radiance * fr * (cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf);
  } else if (!hit.hit && sky.sky != nullptr) {
    // Escaped: the sky, at the density with which the light mixture draws this direction.
    const float pLight = SkyLightPdf(mix, *sky.sky, bs.wi);
    const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
    const float weight = cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf;
    if (sunPart) *sunPart = Luminance(sky.sky->SunRadiance(bs.wi) * fr * weight);
    const Vec3 radiance = sky.differenceSun ? sky.sky->EnvironmentRadiance(bs.wi) : sky.sky->Radiance(bs.wi);
    return radiance * fr * weight;
  }
  return Vec3(0.0f);
}

// Redraws the points of receiver p's draws of its differenced groups (ReceiverBlock::differenced) from each group's
// projected-solid-angle sampler instead of uniformly by area, after the light-draw kernel has drawn every sample: the
// group stays the one the kernel's u selected (probability P(g) from the receiver's cdf), the fraction of the group's
// step of the cdf that u fell on picks the sampler's fan triangle, and the two area coordinates the direction in it.
// The sample's light term becomes L_e f_r cos θ / (P(g) pdf), in solid angle; its shadow ray replaces the kernel's.
// The kernel's rays of the receiver are [rayBegin, rayEnd); returns the new end, the rays of the draws of other
// groups kept in order and the redrawn ones after them.
size_t RedrawDifferencedDraws(const ReceiverBlock& block, size_t p, const float* u, size_t n, size_t firstSample,
                              const std::vector<LightTriangle>& lightList, const LightDrawLights& lights,
                              BlockScratch& s, float* const (&out)[3], size_t rayBegin, size_t rayEnd) {
  const DifferencedGroups& d = block.differenced[p];
  const ShadingPoint& sp = block.points[p];
  const float* cdf = block.dists[p].Cdf();
  const size_t groups = lights.groups;
  const auto differencedIndex = [&](uint32_t g) -> int {
    const uint32_t* at = std::lower_bound(d.group, d.group + d.count, g);
    return at != d.group + d.count && *at == g ? static_cast<int>(at - d.group) : -1;
  };
  // The kernel's rays of the other groups' draws, compacted.
  size_t end = rayBegin;
  for (size_t r = rayBegin; r < rayEnd; ++r) {
    const size_t k = s.drawOf[r] - firstSample;
    if (differencedIndex(SampleCdf(cdf, groups, u[k])) >= 0) continue;
    for (std::vector<float>& v : s.drawn) v[end] = v[r];
    s.drawOf[end++] = s.drawOf[r];
  }
  const ProjectedSolidAngleSampler* samplers = block.DifferencedSamplers(p);
  const glm::dvec3 x(sp.position);
  const float total = cdf[groups - 1];
  for (size_t k = 0; k < n; ++k) {
    const uint32_t g = SampleCdf(cdf, groups, u[k]);
    const int j = differencedIndex(g);
    if (j < 0) continue;
    const size_t e = firstSample + k;
    for (int c = 0; c < 3; ++c) out[c][e] = 0.0f;
    const float before = g ? cdf[g - 1] : 0.0f;
    const float step = cdf[g] - before;
    const float pmf = CdfPmf(cdf, groups, g);
    if (!(step > 0.0f) || !(pmf > 0.0f)) continue;
    const double within = std::clamp(static_cast<double>((u[k] * total - before) / step), 0.0, 1.0);
    const PolygonDirection dir = SampleProjectedSolidAngle(samplers[j], within, u[n + k], u[2 * n + k]);
    if (!(dir.pdf > 0.0)) continue;
    const Vec3 wi(dir.w);
    const float cosX = glm::dot(sp.shadingNormal, wi);
    if (!(cosX > 0.0f) || !(glm::dot(sp.geometricNormal, wi) > 0.0f)) continue;
    const uint32_t first = lights.groupFirst[g];
    const LightTriangle& t = lightList[first];
    const Vec3 f = t.radiance * EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, wi) * cosX;
    if (!(f.x > 0.0f || f.y > 0.0f || f.z > 0.0f)) continue;
    const Vec3 term = f * static_cast<float>(1.0 / (static_cast<double>(pmf) * dir.pdf));
    for (int c = 0; c < 3; ++c) out[c][e] = term[c];
    const bool quad = lights.groupSplit[g] < 2.0f;
    const float errorScale = quad ? std::max(t.errorScale, lightList[first + 1].errorScale) : t.errorScale;
    const Vec3 y(x + dir.w * dir.distance);
    const ShadowRaySegment ray = ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y, t.normal, errorScale);
    for (int c = 0; c < 3; ++c) {
      s.drawn[c][end] = ray.org[c];
      s.drawn[3 + c][end] = ray.dir[c];
    }
    s.drawn[6][end] = ray.tmax;
    s.drawOf[end++] = static_cast<uint32_t>(e);
  }
  return end;
}

}  // namespace

// `count` direct-lighting samples at a receiver in a frame with a sky, from the points whose coordinate j is
// u[j * count + k] (kSkySampleDims coordinates): light sampling (a strategy from the receiver's mixture, then a
// light point or a sky direction from it) plus BSDF sampling, combined by the power heuristic (pbrt-v4
// PathIntegrator::SampleLd style, restricted to direct light); BSDF sampling on every surface, as a BSDF ray that
// escapes is the only way to reach the sky's directions the light mixture samples rarely. Sample k's value is
// (out[0][k], out[1][k], out[2][k]). Frames without a sky take SkylessBlockSamples.
void SkySamples(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
                const PixelLightDistribution& dist, const SkySampling& sky, const float* u, size_t count,
                SampleBatch& b, float* const (&out)[3], uint64_t& rays, const LightTermRecord& record) {
  const LightMixture& mix = sky.mixture;
  b.lightTerm.assign(count, Vec3(0.0f));
  b.occludedTerm.assign(count, Vec3(0.0f));
  b.bsdfTerm.assign(count, Vec3(0.0f));
  b.rays.clear();
  b.rayOf.clear();
  // While recording: the sun's part of each sample's light term where its ray arrives (luminance).
  const bool sunParts = record.sunPart != nullptr;
  std::vector<float>& lightSunPart = b.lightSunPart;
  if (sunParts) lightSunPart.assign(count, 0.0f);
  for (size_t k = 0; k < count; ++k) {
    const auto uk = [&](int j) { return u[static_cast<size_t>(j) * count + k]; };
    const LightStrategy strategy = ChooseLightStrategy(mix, uk(kStrategyDim));
    if (record.unshadowed) {
      record.strategy[k] = static_cast<uint8_t>(strategy);
      record.light[k] = kNoRecordedLight;
    }
    if (strategy == LightStrategy::kLocal && mix.local > 0.0f) {
      LightSample y;
      y.lightId = dist.Sample(uk(0));
      if (record.unshadowed) record.light[k] = y.lightId;
      const LightTriangle& lt = lights[y.lightId];
      y.position = SampleTrianglePoint(lt, uk(1), uk(2));
      y.normal = lt.normal;
      y.radiance = lt.radiance;
      y.pdfArea = dist.AreaDensity(y.lightId) * mix.local;
      const LightPath path = ConnectToLightOnPlane(sp, y.position, y.normal, lt.p0);
      const Vec3 f = ContributionAlong(sp, y.radiance, path);
      if ((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f) {
        const float pLight = y.pdfArea * path.distance * path.distance / path.cosY;
        const float weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi));
        b.lightTerm[k] = f * (weight / y.pdfArea);
        const ShadowRaySegment s =
            ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal, lt.errorScale);
        b.rays.push_back(ShadowRay{s.org, s.dir, s.tmax});
        b.rayOf.push_back(static_cast<uint32_t>(k));
      }
    } else if (strategy != LightStrategy::kLocal) {
      // A sky direction: the integrand is Sky::Radiance(ω) f_r cos θ, evaluated through the far point that stands
      // for ω (core/sky.h SkyPointFor), its density the mixture's over every sky strategy
      // (sim/reference/reference_sky.h). Under the sun's difference estimator (SkySampling::differenceSun) the sun's
      // part is taken apart: its term, −(sun's part) / p with no MIS weight, counts where the ray is occluded.
      const Vec3 w = SampleSkyStrategy(*sky.sky, strategy, uk(0), uk(kCoinDim), uk(1), uk(2));
      const float pLight = SkyLightPdf(mix, *sky.sky, w);
      const Vec3 radiance = sky.differenceSun ? sky.sky->EnvironmentRadiance(w) : sky.sky->Radiance(w);
      const LightSample y = SkyPointFor(sp.position, w, radiance);
      const Vec3 f = UnshadowedContribution(sp, y);
      Vec3 fSun(0.0f);
      if (sky.differenceSun || sunParts)
        fSun = UnshadowedContribution(sp, SkyPointFor(sp.position, w, sky.sky->SunRadiance(w)));
      const bool light = f.x > 0.0f || f.y > 0.0f || f.z > 0.0f;
      const bool sun = sky.differenceSun && (fSun.x > 0.0f || fSun.y > 0.0f || fSun.z > 0.0f);
      if ((light || sun) && pLight > 0.0f) {
        const float weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, w));
        b.lightTerm[k] = f * (weight / pLight);
        if (sun) b.occludedTerm[k] = fSun * (-1.0f / pLight);
        if (sunParts) lightSunPart[k] = Luminance(fSun * (weight / pLight));
        // The far point's own error scale is its distance, which ShadowRaySetup adds already.
        const ShadowRaySegment s =
            ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal, 0.0f);
        b.rays.push_back(ShadowRay{s.org, s.dir, s.tmax});
        b.rayOf.push_back(static_cast<uint32_t>(k));
      }
    }
    float bsdfSunPart = 0.0f;
    b.bsdfTerm[k] = BsdfTerm(sp, scene, lights, dist, sky, uk(3), uk(4), rays, sunParts ? &bsdfSunPart : nullptr);
    if (sunParts) record.sunPart[k] = bsdfSunPart;
  }
  b.occluded.resize(b.rays.size());
  scene.OccludedBatch(b.rays.data(), b.occluded.data(), b.rays.size());
  rays += b.rays.size();
  for (size_t k = 0; k < count; ++k)
    for (int c = 0; c < 3; ++c) out[c][k] = b.bsdfTerm[k][c];
  if (record.unshadowed) {
    for (size_t k = 0; k < count; ++k) {
      record.unshadowed[k] = Luminance(b.lightTerm[k]);
      record.visible[k] = 0;
    }
    for (size_t r = 0; r < b.rays.size(); ++r) record.visible[b.rayOf[r]] = !b.occluded[r];
  }
  for (size_t r = 0; r < b.rays.size(); ++r) {
    const uint32_t k = b.rayOf[r];
    if (b.occluded[r] && !sky.differenceSun) continue;
    const Vec3 v = (b.occluded[r] ? b.occludedTerm[k] : b.lightTerm[k]) + b.bsdfTerm[k];
    for (int c = 0; c < 3; ++c) out[c][k] = v[c];
    if (sunParts && !b.occluded[r]) record.sunPart[k] += lightSunPart[k];
  }
}

// The direct-lighting samples of a block of receivers in a frame without a sky: receiver p's counts[p] samples
// from the points at u + uFirst[p] (SkySamples' layout, kSampleDims coordinates), into out + first[p]. Light
// sampling from each receiver's distribution, plus, at a receiver that is not diffuse, BSDF sampling with the power
// heuristic. The light half is the light-draw kernel (a packet of draws per register, its MIS weight included),
// every receiver's shadow rays then traced as one batch; the BSDF half the BSDF-draw kernel, each of its rays asking
// EmbreeScene::FirstEmitter. Reads coordinates 0-2 at a diffuse receiver, 0-4 at others; out[c] is the block's
// samples' channel c.
void SkylessBlockSamples(const ReceiverBlock& block, const size_t* counts, const size_t* uFirst, const size_t* first,
                         const EmbreeScene& scene, const BsdfSoa& materials,
                         const std::vector<LightTriangle>& lightList, const LightDrawLights& lights, BlockScratch& s,
                         float* const (&out)[3], uint64_t& rays) {
  const size_t total = first[block.count - 1] + counts[block.count - 1];
  for (std::vector<float>& v : s.drawn) v.resize(total);
  s.drawOf.resize(total);
  size_t written = 0;
  size_t rayFirst[kSelectionBlock + 1];  // receiver p's rays are [rayFirst[p], rayFirst[p + 1])
  for (size_t p = 0; p < block.count; ++p) {
    rayFirst[p] = written;
    const ShadingPoint& sp = block.points[p];
    const float* u = s.u.data() + uFirst[p];
    const size_t n = counts[p];
    LightDraws draws;
    draws.uSelect = u;
    draws.uPoint0 = u + n;
    draws.uPoint1 = u + 2 * n;
    draws.count = n;
    LightDrawOutputs o;
    for (int c = 0; c < 3; ++c) {
      o.term[c] = out[c] + first[p];
      o.org[c] = s.drawn[c].data() + written;
      o.dir[c] = s.drawn[3 + c].data() + written;
    }
    o.tmax = s.drawn[6].data() + written;
    o.draw = s.drawOf.data() + written;
    o.firstDraw = static_cast<uint32_t>(first[p]);  // the block's sample index
    // The kernel writes every draw's term, and packs the rays of the draws that can count.
    const size_t kernelEnd =
        written + DrawLightSamples(ReceiverOf(sp, block.materialId[p], sp.bsdf.type != BsdfType::kDiffuse),
                                   materials, lights, block.dists[p].Cdf(), draws, o);
    written = block.differenced[p].count > 0 && block.projectedSolidAngleDraws
                  ? RedrawDifferencedDraws(block, p, u, n, first[p], lightList, lights, s,
                                           out, written, kernelEnd)
                  : kernelEnd;
  }
  rayFirst[block.count] = written;
  ShadowRaysSoa shadowRays;
  for (int c = 0; c < 3; ++c) {
    shadowRays.org[c] = s.drawn[c].data();
    shadowRays.dir[c] = s.drawn[3 + c].data();
  }
  shadowRays.tmax = s.drawn[6].data();
  shadowRays.count = written;
  s.occluded.resize(written);
  scene.OccludedBatch(shadowRays, s.occluded.data());
  rays += written;
  if (s.record) {
    for (size_t p = 0; p < block.count; ++p)
      for (size_t k = 0; k < counts[p]; ++k) {
        const size_t e = first[p] + k;
        s.recordUnshadowed[e] = Luminance(Vec3(out[0][e], out[1][e], out[2][e]));
        s.recordVisible[e] = 0;
        s.recordLight[e] = block.dists[p].Sample(s.u[uFirst[p] + k]);
        s.recordStrategy[e] = static_cast<uint8_t>(LightStrategy::kLocal);
      }
    for (size_t r = 0; r < written; ++r) s.recordVisible[s.drawOf[r]] = !s.occluded[r];
  }
  // The light term stays where its ray is unoccluded; a differenced group's becomes its negative where the ray is
  // occluded and 0 where it is not.
  for (size_t p = 0; p < block.count; ++p) {
    const DifferencedGroups& d = block.differenced[p];
    for (size_t r = rayFirst[p]; r < rayFirst[p + 1]; ++r) {
      const size_t e = s.drawOf[r];
      bool differenced = false;
      if (d.count > 0) {
        const PixelLightDistribution& dist = block.dists[p];
        const uint32_t group = dist.GroupOf(dist.Sample(s.u[uFirst[p] + (e - first[p])]));
        differenced = std::binary_search(d.group, d.group + d.count, group);
      }
      if (differenced)
        for (int c = 0; c < 3; ++c) out[c][e] = s.occluded[r] ? -out[c][e] : 0.0f;
      else if (s.occluded[r])
        for (int c = 0; c < 3; ++c) out[c][e] = 0.0f;
    }
  }
  // Plus the BSDF term (a diffuse receiver has none): a sample from the BSDF-draw kernel whose ray meets an
  // emitter's front, weighted by the power heuristic against the light strategy's density there (pbrt-v4
  // PathIntegrator::SampleLd style, restricted to direct light).
  for (size_t p = 0; p < block.count; ++p) {
    const ShadingPoint& sp = block.points[p];
    if (sp.bsdf.type == BsdfType::kDiffuse) continue;
    const float* u = s.u.data() + uFirst[p];
    const size_t n = counts[p];
    for (std::vector<float>& v : s.bsdfDrawn) v.resize(n);
    s.bsdfOf.resize(n);
    BsdfDrawOutputs o;
    for (int c = 0; c < 3; ++c) {
      o.org[c] = s.bsdfDrawn[c].data();
      o.dir[c] = s.bsdfDrawn[3 + c].data();
      o.weight[c] = s.bsdfDrawn[6 + c].data();
    }
    o.pdf = s.bsdfDrawn[9].data();
    o.draw = s.bsdfOf.data();
    o.firstDraw = static_cast<uint32_t>(first[p]);
    const size_t drawn = DrawBsdfSamples(ReceiverOf(sp, block.materialId[p], false), materials,
                                         BsdfDraws{u + 3 * n, u + 4 * n, n}, o);
    rays += drawn;
    const PixelLightDistribution& dist = block.dists[p];
    for (size_t e = 0; e < drawn; ++e) {
      const Vec3 dir(o.dir[0][e], o.dir[1][e], o.dir[2][e]);
      const EmitterHit hit = scene.FirstEmitter(Vec3(o.org[0][e], o.org[1][e], o.org[2][e]), dir);
      if (hit.lightId < 0 || !hit.frontFace) continue;
      const LightTriangle& t = lightList[static_cast<size_t>(hit.lightId)];
      const float cosY = -glm::dot(t.normal, dir);
      if (!(cosY > 0.0f)) continue;
      // The light strategy's density of this point in solid angle: its area density, times d² / cos θy.
      const float pLight = dist.AreaDensity(static_cast<uint32_t>(hit.lightId)) * hit.t * hit.t / cosY;
      const float mis = PowerHeuristic(o.pdf[e], pLight);
      for (int c = 0; c < 3; ++c) out[c][o.draw[e]] += t.radiance[c] * (o.weight[c][e] * mis);
    }
  }
}

}  // namespace restir
