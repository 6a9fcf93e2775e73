// What the closed-form tests of the reference's and ReSTIR GI's indirect light share
// (tests/sim/reference/reference_paths_test.cpp, furnace_test.cpp): the reference rendered at a static frame and
// its claims against a truth per pixel (ExpectAgreement), and ReSTIR GI's frames of a static scene over seeds with
// their claims (ExpectUnbiasedFrames). The statistics are stated where each claim is made.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/light_sampler.h"
#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/reference/reference.h"
#include "sim/reference/reference_paths.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/shading_point.h"
#include "sim/scene/sky_frame.h"
#include "stats.h"

namespace restir {
namespace closed_form {

using D3 = glm::dvec3;

inline constexpr double kClaimRate = 1e-4;
inline constexpr double kMaxRelativeError = 0.01;

inline double Y(const D3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}
inline double Radians(double degrees) {
  return degrees * M_PI / 180.0;
}

// ∫ over the polygon of cos θ dω seen from x with normal n, the polygon wholly above x's horizon (Lambert
// 1760: ½ Σ over its edges of the angle each subtends times n · the unit normal of the plane through x and
// the edge).
inline double ProjectedSolidAngle(const D3& x, const D3& n, const std::vector<D3>& polygon) {
  double sum = 0.0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const D3 a = glm::normalize(polygon[i] - x), b = glm::normalize(polygon[(i + 1) % polygon.size()] - x);
    const D3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (len > 0.0) sum += std::atan2(len, glm::dot(a, b)) * glm::dot(n, c / len);
  }
  return 0.5 * std::fabs(sum);
}

// ---- The reference at one static frame, and its claims ----

struct Rendered {
  GBuffer g;           // the frame's primary hits
  ReferenceImage ref;  // the reference over them, with its per-pixel standard errors
};

inline Rendered Render(const Sequence& seq, const FrameState& state, int bounces, int spp) {
  Rendered r;
  EmbreeScene scene(seq);
  scene.Update(state);
  TracePrimary(scene, state.camera, r.g);
  ReferenceParams params;
  params.samplesPerPixel = spp;
  params.indirectBounces = bounces;
  r.ref = RenderReference(seq, state, scene, r.g, params);
  return r;
}

// The claims over the pixels `truth` gives a value for (NaN: not compared). Each pixel's estimate is a mean
// of few paths that reach the light rarely (a few hits a replicate), so its replicate means are skewed and z
// = error / se is not Student's t: the claims are on sums over the pixels instead, which the central limit
// theorem makes normal whatever each pixel's distribution. Unbiased: the mean of the relative errors e_i =
// (v_i − t_i) / t_i is 0. Honest standard errors: E[(v_i − t_i)²] = Var v_i = E[se_i²] (se² is the
// replicates' unbiased variance of the mean), so the mean of d_i = (e_i² − se_i² / t_i²) is 0. Each by a
// z-test over the pixels at kClaimRate.
inline void ExpectAgreement(const Rendered& r, const std::function<double(size_t)>& truth, const std::string& what,
                            size_t minPixels) {
  const GBuffer& g = r.g;
  std::vector<double> relative, excess;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    const double t = truth(i);
    if (std::isnan(t)) continue;
    const double value = Y(D3(r.ref.mean.pixels[i])), se = r.ref.lumaStandardError[i];
    ASSERT_GT(se, 0.0) << what << ": pixel " << i << " has no spread (" << value << " against " << t << ")";
    const double e = value / t - 1.0;
    relative.push_back(e);
    excess.push_back(e * e - (se * se) / (t * t));
  }
  ASSERT_GE(relative.size(), minPixels) << what;
  const auto meanAndSe = [](const std::vector<double>& v) {
    double sum = 0.0, sumSq = 0.0;
    for (double x : v) sum += x;
    const double mean = sum / double(v.size());
    for (double x : v) sumSq += (x - mean) * (x - mean);
    return std::pair<double, double>(mean, std::sqrt(sumSq / double(v.size() - 1) / double(v.size())));
  };
  const auto [bias, biasSe] = meanAndSe(relative);
  const auto [honesty, honestySe] = meanAndSe(excess);
  double meanSq = 0.0;
  for (double e : relative) meanSq += e * e;
  meanSq /= double(relative.size());
  const double q = test::NormalQuantileUpper(0.5 * kClaimRate);
  std::printf(
      "  %-48s px %5zu  rel.err %+.3f%% (se %.3f%%)  RMS rel.err %.2f%%, excess over se %+.2e (se %.1e)  "
      "paths %llu\n",
      what.c_str(), relative.size(), 100.0 * bias, 100.0 * biasSe, 100.0 * std::sqrt(meanSq), honesty,
      honestySe, static_cast<unsigned long long>(r.ref.paths));
  EXPECT_LE(std::fabs(bias), q * biasSe) << what << ": mean relative error, z-test";
  EXPECT_LE(std::fabs(bias), kMaxRelativeError) << what;
  EXPECT_LT(biasSe, kMaxRelativeError / 3.0) << what << ": the bound on the relative error has no power";
  EXPECT_LE(std::fabs(honesty), q * honestySe)
      << what << ": squared errors against the standard errors, z-test";
}

// ---- ReSTIR GI's frames (Pipeline::RenderIndirect) of a static scene ----

// A static scene as every frame of ReSTIR GI sees it: the same view, each pixel reprojecting onto itself.
struct StaticGiScene {
  const Sequence& seq;                    // the scene, outliving this
  const FrameState& state;                // its one state, every frame's and every previous frame's
  EmbreeScene scene;                      // built for `state`
  GBuffer g;                              // the primary hits, reprojected onto themselves
  std::unique_ptr<LightSampler> lights;   // the direct light's sampler over the scene's light triangles
  std::vector<Bsdf> bsdfs;                // one per material
  Sky sky;                                // the state's sky (empty: none)

  StaticGiScene(const Sequence& s, const FrameState& st) : seq(s), state(st), scene(s) {
    scene.Update(state);
    TracePrimary(scene, state.camera, g);
    const GBuffer previous = g;
    Reproject(state, state, previous, scene.LightObjectId(), ReprojectionParams{}, g);
    lights = std::make_unique<LightSampler>(scene.LightTriangles(), LightSelection::kPower);
    bsdfs = MaterialBsdfs(seq);
    sky = MakeSky(seq, state);
  }
  // Seed k's frame f as the pipeline's passes see it (reservoirs carried from frame f − 1).
  FrameInputs Inputs(int k, int f) const {
    FrameInputs in;
    in.state = &state;
    in.scene = &scene;
    in.gbuffer = &g;
    in.lights = lights.get();
    in.materials = &bsdfs;
    in.sky = sky;
    in.previousSky = sky;
    if (f > 0) in.previousState = &state, in.previousGbuffer = &g, in.previousLights = &scene.LightTriangles();
    in.seed = static_cast<uint32_t>(k);
    in.frame = static_cast<uint32_t>(f);
    return in;
  }
  // Seed k's GI frame f through `pipeline` (its reservoirs carried from frame f − 1): the reservoirs' image plus the
  // paths through a vertex that is not reconnected, as FrameLoop::RenderPreset adds them.
  ImageRgb Frame(Pipeline& pipeline, int k, int f) const {
    const FrameInputs in = Inputs(k, f);
    uint64_t rays = 0;
    IndirectVertices paths =
        SecondaryVertices(seq, state, scene, g, pipeline.Settings().indirect.bounces, in.seed, in.frame, rays);
    const FrameResult gi = pipeline.RenderIndirect(in, paths.vertices);
    ImageRgb image = std::move(paths.unshifted);
    for (size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] += gi.image.pixels[i];
    return image;
  }
  // The whole frame, as FrameLoop::RenderPreset adds it: the preset's direct light (RenderFrame, first, as the frame
  // loop calls it), without what the primary ray sees emitted, plus Frame's indirect light.
  ImageRgb WholeFrame(Pipeline& pipeline, int k, int f) const {
    ImageRgb image = pipeline.RenderFrame(Inputs(k, f)).image;
    const ImageRgb indirect = Frame(pipeline, k, f);
    for (size_t i = 0; i < image.pixels.size(); ++i)
      image.pixels[i] += indirect.pixels[i] - DirectEmission(g, i, scene.LightTriangles());
    return image;
  }
};

// Seed k's indirect light after `frames` frames of a static scene, each frame's paths (SecondaryVertices) resampled
// by the preset's GI passes with the previous frame's reservoirs.
// With `whole`, the whole frame but what the primary ray sees emitted (StaticGiScene::WholeFrame).
inline std::vector<ImageRgb> GiFrames(const Sequence& seq, const FrameState& state, const PipelineSettings& settings,
                                      int frames, int seeds, GBuffer& g, bool whole = false) {
  const StaticGiScene s(seq, state);
  g = s.g;
  std::vector<ImageRgb> out;
  for (int k = 0; k < seeds; ++k) {
    Pipeline pipeline(settings);
    ImageRgb last;
    for (int f = 0; f < frames; ++f) last = whole ? s.WholeFrame(pipeline, k, f) : s.Frame(pipeline, k, f);
    out.push_back(std::move(last));
  }
  return out;
}

// The bound on a GI frame mean's relative error: its standard error over 96 seeds is 0.4-0.5% on the floor.
inline constexpr double kGiMaxRelativeError = 0.02;

// Reuse makes neighbouring pixels' errors depend on each other, so the claim is on whole frames, which the seeds
// make independent: per seed, the mean relative error over the compared pixels, and over each of four bands of
// them (in pixel order, so that each band is a part of the view: a floor's near to far rows, a sphere's top to
// bottom), is 0 by Student's t-test over the seeds at kClaimRate / 5 each (Bonferroni over the five); and the
// frames' mean is within kGiMaxRelativeError.
inline void ExpectUnbiasedFrames(const std::vector<ImageRgb>& frames, const GBuffer& g,
                                 const std::function<double(size_t)>& truth, const std::string& what) {
  std::vector<size_t> compared;
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i) && !std::isnan(truth(i))) compared.push_back(i);
  ASSERT_GE(compared.size(), 400u) << what;
  constexpr int kBands = 4;
  const double n = double(frames.size());
  for (int band = -1; band < kBands; ++band) {
    const size_t begin = band < 0 ? 0 : compared.size() * band / kBands;
    const size_t end = band < 0 ? compared.size() : compared.size() * (band + 1) / kBands;
    double sum = 0.0, sumSq = 0.0;
    for (const ImageRgb& image : frames) {
      double e = 0.0;
      for (size_t j = begin; j < end; ++j) e += Y(D3(image.pixels[compared[j]])) / truth(compared[j]) - 1.0;
      e /= double(end - begin);
      sum += e;
      sumSq += e * e;
    }
    const double mean = sum / n, se = std::sqrt(std::max(0.0, (sumSq - n * mean * mean) / (n - 1.0)) / n);
    const double q = test::StudentTQuantileTwoSided(kClaimRate / (kBands + 1), n - 1.0);
    std::printf("  %-60s band %2d  rel.err %+.3f%% (se %.3f%%)\n", what.c_str(), band, 100.0 * mean, 100.0 * se);
    EXPECT_LE(std::fabs(mean), q * se) << what << " band " << band << ": mean relative error, t-test";
    if (band < 0) {
      EXPECT_LE(std::fabs(mean), kGiMaxRelativeError) << what;
      EXPECT_LT(se, kGiMaxRelativeError / 3.0) << what << ": the bound on the relative error has no power";
    }
  }
}

}  // namespace closed_form
}  // namespace restir
