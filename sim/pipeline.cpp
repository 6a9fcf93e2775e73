#include "sim/pipeline.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <chrono>

#include "core/rng.h"

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
                       SceneFrame frame) {
  const Vec3 toLight = lightPosition - sp.position;
  const float d = glm::length(toLight);
  const Vec3 dir = toLight / d;
  const Vec3 org = OffsetRayOrigin(sp.position, sp.geometricNormal, dir);
  // Stop a relative 1e-3 short of the light point so the emitter itself never counts as an occluder.
  const float tmax = glm::length(lightPosition - org) * (1.0f - 1e-3f);
  return scene.Occluded(org, dir, tmax, frame);
}

FrameResult Pipeline::RenderFrame(const FrameInputs& in) {
  const GBuffer& g = *in.gbuffer;
  const int w = g.width, h = g.height;
  const size_t n = g.Size();
  reservoirs_.assign(n, Reservoir{});
  FrameResult result;
  result.image = ImageRgb(w, h);
  const Camera& camera = in.state->camera;
  const InitialSamplingParams& ip = settings_.initial;

  // Initial sampling: streaming RIS over M candidates from the light sampler (seed 003 §1).
  tbb::combinable<uint64_t> rays([] { return uint64_t{0}; });
  auto t0 = std::chrono::steady_clock::now();
  ForEachRow(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!g.IsSurface(i) || in.lights->Empty()) continue;
      const ShadingPoint sp = ShadingPointAt(g, i, camera, *in.materials);
      Sampler s(RngKey{in.seed, in.frame, static_cast<uint32_t>(i), static_cast<uint32_t>(RngPass::kInitial)});
      Reservoir r;
      for (int j = 0; j < ip.candidates; ++j) {
        const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next(), uSel = s.Next();
        const LightSample y = in.lights->Sample(u0, u1, u2, u3);
        const float target = TargetFunction(UnshadowedContribution(sp, y));
        StreamCandidate(r, y, target, RisWeight(target, y.pdfArea), uSel);
      }
      FinalizeRis(r, static_cast<float>(ip.candidates));
      r.confidence = 1.0f;  // an initial reservoir counts one frame of history (DESIGN §4)
      if (ip.initialVisibility && r.HasSample()) {
        rays.local() += 1;
        if (ShadowRayOccluded(*in.scene, sp, r.sample.position)) r.W = 0.0f, r.visibility = 0.0f;
      }
      reservoirs_[i] = r;
    }
  });
  result.passes.push_back({"initial", MsSince(t0), rays.combine(std::plus<uint64_t>())});

  // Shading: f(Y) W with a final shadow ray (DESIGN §4), plus what the primary ray sees directly.
  tbb::combinable<uint64_t> shadeRays([] { return uint64_t{0}; });
  tbb::combinable<uint64_t> guarded([] { return uint64_t{0}; });
  t0 = std::chrono::steady_clock::now();
  const std::vector<LightTriangle>& lights = in.scene->LightTriangles();
  ForEachRow(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      Vec3 c = DirectEmission(g, i, lights);
      const Reservoir& r = reservoirs_[i];
      if (g.IsSurface(i) && r.HasSample()) {
        const ShadingPoint sp = ShadingPointAt(g, i, camera, *in.materials);
        Vec3 f = UnshadowedContribution(sp, r.sample);
        if (settings_.shade.finalVisibility && (f.x > 0.0f || f.y > 0.0f || f.z > 0.0f)) {
          shadeRays.local() += 1;
          if (ShadowRayOccluded(*in.scene, sp, r.sample.position)) f = Vec3(0.0f);
        }
        c += f * r.W;
      }
      if (!IsFinite(c)) {
        guarded.local() += 1;
        c = Vec3(0.0f);
      }
      result.image.pixels[i] = c;
    }
  });
  result.passes.push_back({"shade", MsSince(t0), shadeRays.combine(std::plus<uint64_t>())});
  result.guardedEvents = guarded.combine(std::plus<uint64_t>());
  return result;
}

}  // namespace restir
