#include "sim/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>

#include "core/light_sampler.h"
#include "core/rng.h"
#include "core/shading.h"
#include "sim/atomic_file.h"
#include "sim/pipeline.h"

namespace restir {

namespace {

// Bump when the renderer changes what it computes: old cache entries then stop matching.
constexpr uint32_t kReferenceVersion = 1;
// The reference has its own seed so that runs with different --seed share one reference.
constexpr uint32_t kReferenceSeed = 0x5EFE12ECu;
constexpr char kCacheMagic[8] = {'R', 'S', 'R', 'E', 'F', '0', '0', '1'};

float PowerHeuristic(float a, float b) {
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

// One direct-lighting sample at a receiver: light sampling, plus BSDF sampling with the power heuristic on
// glossy surfaces (pbrt-v4 PathIntegrator::SampleLd style, restricted to direct light).
Vec3 DirectSample(const ShadingPoint& sp, const EmbreeScene& scene, const LightSampler& lights, Sampler& s,
                  uint64_t& rays) {
  Vec3 sum(0.0f);
  const bool glossy = sp.bsdf.type == BsdfType::kGgx;
  const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next();
  const float b0 = s.Next(), b1 = s.Next();
  const LightSample y = lights.Sample(u0, u1, u2, u3);
  const Vec3 f = UnshadowedContribution(sp, y);
  if ((f.x > 0.0f || f.y > 0.0f || f.z > 0.0f) && y.pdfArea > 0.0f) {
    ++rays;
    if (!ShadowRayOccluded(scene, sp, y.position)) {
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
      const SurfaceHit hit = scene.Intersect(OffsetRayOrigin(sp.position, sp.geometricNormal, bs.wi), bs.wi,
                                             std::numeric_limits<float>::infinity());
      if (hit.hit && hit.lightId >= 0 && hit.frontFace) {
        const LightTriangle& t = lights.Lights()[static_cast<size_t>(hit.lightId)];
        const float cosY = -glm::dot(t.normal, bs.wi);
        const float pLight = lights.PdfArea(static_cast<uint32_t>(hit.lightId)) * hit.t * hit.t / cosY;
        const float cosX = glm::dot(sp.shadingNormal, bs.wi);
        const Vec3 fr = EvalBsdf(sp.bsdf, sp.shadingNormal, sp.wo, bs.wi);
        if (cosY > 0.0f) sum += t.radiance * fr * (cosX * PowerHeuristic(bs.pdf, pLight) / bs.pdf);
      }
    }
  }
  return sum;
}

bool ReadCache(const std::string& path, int w, int h, ReferenceImage& out) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return false;
  char magic[8];
  int32_t dims[2];
  f.read(magic, 8);
  f.read(reinterpret_cast<char*>(dims), sizeof(dims));
  if (!f || std::memcmp(magic, kCacheMagic, 8) != 0 || dims[0] != w || dims[1] != h) return false;
  out.mean = ImageRgb(w, h);
  out.standardError = ImageRgb(w, h);
  f.read(reinterpret_cast<char*>(out.mean.pixels.data()), out.mean.pixels.size() * sizeof(Vec3));
  f.read(reinterpret_cast<char*>(out.standardError.pixels.data()),
         out.standardError.pixels.size() * sizeof(Vec3));
  return static_cast<bool>(f);
}

void WriteCache(const std::string& path, const ReferenceImage& ref) {
  std::string bytes(kCacheMagic, 8);
  const int32_t dims[2] = {ref.mean.width, ref.mean.height};
  bytes.append(reinterpret_cast<const char*>(dims), sizeof(dims));
  bytes.append(reinterpret_cast<const char*>(ref.mean.pixels.data()), ref.mean.pixels.size() * sizeof(Vec3));
  bytes.append(reinterpret_cast<const char*>(ref.standardError.pixels.data()),
               ref.standardError.pixels.size() * sizeof(Vec3));
  WriteFileAtomic(path, bytes);
}

}  // namespace

std::string ReferenceCacheKey(const Sequence& sequence, int frame, int width, int height, int spp) {
  const int32_t fields[6] = {frame, width, height, spp, static_cast<int32_t>(kReferenceVersion),
                             static_cast<int32_t>(kReferenceSeed)};
  uint64_t h = Fnv1a(sequence.contentHash.data(), sequence.contentHash.size());
  h = Fnv1a(fields, sizeof(fields), h);
  return HexHash(h);
}

ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& g, const ReferenceParams& params) {
  const auto t0 = std::chrono::steady_clock::now();
  const int w = g.width, h = g.height;
  std::string cachePath;
  if (!params.cacheDir.empty()) {
    cachePath = (std::filesystem::path(params.cacheDir) /
                 ("ref-" + ReferenceCacheKey(sequence, state.frame, w, h, params.samplesPerPixel) + ".bin"))
                    .string();
    ReferenceImage cached;
    if (ReadCache(cachePath, w, h, cached)) {
      cached.fromCache = true;
      cached.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      return cached;
    }
  }

  ReferenceImage ref;
  ref.mean = ImageRgb(w, h);
  ref.standardError = ImageRgb(w, h);
  const std::vector<LightTriangle>& lightList = scene.LightTriangles();
  const LightSampler lights(lightList, LightSelection::kPower);
  const std::vector<Bsdf> bsdfs = MaterialBsdfs(sequence);
  const int spp = std::max(1, params.samplesPerPixel);
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& range) {
    uint64_t& localRays = rays.local();
    for (int y = range.begin(); y < range.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        ref.mean.pixels[i] = DirectEmission(g, i, lightList);
        if (!g.IsSurface(i) || lights.Empty()) continue;
        const ShadingPoint sp = ShadingPointAt(g, i, state.camera, bsdfs);
        Sampler s(RngKey{kReferenceSeed, static_cast<uint32_t>(state.frame), static_cast<uint32_t>(i),
                         static_cast<uint32_t>(RngPass::kReference)});
        glm::dvec3 sum(0.0), sum2(0.0);
        for (int k = 0; k < spp; ++k) {
          const glm::dvec3 v(DirectSample(sp, scene, lights, s, localRays));
          sum += v;
          sum2 += v * v;
        }
        const glm::dvec3 mean = sum / double(spp);
        const glm::dvec3 var = glm::max(sum2 / double(spp) - mean * mean, glm::dvec3(0.0)) *
                               (spp > 1 ? double(spp) / double(spp - 1) : 0.0);
        ref.mean.pixels[i] += Vec3(mean);
        ref.standardError.pixels[i] = Vec3(glm::sqrt(var / double(spp)));
      }
    }
  });
  ref.rays = rays.combine(std::plus<uint64_t>());
  if (!cachePath.empty()) WriteCache(cachePath, ref);
  ref.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return ref;
}

double MeanRelativeStandardError(const ReferenceImage& ref) {
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < ref.mean.Size(); ++i) {
    const double y = Luminance(ref.mean.pixels[i]);
    if (y > 1e-4) {
      sum += Luminance(ref.standardError.pixels[i]) / y;
      ++count;
    }
  }
  return count ? sum / double(count) : 0.0;
}

}  // namespace restir
