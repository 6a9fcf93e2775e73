#include "sim/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <filesystem>

#include "core/light_sampler.h"
#include "core/polygon_irradiance.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/shading.h"
#include "sim/atomic_file.h"
#include "sim/clock.h"
#include "sim/hash.h"
#include "sim/input_file.h"
#include "sim/reference_cache.h"
#include "sim/shading_point.h"

namespace restir {

namespace {

// Bump when the renderer changes what it computes: old cache entries then stop matching.
constexpr uint32_t kReferenceVersion = 6;
// The reference has its own seed so that runs with different --seed share one reference.
constexpr uint32_t kReferenceSeed = 0x5EFE12ECu;

// Randomised quasi-Monte Carlo: each pixel's samples are kReplicates independent randomly shifted copies of
// the additive-recurrence (Roberts "R_d") low-discrepancy sequence in kSampleDims dimensions. Each sample is
// still uniformly distributed (so every replicate mean is unbiased), the points are stratified across light
// selection and area (so the error falls much faster than with independent samples), and the spread of the
// independent replicate means gives an honest standard error (Owen 2013, "Monte Carlo theory, methods and
// examples", ch. 17: randomized QMC).
constexpr int kSampleDims = 5;  // light selection, two area coordinates, two BSDF coordinates
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

class PixelLightDistribution {
 public:
  void Build(const ShadingPoint& sp, const LightSampler& power) {
    const std::vector<LightTriangle>& lights = power.Lights();
    const size_t n = lights.size();
    pmf_.resize(n);
    cdf_.resize(n);
    double total = 0.0;
    perPixel_ = n <= kMaxPerPixelLights;
    if (perPixel_) {
      std::vector<Vec3>& tri = scratch_;
      for (size_t l = 0; l < n; ++l) {
        const LightTriangle& t = lights[l];
        double u = 0.0;
        const float lum = Luminance(t.radiance);
        if (lum > 0.0f && glm::dot(t.normal, sp.position - t.p0) > 0.0f) {
          tri.assign({t.p0, t.p0 + t.e1, t.p0 + t.e2});
          const std::vector<Vec3> clipped = ClipPolygonToHemisphere(sp.position, sp.shadingNormal, tri);
          const double e = clipped.size() >= 3 ? PolygonIrradiance(sp.position, sp.shadingNormal, clipped, lum) : 0.0;
          u = e * Luminance(sp.bsdf.albedo) * kInvPi;
          if (sp.bsdf.type == BsdfType::kGgx) {
            LightSample c;
            c.position = t.p0 + (t.e1 + t.e2) * (1.0f / 3.0f);
            c.normal = t.normal;
            c.radiance = t.radiance;
            u = 0.1 * u + double(TargetFunction(UnshadowedContribution(sp, c))) * t.area;
          }
        }
        pmf_[l] = u;
        total += u;
      }
    }
    const double mix = total > 0.0 ? kDefensivePowerShare : 1.0;
    double c = 0.0;
    for (size_t l = 0; l < n; ++l) {
      const double p = (total > 0.0 ? (1.0 - mix) * pmf_[l] / total : 0.0) + mix * power.SelectionPmf(uint32_t(l));
      pmf_[l] = p;
      c += p;
      cdf_[l] = c;
    }
  }
  // Light index for u in [0, 1), by inverting the cumulative distribution (stratified u stays stratified).
  uint32_t Sample(float u) const {
    const double target = double(u) * cdf_.back();
    auto it = std::upper_bound(cdf_.begin(), cdf_.end(), target);
    size_t l = std::min(static_cast<size_t>(it - cdf_.begin()), cdf_.size() - 1);
    while (pmf_[l] <= 0.0 && l + 1 < cdf_.size()) ++l;  // never return a zero-probability light
    return static_cast<uint32_t>(l);
  }
  float Pmf(uint32_t l) const { return static_cast<float>(pmf_[l] / cdf_.back()); }

 private:
  std::vector<double> pmf_, cdf_;
  std::vector<Vec3> scratch_;
  bool perPixel_ = true;
};

// One direct-lighting sample at a receiver: light sampling, plus BSDF sampling with the power heuristic on
// glossy surfaces (pbrt-v4 PathIntegrator::SampleLd style, restricted to direct light).
Vec3 DirectSample(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
                  const PixelLightDistribution& dist, const float (&u)[kSampleDims], uint64_t& rays) {
  Vec3 sum(0.0f);
  const bool glossy = sp.bsdf.type == BsdfType::kGgx;
  LightSample y;
  y.lightId = dist.Sample(u[0]);
  const LightTriangle& lt = lights[y.lightId];
  y.position = SampleTrianglePoint(lt, u[1], u[2]);
  y.normal = lt.normal;
  y.radiance = lt.radiance;
  y.pdfArea = dist.Pmf(y.lightId) / lt.area;
  const float b0 = u[3], b1 = u[4];
  const Vec3 f = UnshadowedContribution(sp, y);
  if ((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f) {
    ++rays;
    if (!ShadowRayOccluded(scene, sp, y.position, y.normal, lt.errorScale)) {
      float weight = 1.0f;
      if (glossy) {
        const LightPath path = ConnectToLight(sp, y.position, y.normal);
        const float cosY = -glm::dot(y.normal, path.wi);
        const float pLight = y.pdfArea * path.distance * path.distance / cosY;
        weight = PowerHeuristic(pLight, PdfBsdf(sp.bsdf, sp.shadingNormal, sp.wo, path.wi));
      }
      sum += f * (weight / y.pdfArea);
    }
  }
  if (glossy) {
    const BsdfSample bs = SampleBsdf(sp.bsdf, sp.shadingNormal, sp.wo, b0, b1);
    if (bs.pdf > 0.0f && glm::dot(sp.geometricNormal, bs.wi) > 0.0f) {
      ++rays;
      const SurfaceHit hit = scene.Intersect(OffsetRayOrigin(sp.position, sp.geometricNormal, sp.errorScale, bs.wi),
                                             bs.wi, std::numeric_limits<float>::infinity());
      if (hit.hit && hit.lightId >= 0 && hit.frontFace) {
        const LightTriangle& t = lights[static_cast<size_t>(hit.lightId)];
        const float cosY = -glm::dot(t.normal, bs.wi);
        const float pLight = dist.Pmf(static_cast<uint32_t>(hit.lightId)) / t.area * hit.t * hit.t / cosY;
        const float cosX = glm::dot(sp.shadingNormal, bs.wi);
        const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
        if (cosY > 0.0f) sum += t.radiance * fr * (cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf);
      }
    }
  }
  return sum;
}

// A cached reference, or false when there is none. An entry that exists but is not a valid answer for this key
// (damaged, truncated, another frame's, not a regular file) is reported in one line and rendered again; the new
// entry then replaces it.
bool ReadCache(const std::string& path, const std::string& key, int w, int h, ReferenceImage& out) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, ReferenceCacheEntrySize(key, w, h), bytes, problem)) {
    if (problem == "no such file") return false;
  } else if (DecodeReferenceCacheEntry(bytes, key, w, h, out.mean, out.standardError, out.lumaStandardError,
                                       problem)) {
    return true;
  }
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
  return Fnv1a(state.lightOn.data(), state.lightOn.size(), h);
}

std::string ReferenceCacheKey(const Sequence& sequence, const FrameState& state, int spp) {
  const int32_t fields[3] = {spp, static_cast<int32_t>(kReferenceVersion), static_cast<int32_t>(kReferenceSeed)};
  uint64_t h = Fnv1a(sequence.contentHash.data(), sequence.contentHash.size());
  h = Fnv1a(fields, sizeof(fields), h);
  const uint64_t s = HashFrameState(state);
  return HexHash(Fnv1a(&s, sizeof(s), h));
}

ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& g, const ReferenceParams& params) {
  const auto t0 = Clock::now();
  const int w = g.width, h = g.height;
  std::string cachePath, cacheKey;
  if (!params.cacheDir.empty()) {
    cacheKey = ReferenceCacheKey(sequence, state, params.samplesPerPixel);
    cachePath = (std::filesystem::path(params.cacheDir) / ("ref-" + cacheKey + ".bin")).string();
    ReferenceImage cached;
    if (ReadCache(cachePath, cacheKey, w, h, cached)) {
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
  const std::vector<Bsdf> bsdfs = MaterialBsdfs(sequence);
  static const RobertsSequence<kSampleDims> rd;
  // Keyed by the scene state, not the frame index: frames that show the same state (a static camera and scene)
  // get the same reference, bit for bit, and share one cache entry.
  const uint64_t stateHash = HashFrameState(state);
  const uint32_t stateKey = static_cast<uint32_t>(stateHash ^ (stateHash >> 32));
  const int perReplicate = (std::max(1, params.samplesPerPixel) + kReplicates - 1) / kReplicates;
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& range) {
    uint64_t& localRays = rays.local();
    PixelLightDistribution dist;
    for (int y = range.begin(); y < range.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        ref.mean.pixels[i] = DirectEmission(g, i, lightList);
        if (!g.IsSurface(i) || lights.Empty()) continue;
        const ShadingPoint sp = ShadingPointAt(g, i, state.camera.position, bsdfs);
        dist.Build(sp, lights);
        const RngKey key{kReferenceSeed, stateKey, static_cast<uint32_t>(i),
                         static_cast<uint32_t>(RngPass::kReference)};
        glm::dvec3 replicateMean[kReplicates];
        for (int rep = 0; rep < kReplicates; ++rep) {
          double shift[kSampleDims];
          for (int j = 0; j < kSampleDims; ++j)
            shift[j] = UniformFloat(key, static_cast<uint32_t>(rep * kSampleDims + j));
          glm::dvec3 sum(0.0);
          for (int k = 0; k < perReplicate; ++k) {
            float u[kSampleDims];
            for (int j = 0; j < kSampleDims; ++j) u[j] = rd.Coordinate(shift[j], k, j);
            sum += glm::dvec3(DirectSample(sp, scene, lightList, dist, u, localRays));
          }
          replicateMean[rep] = sum / double(perReplicate);
        }
        glm::dvec3 mean(0.0), var(0.0);
        for (const glm::dvec3& m : replicateMean) mean += m;
        mean /= double(kReplicates);
        for (const glm::dvec3& m : replicateMean) var += (m - mean) * (m - mean);
        var /= double(kReplicates - 1);
        const double meanY = LuminanceD(mean);
        double varY = 0.0;
        for (const glm::dvec3& m : replicateMean) varY += (LuminanceD(m) - meanY) * (LuminanceD(m) - meanY);
        varY /= double(kReplicates - 1);
        ref.mean.pixels[i] += Vec3(mean);
        ref.standardError.pixels[i] = Vec3(glm::sqrt(var / double(kReplicates)));
        ref.lumaStandardError[i] = static_cast<float>(std::sqrt(varY / double(kReplicates)));
      }
    }
  });
  ref.rays = rays.combine(std::plus<uint64_t>());
  if (!cachePath.empty()) WriteFileAtomic(cachePath, EncodeReferenceCacheEntry(cacheKey, ref.mean, ref.standardError,
                                                                    ref.lumaStandardError));
  ref.ms = MsSince(t0);
  return ref;
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
