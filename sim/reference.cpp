#include "sim/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <sys/mman.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <filesystem>

#include "core/light_draw_kernel.h"
#include "core/light_sampler.h"
#include "core/polygon_irradiance.h"
#include "core/qmc_kernel.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/shading.h"
#include "core/shadow_ray.h"
#include "sim/atomic_file.h"
#include "sim/clock.h"
#include "sim/hash.h"
#include "sim/input_file.h"
#include "sim/reference_cache.h"
#include "sim/reference_sky.h"
#include "sim/shading_point.h"
#include "sim/sky_frame.h"

namespace restir {

namespace {

// Bump when the renderer changes what it computes: old cache entries then stop matching. (The sky did not bump
// it: a skyless frame's reference is the same bits as before, and a frame with a sky hashes its sky into the key,
// HashFrameState, so no entry written before the sky existed can match it.)
constexpr uint32_t kReferenceVersion = 7;
// The reference has its own seed so that runs with different --seed share one reference.
constexpr uint32_t kReferenceSeed = 0x5EFE12ECu;

// Randomised quasi-Monte Carlo: each pixel's samples are kReplicates independent randomly shifted copies of
// the additive-recurrence (Roberts "R_d") low-discrepancy sequence in kSampleDims dimensions. Each sample is
// still uniformly distributed (so every replicate mean is unbiased), the points are stratified across light
// selection and area (so the error falls much faster than with independent samples), and the spread of the
// independent replicate means gives an honest standard error (Owen 2013, "Monte Carlo theory, methods and
// examples", ch. 17: randomized QMC).
constexpr int kSampleDims = 5;  // light selection, two area coordinates, two BSDF coordinates
// Under a sky: the same five (light selection doubling as the environment's texel selection, the two area
// coordinates as the direction's in the sun's cone or the texel), then the strategy choice and the environment's
// alias-table coin. A skyless frame keeps kSampleDims, so its points, and its image, do not change.
constexpr int kStrategyDim = 5;
constexpr int kCoinDim = 6;
constexpr int kSkySampleDims = 7;
constexpr int kReplicates = 16;

double LuminanceD(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// Light selection for one receiver. Power alone spends most samples on lights that barely reach the pixel
// (the flagship's facade is lit through a window by a few of 72 lights), so the reference mixes, per pixel,
// selection proportional to each light's unshadowed contribution there with a defensive share by power:
// P(l) = (1 - δ) u_l / Σ u + δ Φ_l / Σ Φ. Every light with power keeps P > 0, so the estimator stays unbiased;
// only visibility and the variation across a light remain as noise. u_l is exact for diffuse receivers (Lambert's
// polygon formula on the emitter clipped to the receiver's hemisphere) and a centroid estimate plus a diffuse
// term for glossy ones. Above kMaxPerPixelLights, selection by power alone (per-pixel tables would cost more
// than the rays they save).
constexpr float kDefensivePowerShare = 0.1f;
constexpr size_t kMaxPerPixelLights = 4096;
// Memory the pilot's per-pixel light distributions may take to be reused by the main pass.
constexpr size_t kKeptDistributionBytes = size_t{512} << 20;
// Squared distance, in squared triangle sizes (longest edge), beyond which a light's u_l is taken as a point's.
constexpr float kPointLightDistance2 = 36.0f;

// What PixelLightDistribution needs of each light, structure-of-arrays so that the per-pixel point estimate runs
// as one vectorisable loop over the lights.
struct LightProxies {
  std::vector<float> cx, cy, cz;        // centroid
  std::vector<float> nx, ny, nz;        // emitting normal
  std::vector<float> offset;            // n · p0: the light faces x when n · x > offset
  std::vector<float> size2;             // squared longest edge
  std::vector<float> lumArea;           // luminance of the radiance × area
  std::vector<float> powerPmf;          // the defensive share's selection probability, by power
  LightProxies(const std::vector<LightTriangle>& lights, const LightSampler& power) {
    for (const LightTriangle& t : lights) {
      const Vec3 c = t.p0 + (t.e1 + t.e2) * (1.0f / 3.0f);
      cx.push_back(c.x), cy.push_back(c.y), cz.push_back(c.z);
      nx.push_back(t.normal.x), ny.push_back(t.normal.y), nz.push_back(t.normal.z);
      offset.push_back(glm::dot(t.normal, t.p0));
      size2.push_back(std::max({glm::dot(t.e1, t.e1), glm::dot(t.e2, t.e2), glm::dot(t.e1 - t.e2, t.e1 - t.e2)}));
      const float lum = Luminance(t.radiance);
      lumArea.push_back(lum > 0.0f ? lum * t.area : 0.0f);
    }
    // An empty sampler (every light off) has no table to read; no pixel then builds a distribution.
    if (!power.Empty())
      for (uint32_t l = 0; l < lights.size(); ++l) powerPmf.push_back(power.SelectionPmf(l));
  }
};

class PixelLightDistribution {
 public:
  // Builds the distribution's cdf into cdf[0, n) (n lights), storage the caller owns, and views it. `receiver`
  // is sp for the light-draw kernels (its material in `materials`), `drawLights` the frame's lights for them.
  void Build(const ShadingPoint& sp, const LightDrawReceiver& receiver, const BsdfSoa& materials,
             const LightDrawLights& drawLights, const LightSampler& power, const LightProxies& proxies, float* cdf) {
    const std::vector<LightTriangle>& lights = power.Lights();
    const size_t n = lights.size();
    work_.resize(n);
    point_.resize(n);
    // The loops below are split so that the compiler vectorises the per-light arithmetic; the sums stay sequential
    // (their order fixes the bits).
    double* const work = work_.data();
    double total = 0.0;
    if (n <= kMaxPerPixelLights) {
      const float* const point = point_.data();
      PointEstimates(sp, proxies, point_.data());
      const float albedo = Luminance(sp.bsdf.albedo) * kInvPi;
      for (size_t l = 0; l < n; ++l) work[l] = double(point[l]) * albedo;
      for (size_t l = 0; l < n; ++l)
        if (!(point[l] >= 0.0f)) work[l] = Exact(sp, lights[l], albedo);
      if (sp.bsdf.type != BsdfType::kDiffuse) {
        // The BSDF at each light's centroid (the light-draw kernels: every light at once).
        target_.resize(n);
        LightCentroidTargets(receiver, materials, drawLights, target_.data());
        for (size_t l = 0; l < n; ++l) {
          if (work_[l] <= 0.0 && point_[l] == 0.0f) continue;  // facing away, dark or below the horizon
          work_[l] = 0.1 * work_[l] + double(target_[l]) * lights[l].area;
        }
      }
      // Not finite (|w| <= max is false for NaN and infinities): no share.
      for (size_t l = 0; l < n; ++l)
        work[l] = std::fabs(work[l]) <= std::numeric_limits<double>::max() ? work[l] : 0.0;
      for (size_t l = 0; l < n; ++l) total += work[l];
    }
    const double estimate = n <= kMaxPerPixelLights ? total : -1.0;
    const double mix = total > 0.0 ? kDefensivePowerShare : 1.0;
    const float* const pmf = proxies.powerPmf.data();
    if (total > 0.0)
      for (size_t l = 0; l < n; ++l) work[l] = (1.0 - mix) * work[l] / total + mix * double(pmf[l]);
    else
      for (size_t l = 0; l < n; ++l) work[l] = 0.0 + mix * double(pmf[l]);
    // The prefix sums; their last is the total c, summed in the same order from the same zero.
    double running = 0.0;
    for (size_t l = 0; l < n; ++l) {
      running += work[l];
      work[l] = running;
    }
    const double c = running;
    for (size_t l = 0; l < n; ++l) cdf[l] = static_cast<float>(work[l] / c);
    View(cdf, n);
    estimate_ = estimate;
  }
  // Views a distribution Build wrote earlier.
  void View(const float* cdf, size_t n) {
    cdf_ = cdf;
    n_ = n;
    estimate_ = -1.0;  // a viewed distribution carries no estimate (the shared one, or one kept by the pilot)
  }
  // Light index for u in [0, 1), by inverting the cumulative distribution (stratified u stays stratified). Only
  // when rounding puts the target at the total is the last light returned whatever its Pmf; a zero Pmf then
  // gives the sample no light term (its area density is not positive).
  uint32_t Sample(float u) const { return SampleCdf(cdf_, n_, u); }
  // The probability Sample returns l: the pmf as the cdf it inverts sees it, so selection and pdf agree.
  float Pmf(uint32_t l) const { return CdfPmf(cdf_, n_, l); }
  const float* Cdf() const { return cdf_; }
  // What the last Build estimated the lights give the receiver together, Σ u_l × albedo / π (the luminance of
  // the reflected radiance, unshadowed; for a diffuse receiver exact but for the point estimates' O((size/d)²)),
  // or -1 where it did not estimate it (above kMaxPerPixelLights). Sets the local lights' share of the light
  // mixture under a sky (sim/reference_sky.h).
  double Estimate() const { return estimate_; }

 private:
  // u_l, the light's unshadowed contribution at the receiver without the albedo, for every light at once. It
  // only shapes the distribution (any positive pmf keeps the estimate unbiased), so a light far from the receiver
  // compared with its size is taken as a point at its centroid: E = L A cos θx cos θy / d², off by
  // O((size / d)²). out[l] = 0 for lights facing away or dark, -1 where the point is not accurate enough (near,
  // large, or the centroid close to the horizon: Exact then clips and integrates).
  static void PointEstimates(const ShadingPoint& sp, const LightProxies& p, float* __restrict out) {
    const float x = sp.position.x, y = sp.position.y, z = sp.position.z;
    const float sx = sp.shadingNormal.x, sy = sp.shadingNormal.y, sz = sp.shadingNormal.z;
    const size_t n = p.cx.size();
    const float *cx = p.cx.data(), *cy = p.cy.data(), *cz = p.cz.data(), *nx = p.nx.data(), *ny = p.ny.data(),
                *nz = p.nz.data(), *offset = p.offset.data(), *size2 = p.size2.data(), *lumArea = p.lumArea.data();
    // Written without branches (bitwise & and |, selects on values: std::max(v, 0) is v < 0 ? 0 : v) so that the
    // loop vectorises (with -fno-trapping-math, CMakeLists.txt); every lane computes what the scalar expression
    // does.
    for (size_t l = 0; l < n; ++l) {
      const float dx = cx[l] - x, dy = cy[l] - y, dz = cz[l] - z;
      const float d2 = dx * dx + dy * dy + dz * dz;
      const float facing = nx[l] * x + ny[l] * y + nz[l] * z - offset[l];
      const float cosXd = sx * dx + sy * dy + sz * dz;          // cos θx · d
      const float cosYd = -(nx[l] * dx + ny[l] * dy + nz[l] * dz);  // cos θy · d
      // Far: beyond kPointLightDistance2 sizes, and the centroid at least one size above the horizon, so the
      // whole triangle is above it (no clipping needed).
      const bool far = (d2 > kPointLightDistance2 * size2[l]) & (cosXd * cosXd > size2[l]) & (cosXd > 0.0f);
      const float clampedX = cosXd < 0.0f ? 0.0f : cosXd;
      const float clampedY = cosYd < 0.0f ? 0.0f : cosYd;
      const float point = lumArea[l] * clampedX * clampedY / (d2 * d2);
      const bool none = !(facing > 0.0f) | !(lumArea[l] > 0.0f);
      const float value = far ? point : -1.0f;
      out[l] = none ? 0.0f : value;
    }
  }

  // Lambert's formula, in double, on the triangle clipped to the receiver's hemisphere.
  static double Exact(const ShadingPoint& sp, const LightTriangle& t, float albedo) {
    const Vec3 tri[3] = {t.p0, t.p0 + t.e1, t.p0 + t.e2};
    const Vec3& n = sp.shadingNormal;
    if (glm::dot(n, tri[0] - sp.position) <= 0.0f && glm::dot(n, tri[1] - sp.position) <= 0.0f &&
        glm::dot(n, tri[2] - sp.position) <= 0.0f)
      return 0.0;
    Vec3 clipped[4];
    const size_t k = ClipPolygonToHemisphere(sp.position, n, tri, 3, clipped);
    return k >= 3 ? PolygonIrradianceOf<double>(sp.position, n, clipped, k, Luminance(t.radiance)) * albedo : 0.0;
  }

  std::vector<double> work_;
  std::vector<float> point_;
  std::vector<float> target_;
  double estimate_ = -1.0;
  const float* cdf_ = nullptr;
  size_t n_ = 0;
};

// An uninitialised float array in transparent huge pages where the system offers them (Linux, THP in "madvise"
// mode as Debian ships it): a large array first touched page by page otherwise takes a page fault per 4 KiB.
class HugePageFloats {
 public:
  explicit HugePageFloats(size_t count) {
    if (count == 0) return;
    constexpr size_t kHuge = size_t{2} << 20;
    const size_t bytes = (count * sizeof(float) + kHuge - 1) / kHuge * kHuge;
    data_ = static_cast<float*>(std::aligned_alloc(kHuge, bytes));
    if (!data_) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
    madvise(data_, bytes, MADV_HUGEPAGE);  // advice only: where it is refused, 4 KiB pages as before
#endif
  }
  ~HugePageFloats() { std::free(data_); }
  HugePageFloats(const HugePageFloats&) = delete;
  HugePageFloats& operator=(const HugePageFloats&) = delete;
  float* get() const { return data_; }

 private:
  float* data_ = nullptr;
};

// Per-thread scratch of one pixel's samples: the light-sampling terms wait for their shadow rays, which go to
// Embree as one batch (packets, EmbreeScene::OccludedBatch) instead of one rtcOccluded1 per sample.
struct SampleBatch {
  std::vector<Vec3> lightTerm;   // per sample: the light-sampling term if its shadow ray is unoccluded
  std::vector<Vec3> bsdfTerm;    // per sample: the BSDF-sampling term, visibility already resolved
  std::vector<ShadowRay> rays;   // the shadow rays of the samples whose light term is nonzero
  std::vector<uint32_t> rayOf;   // the sample each ray belongs to
  std::vector<uint8_t> occluded;
  std::vector<float> drawn[10];  // the light-draw kernel's outputs: term r g b, origin, direction, length
  std::vector<uint32_t> drawOf;  // the light-draw kernel's: the sample of each of its rays
};

// The frame's light triangles as the light-draw kernel reads them (core/light_draw_kernel.h).
struct LightDrawSoa {
  struct alignas(64) Record {
    float v[kLightDrawRecordFloats];  // WriteLightDrawRecord's layout
  };
  std::vector<Record> records;    // one per light triangle, in the frame's order
  std::vector<float> errorScale;  // LightTriangle::errorScale, likewise
  LightDrawLights view;           // what the kernel reads: the two above
  explicit LightDrawSoa(const std::vector<LightTriangle>& lights) : records(lights.size()) {
    for (size_t l = 0; l < lights.size(); ++l) {
      WriteLightDrawRecord(lights[l], records[l].v);
      errorScale.push_back(lights[l].errorScale);
    }
    view.records = records.empty() ? nullptr : records.data()->v;
    view.errorScale = errorScale.data();
    view.count = lights.size();
  }
};

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

// The sky of a frame (null in a skyless one) and one receiver's light mixture, as SkySamples needs them.
struct SkySampling {
  const Sky* sky = nullptr;  // null: a skyless frame, sampled exactly as before the sky existed
  LightMixture mixture;      // the receiver's strategy probabilities ({1, 0, 0} in a skyless frame)
};

// The BSDF-sampling term of one sample (a direction from the BSDF at (u0, u1), weighted by the power heuristic
// against the light strategies' density where its ray lands), 0 where the ray finds no light; counts the ray.
Vec3 BsdfTerm(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
              const PixelLightDistribution& dist, const SkySampling& sky, float u0, float u1, uint64_t& rays) {
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
    const float pLight = dist.Pmf(static_cast<uint32_t>(hit.lightId)) * mix.local / t.area * hit.t * hit.t / cosY;
    const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
    if (cosY > 0.0f) return t.radiance * fr * (cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf);
  } else if (!hit.hit && sky.sky != nullptr) {
    // Escaped: the sky, at the density with which the light mixture draws this direction.
    const float pLight = SkyLightPdf(mix, *sky.sky, bs.wi);
    const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
    return sky.sky->Radiance(bs.wi) * fr * (cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf);
  }
  return Vec3(0.0f);
}

// `count` direct-lighting samples at a receiver in a frame with a sky, from the points whose coordinate j is
// u[j * count + k] (kSkySampleDims coordinates): light sampling (a strategy from the receiver's mixture, then a
// light point or a sky direction from it) plus BSDF sampling, combined by the power heuristic (pbrt-v4
// PathIntegrator::SampleLd style, restricted to direct light); BSDF sampling on every surface, as a BSDF ray that
// escapes is the only way to reach the sky's directions the light mixture samples rarely. out[k] is sample k's
// value. Frames without a sky take SkylessSamples.
void SkySamples(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
                const PixelLightDistribution& dist, const SkySampling& sky, const float* u, size_t count,
                SampleBatch& b, Vec3* out, uint64_t& rays) {
  const LightMixture& mix = sky.mixture;
  b.lightTerm.assign(count, Vec3(0.0f));
  b.bsdfTerm.assign(count, Vec3(0.0f));
  b.rays.clear();
  b.rayOf.clear();
  for (size_t k = 0; k < count; ++k) {
    const auto uk = [&](int j) { return u[static_cast<size_t>(j) * count + k]; };
    const LightStrategy strategy = ChooseLightStrategy(mix, uk(kStrategyDim));
    if (strategy == LightStrategy::kLocal && mix.local > 0.0f) {
      LightSample y;
      y.lightId = dist.Sample(uk(0));
      const LightTriangle& lt = lights[y.lightId];
      y.position = SampleTrianglePoint(lt, uk(1), uk(2));
      y.normal = lt.normal;
      y.radiance = lt.radiance;
      y.pdfArea = dist.Pmf(y.lightId) * mix.local / lt.area;
      const Vec3 f = UnshadowedContribution(sp, y);
      if ((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f) {
        const LightPath path = ConnectToLight(sp, y.position, y.normal);
        const float cosY = -glm::dot(y.normal, path.wi);
        const float pLight = y.pdfArea * path.distance * path.distance / cosY;
        const float weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi));
        b.lightTerm[k] = f * (weight / y.pdfArea);
        const ShadowRaySegment s =
            ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal, lt.errorScale);
        b.rays.push_back(ShadowRay{s.org, s.dir, s.tmax});
        b.rayOf.push_back(static_cast<uint32_t>(k));
      }
    } else if (strategy != LightStrategy::kLocal) {
      // A sky direction: the integrand is Sky::Radiance(ω) f_r cos θ, evaluated through the far point that stands
      // for ω (core/sky.h SkyPointFor), its density the mixture's over every sky strategy (sim/reference_sky.h).
      const Vec3 w = SampleSkyStrategy(*sky.sky, strategy, uk(0), uk(kCoinDim), uk(1), uk(2));
      const float pLight = SkyLightPdf(mix, *sky.sky, w);
      const LightSample y = SkyPointFor(sp.position, w, sky.sky->Radiance(w));
      const Vec3 f = UnshadowedContribution(sp, y);
      if ((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && pLight > 0.0f) {
        const float weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, w));
        b.lightTerm[k] = f * (weight / pLight);
        // The far point's own error scale is its distance, which ShadowRaySetup adds already.
        const ShadowRaySegment s =
            ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y.position, y.normal, 0.0f);
        b.rays.push_back(ShadowRay{s.org, s.dir, s.tmax});
        b.rayOf.push_back(static_cast<uint32_t>(k));
      }
    }
    b.bsdfTerm[k] = BsdfTerm(sp, scene, lights, dist, sky, uk(3), uk(4), rays);
  }
  b.occluded.resize(b.rays.size());
  scene.OccludedBatch(b.rays.data(), b.occluded.data(), b.rays.size());
  rays += b.rays.size();
  for (size_t k = 0; k < count; ++k) out[k] = b.bsdfTerm[k];
  for (size_t r = 0; r < b.rays.size(); ++r)
    if (!b.occluded[r]) out[b.rayOf[r]] = b.lightTerm[b.rayOf[r]] + b.bsdfTerm[b.rayOf[r]];
}

// `count` direct-lighting samples at a receiver in a frame without a sky, laid out as SkySamples' (kSampleDims
// coordinates): light sampling from the receiver's light distribution, plus, at a receiver that is not diffuse,
// BSDF sampling with the power heuristic. The light half is the light-draw kernel (a packet of draws per register,
// its MIS weight included), the BSDF half BsdfTerm. Reads coordinates 0-2 of u at a diffuse receiver, 0-4 at
// others.
void SkylessSamples(const ShadingPoint& sp, int32_t materialId, const EmbreeScene& scene, const BsdfSoa& materials,
                    const std::vector<LightTriangle>& lightList, const PixelLightDistribution& dist,
                    const SkySampling& sky, const LightDrawLights& lights, const float* u, size_t count,
                    SampleBatch& b, Vec3* out, uint64_t& rays) {
  const bool bsdfSampling = sp.bsdf.type != BsdfType::kDiffuse;
  for (std::vector<float>& v : b.drawn) v.resize(count);
  b.drawOf.resize(count);
  const LightDrawReceiver receiver = ReceiverOf(sp, materialId, bsdfSampling);
  LightDraws draws;
  draws.uSelect = u;
  draws.uPoint0 = u + count;
  draws.uPoint1 = u + 2 * count;
  draws.count = count;
  LightDrawOutputs o;
  ShadowRaysSoa shadowRays;
  for (int c = 0; c < 3; ++c) {
    o.term[c] = b.drawn[c].data();
    o.org[c] = b.drawn[3 + c].data();
    o.dir[c] = b.drawn[6 + c].data();
    shadowRays.org[c] = o.org[c];
    shadowRays.dir[c] = o.dir[c];
  }
  o.tmax = b.drawn[9].data();
  o.draw = b.drawOf.data();
  shadowRays.tmax = o.tmax;
  // The kernel packs the draws whose term can count, with their rays: the batch goes to Embree as it is.
  shadowRays.count = DrawLightSamples(receiver, materials, lights, dist.Cdf(), draws, o);
  b.occluded.resize(shadowRays.count);
  scene.OccludedBatch(shadowRays, b.occluded.data());
  rays += shadowRays.count;
  // The BSDF term, plus the light term where its ray is unoccluded (a diffuse receiver's BSDF term is 0).
  if (bsdfSampling) {
    for (size_t k = 0; k < count; ++k)
      out[k] = BsdfTerm(sp, scene, lightList, dist, sky, u[3 * count + k], u[4 * count + k], rays);
    for (size_t r = 0; r < shadowRays.count; ++r) {
      const size_t k = b.drawOf[r];
      if (!b.occluded[r]) out[k] = Vec3(o.term[0][r], o.term[1][r], o.term[2][r]) + out[k];
    }
  } else {
    std::fill(out, out + count, Vec3(0.0f));
    for (size_t r = 0; r < shadowRays.count; ++r)
      if (!b.occluded[r]) out[b.drawOf[r]] = Vec3(o.term[0][r], o.term[1][r], o.term[2][r]) + Vec3(0.0f);
  }
}

// Two-stage allocation (issue 16; docs/metrics.md, "How the reference is sampled"): kPilotSamples independent uniform
// samples per pixel estimate the per-sample relative variance v = Var[f] / E[f]²; the main pass then spends
// samples in proportion to v (every pixel reaching about the same relative standard error), with samples
// independent of the pilot's. The pilot's samples are not part of the estimate: the allocation is then a
// function of independent randomness only, so each pixel's estimate and its replicate standard error stay
// unbiased given its sample count (no stopping on the sample's own values).
constexpr int kPilotSamples = 16;
// In budget mode, this share of the main budget goes to every pixel uniformly: the pilot's 16 samples can miss
// a rare light (v estimated 0), and a floor keeps such pixels from being starved.
constexpr double kUniformShare = 0.25;
// No pixel gets more than this multiple of the mean per-replicate count (budget mode), or more than
// kMaxSamplesPerPixel (error mode).
constexpr int kMaxAllocationScale = 16;
constexpr int kMaxSamplesPerPixel = 1 << 16;

// Per-replicate sample counts from the pilot's relative variances (negative: the pilot saw no light).
std::vector<uint32_t> AllocateSamples(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                      const ReferenceParams& params) {
  std::vector<uint32_t> m(relVar.size(), 0);
  if (params.targetRelativeError > 0.0) {
    // Relative standard error of a mean of n samples: sqrt(v / n) = E  =>  n = v / E².
    const double e2 = params.targetRelativeError * params.targetRelativeError;
    for (size_t i = 0; i < relVar.size(); ++i) {
      if (!active[i]) continue;
      const double n = relVar[i] > 0.0f ? std::ceil(double(relVar[i]) / e2) : 0.0;
      const double perReplicate = std::ceil(std::min(n, double(kMaxSamplesPerPixel)) / kReplicates);
      m[i] = static_cast<uint32_t>(std::max(1.0, perReplicate));
    }
    return m;
  }
  const int budget = std::max(1, params.samplesPerPixel);
  const double meanPerReplicate = std::max(1.0, std::ceil(double(budget - kPilotSamples) / kReplicates));
  double sum = 0.0;
  for (size_t i = 0; i < relVar.size(); ++i)
    if (active[i] && relVar[i] > 0.0f) sum += relVar[i];
  // Mean over every active pixel (those with v = 0 included), so the allocation averages meanPerReplicate.
  size_t activeCount = 0;
  for (uint8_t a : active) activeCount += a;
  const double meanV = activeCount ? sum / double(activeCount) : 0.0;
  for (size_t i = 0; i < relVar.size(); ++i) {
    if (!active[i]) continue;
    const double share = meanV > 0.0 ? kUniformShare + (1.0 - kUniformShare) * std::max(0.0f, relVar[i]) / meanV
                                     : 1.0;
    const double perReplicate = std::min(std::round(meanPerReplicate * share), meanPerReplicate * kMaxAllocationScale);
    m[i] = static_cast<uint32_t>(std::max(1.0, perReplicate));
  }
  return m;
}

// A cached reference, or false when there is none. An entry that exists but is not a valid answer for this key
// (damaged, truncated, another frame's, not a regular file) is reported in one line and rendered again; the new
// entry then replaces it.
bool ReadCache(const std::string& path, const std::string& key, int w, int h, ReferenceImage& out,
               bool quiet = false) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, ReferenceCacheEntrySize(key, w, h), bytes, problem)) {
    if (problem == "no such file") return false;
  } else if (DecodeReferenceCacheEntry(bytes, key, w, h, out.mean, out.standardError, out.lumaStandardError,
                                       problem)) {
    return true;
  }
  if (quiet) return false;  // read again under the lock: the first reading already said what is wrong with it
  std::fprintf(stderr, "restir-sim: warning: %s: unusable reference cache entry (%s); rendering it again\n",
               path.c_str(), problem.c_str());
  return false;
}

}  // namespace

uint64_t HashFrameState(const FrameState& state) {
  const Camera& c = state.camera;
  const float camera[13] = {c.position.x, c.position.y, c.position.z, c.forward.x, c.forward.y, c.forward.z,
                            c.up.x,       c.up.y,       c.up.z,       c.right.x,   c.right.y,   c.right.z,
                            c.vfovDegrees};
  const int32_t size[2] = {c.width, c.height};
  uint64_t h = Fnv1a(camera, sizeof(camera));
  h = Fnv1a(size, sizeof(size), h);
  for (const Mat4& m : state.objectToWorld) h = Fnv1a(&m, sizeof(Mat4), h);
  h = Fnv1a(state.lightOn.data(), state.lightOn.size(), h);
  // The sky's state only where the frame has a sky: a skyless frame's hash, hence its reference's random numbers
  // and cache key, stay what they were before the sky existed.
  if (state.environmentIntensity > 0.0f || state.sunIntensity > 0.0f) {
    const float sky[6] = {state.environmentIntensity, state.environmentRotationDegrees, state.sunDirection.x,
                          state.sunDirection.y,       state.sunDirection.z,             state.sunIntensity};
    h = Fnv1a(sky, sizeof(sky), h);
  }
  return h;
}

std::string ReferenceCacheKey(const Sequence& sequence, const FrameState& state, const ReferenceParams& params) {
  // The error target, when set, replaces the budget: two runs with different spp share its entry.
  const bool target = params.targetRelativeError > 0.0;
  const int32_t fields[3] = {target ? 0 : params.samplesPerPixel, static_cast<int32_t>(kReferenceVersion),
                             static_cast<int32_t>(kReferenceSeed)};
  const double error = target ? params.targetRelativeError : 0.0;
  uint64_t h = Fnv1a(sequence.contentHash.data(), sequence.contentHash.size());
  h = Fnv1a(fields, sizeof(fields), h);
  h = Fnv1a(&error, sizeof(error), h);
  const uint64_t s = HashFrameState(state);
  return HexHash(Fnv1a(&s, sizeof(s), h));
}

ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& g, const ReferenceParams& params) {
  const auto t0 = Clock::now();
  const int w = g.width, h = g.height;
  std::string cachePath, cacheKey;
  std::optional<FileLock> lock;  // held until the entry is written
  if (!params.cacheDir.empty()) {
    cacheKey = ReferenceCacheKey(sequence, state, params);
    cachePath = (std::filesystem::path(params.cacheDir) / ("ref-" + cacheKey + ".bin")).string();
    ReferenceImage cached;
    if (ReadCache(cachePath, cacheKey, w, h, cached)) {
      cached.fromCache = true;
      cached.ms = MsSince(t0);
      return cached;
    }
    // Many processes (a sweep's jobs, on one machine or a cluster's shared file system) may want this entry at
    // once: the first to lock it renders it, the others wait and read its entry instead of rendering it again.
    // Without the lock (a file system that cannot lock) they render concurrently; each entry's bytes are the same
    // and reach the file by an atomic rename, so any one of them is whole.
    lock.emplace((std::filesystem::path(params.cacheDir) / ("ref-" + cacheKey + ".lock")).string());
    if (lock->Held() && ReadCache(cachePath, cacheKey, w, h, cached, /*quiet=*/true)) {
      cached.fromCache = true;
      cached.ms = MsSince(t0);
      return cached;
    }
  }

  ReferenceImage ref;
  ref.mean = ImageRgb(w, h);
  ref.standardError = ImageRgb(w, h);
  ref.lumaStandardError.assign(static_cast<size_t>(w) * h, 0.0f);
  const std::vector<LightTriangle>& lightList = scene.LightTriangles();
  const LightSampler lights(lightList, LightSelection::kPower);
  const BsdfSoa bsdfs = FrameBsdfTable(MaterialBsdfs(sequence), sequence.materials, g, nullptr);
  static const RobertsSequence<kSampleDims> rd;
  static const RobertsSequence<kSkySampleDims> rdSky;
  // The sky (issue 18): light sampling becomes a per-pixel mixture of the local lights, the sun and the
  // environment (sim/reference_sky.h), and every surface gets BSDF sampling. A skyless frame takes none of it.
  const Sky sky = MakeSky(sequence, state);
  const bool hasSky = !sky.Empty();
  const SkySummary skySummary = hasSky ? SummarizeSky(sky) : SkySummary{};
  const int dims = hasSky ? kSkySampleDims : kSampleDims;
  const bool hasLocal = !lights.Empty();
  // Keyed by the scene state, not the frame index: frames that show the same state (a static camera and scene)
  // get the same reference, bit for bit, and share one cache entry.
  const uint64_t stateHash = HashFrameState(state);
  const uint32_t stateKey = static_cast<uint32_t>(stateHash ^ (stateHash >> 32));
  const size_t pixels = static_cast<size_t>(w) * h;
  std::vector<uint8_t> active(pixels, 0);
  for (size_t i = 0; i < pixels; ++i) {
    // Where the primary ray escaped, the sky it sees (zero in a skyless frame).
    ref.mean.pixels[i] = DirectEmission(g, i, lightList, sky, state.camera);
    active[i] = g.IsSurface(i) && (hasLocal || hasSky);
  }
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> samples([] { return uint64_t{0}; });
  // The pilot's per-pixel light distributions are kept for the main pass when they fit in
  // kKeptDistributionBytes; otherwise the main pass builds them again (the same bits).
  const size_t nLights = lightList.size();
  const LightProxies proxies(lightList, lights);
  const LightDrawSoa drawLights(lightList);
  // Above kMaxPerPixelLights every pixel's distribution is the same (power alone): built once, viewed by all.
  std::vector<float> shared;
  if (hasLocal && nLights > kMaxPerPixelLights) {
    shared.resize(nLights);
    PixelLightDistribution once;
    once.Build(ShadingPoint{}, LightDrawReceiver{}, bsdfs, drawLights.view, lights, proxies, shared.data());
  }
  // Without local lights (none, or all switched off) under a sky, no pixel has a light distribution.
  const bool keep = hasLocal && shared.empty() && pixels * nLights * sizeof(float) <= kKeptDistributionBytes;
  // Not value-initialised: every pixel's row is written by the pilot before the main pass reads it (66 MB at
  // 640x360 with 72 lights, whose zeroing cost as much as a fifth of the distributions' build). In huge pages:
  // first touches of 4 KiB pages cost the 48-spp reference 4% of its time in the kernel's page faults.
  const HugePageFloats kept(keep ? pixels * nLights : 0);
  // Under a sky, each pixel's light mixture, set by the pilot from its estimates, read by the main pass.
  std::vector<LightMixture> mixtures(hasSky ? pixels : 0);
  auto forEachActiveRow = [&](bool builtBefore, auto&& perPixel) {
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& range) {
      PixelLightDistribution dist;
      SampleBatch batch;
      std::vector<float> u, local(!hasLocal || keep || !shared.empty() ? 0 : nLights);
      std::vector<Vec3> values;
      for (int y = range.begin(); y < range.end(); ++y)
        for (int x = 0; x < w; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!active[i]) continue;
          const ShadingPoint sp = ShadingPointAt(g, i, state.camera.position, bsdfs);
          if (hasLocal) {
            float* cdf = keep ? kept.get() + i * nLights : local.data();
            if (!shared.empty())
              dist.View(shared.data(), nLights);
            else if (keep && builtBefore)
              dist.View(cdf, nLights);
            else
              dist.Build(sp, ReceiverOf(sp, g.bsdfId[i], false), bsdfs, drawLights.view, lights, proxies, cdf);
          }
          SkySampling skySampling;
          if (hasSky) {
            skySampling.sky = &sky;
            if (!builtBefore) {
              // The local lights' estimate where the distribution has one; where it has none (above
              // kMaxPerPixelLights), as much as the sky's, so that the local lights get about half the draws.
              const float sunEstimate = SunEstimate(sp, sky, skySummary);
              const float environmentEstimate = EnvironmentEstimate(sp, sky, skySummary);
              const float skyEstimate = std::max(0.0f, sunEstimate) + std::max(0.0f, environmentEstimate);
              const float localEstimate = !hasLocal ? -1.0f
                                          : dist.Estimate() >= 0.0 ? static_cast<float>(dist.Estimate())
                                                                   : skyEstimate;
              mixtures[i] = MixLightStrategies(localEstimate, sunEstimate, environmentEstimate);
            }
            skySampling.mixture = mixtures[i];
          }
          perPixel(i, sp, dist, skySampling, batch, u, values);
        }
    });
  };

  // Pilot: independent uniform samples (their own RNG pass), only their relative variance is kept.
  std::vector<float> relVar(pixels, -1.0f);
  forEachActiveRow(false, [&](size_t i, const ShadingPoint& sp, const PixelLightDistribution& dist,
                              const SkySampling& skySampling, SampleBatch& batch, std::vector<float>& u,
                              std::vector<Vec3>& values) {
    const RngKey key{kReferenceSeed, stateKey, static_cast<uint32_t>(i),
                     static_cast<uint32_t>(RngPass::kReferencePilot)};
    // Sample k's coordinate j is dimension k * dims + j of the key; a diffuse receiver without a sky reads three.
    const bool skyless = !hasSky;
    const int used = skyless && sp.bsdf.type == BsdfType::kDiffuse ? 3 : dims;
    u.resize(static_cast<size_t>(kPilotSamples) * dims);
    UniformFloats(key, 0, static_cast<uint32_t>(dims), kPilotSamples, u.data(), static_cast<size_t>(used), 1);
    values.resize(kPilotSamples);
    if (skyless)
      SkylessSamples(sp, g.bsdfId[i], scene, bsdfs, lightList, dist, skySampling, drawLights.view, u.data(),
                     kPilotSamples, batch, values.data(), rays.local());
    else
      SkySamples(sp, scene, lightList, dist, skySampling, u.data(), kPilotSamples, batch, values.data(), rays.local());
    samples.local() += kPilotSamples;
    double sum = 0.0, sumSq = 0.0;
    for (const Vec3& v : values) {
      const double yv = Luminance(v);
      sum += yv;
      sumSq += yv * yv;
    }
    const double mean = sum / kPilotSamples;
    const double var = std::max(0.0, (sumSq - sum * mean) / (kPilotSamples - 1));
    if (mean > 0.0) relVar[i] = static_cast<float>(std::min(var / (mean * mean), 1e30));
  });
  const std::vector<uint32_t> perReplicate = AllocateSamples(relVar, active, params);
  ref.pixelSamples.assign(pixels, 0);
  for (size_t i = 0; i < pixels; ++i)
    if (active[i]) ref.pixelSamples[i] = kPilotSamples + perReplicate[i] * kReplicates;

  // Main pass: per pixel, kReplicates independently shifted copies of the Roberts sequence, perReplicate[i]
  // points each.
  forEachActiveRow(true, [&](size_t i, const ShadingPoint& sp, const PixelLightDistribution& dist,
                             const SkySampling& skySampling, SampleBatch& batch, std::vector<float>& u,
                             std::vector<Vec3>& values) {
    const RngKey key{kReferenceSeed, stateKey, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kReference)};
    const int m = static_cast<int>(perReplicate[i]);
    const size_t n = static_cast<size_t>(m) * kReplicates;
    const bool skyless = !hasSky;
    const int used = skyless && sp.bsdf.type == BsdfType::kDiffuse ? 3 : dims;
    // Coordinate j of point k of replicate rep is u[j * n + rep * m + k]; the replicate's shift of coordinate j
    // is dimension rep * dims + j of the key.
    u.resize(n * dims);
    float shifts[kSkySampleDims * kReplicates];  // coordinate j's of replicate rep at j * kReplicates + rep
    UniformFloats(key, 0, static_cast<uint32_t>(dims), kReplicates, shifts, static_cast<size_t>(used), 1);
    for (int j = 0; j < used; ++j)
      RobertsCoordinates(shifts + j * kReplicates, kReplicates, static_cast<size_t>(m),
                         hasSky ? rdSky.alpha[j] : rd.alpha[j], u.data() + static_cast<size_t>(j) * n);
    values.resize(n);
    if (skyless)
      SkylessSamples(sp, g.bsdfId[i], scene, bsdfs, lightList, dist, skySampling, drawLights.view, u.data(), n, batch,
                     values.data(), rays.local());
    else
      SkySamples(sp, scene, lightList, dist, skySampling, u.data(), n, batch, values.data(), rays.local());
    samples.local() += n;
    glm::dvec3 replicateMean[kReplicates];
    for (int rep = 0; rep < kReplicates; ++rep) {
      glm::dvec3 sum(0.0);
      for (int k = 0; k < m; ++k) sum += glm::dvec3(values[static_cast<size_t>(rep) * m + k]);
      replicateMean[rep] = sum / double(m);
    }
    glm::dvec3 mean(0.0), var(0.0);
    for (const glm::dvec3& r : replicateMean) mean += r;
    mean /= double(kReplicates);
    for (const glm::dvec3& r : replicateMean) var += (r - mean) * (r - mean);
    var /= double(kReplicates - 1);
    const double meanY = LuminanceD(mean);
    double varY = 0.0;
    for (const glm::dvec3& r : replicateMean) varY += (LuminanceD(r) - meanY) * (LuminanceD(r) - meanY);
    varY /= double(kReplicates - 1);
    ref.mean.pixels[i] += Vec3(mean);
    ref.standardError.pixels[i] = Vec3(glm::sqrt(var / double(kReplicates)));
    ref.lumaStandardError[i] = static_cast<float>(std::sqrt(varY / double(kReplicates)));
  });
  ref.rays = rays.combine(std::plus<uint64_t>());
  ref.samples = samples.combine(std::plus<uint64_t>());
  if (!cachePath.empty()) WriteFileAtomic(cachePath, EncodeReferenceCacheEntry(cacheKey, ref.mean, ref.standardError,
                                                                    ref.lumaStandardError));
  ref.ms = MsSince(t0);
  return ref;
}

double ReferenceScratchBytes(double pixels, double lights, bool sky) {
  const double kept = lights > double(kMaxPerPixelLights) ? lights * sizeof(float) : pixels * lights * sizeof(float);
  // active flag, relative variance, per-replicate count, samples per pixel; under a sky, the light mixture
  const double perPixel = 1.0 + sizeof(float) + 2.0 * sizeof(uint32_t) + (sky ? sizeof(LightMixture) : 0.0);
  // The kept distributions are allocated in whole 2 MiB pages (HugePageFloats).
  const double huge = double(size_t{2} << 20);
  return (kept <= double(kKeptDistributionBytes) ? std::ceil(kept / huge) * huge : 0.0) + pixels * perPixel;
}

double MeanRelativeStandardError(const ReferenceImage& ref) {
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < ref.mean.Size(); ++i) {
    const double y = Luminance(ref.mean.pixels[i]);
    if (y > 1e-4) {
      sum += ref.lumaStandardError[i] / y;
      ++count;
    }
  }
  return count ? sum / double(count) : 0.0;
}

}  // namespace restir
