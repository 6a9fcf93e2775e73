// A scene translated far from the world origin renders as it does at the origin, within the float precision of
// its geometry there (issue 13): the flagship's first frames (camera pan, barred window, 72 lights, glossy and
// diffuse) moved by 10 m, 1 km and 10 km. Random numbers are keyed by pixel, not position, so the two runs use
// the same ones; what differs is only how finely a float can place each point, so
// - the G-buffer: the same surface (object and face) at all but a few silhouette pixels; positions within a few
//   float spacings of the translated ones; depths and reprojected coordinates within float rounding;
// - `ris` (no history, no neighbours): nearly every pixel equal to a percent; it differs only where a sample's
//   selection or visibility sits on a boundary that float rounding moves;
// - every preset: the same image mean. Reuse carries each such flip into neighbours and later frames, so
//   individual pixels may differ widely (stochastic pairwise MIS most: its cell draws are discrete choices among
//   60 pixels), but not systematically: the pixels' differences d_i must sum to within 4 sqrt(Σ d_i²) of zero
//   (plus 1e-4 of the mean), as differences of either sign at random would.
// At 10 km the float spacing (1 mm) approaches the scale of the bars (5 cm) and light gaps: the ris bound
// loosens to what that allows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/run/frame_loop.h"
#include "sim/estimator/presets.h"

namespace restir {
namespace {

Sequence Translated(Sequence seq, const Vec3& t) {
  for (Object& o : seq.objects)
    for (TransformKey& k : o.keys) k.translate += t;
  for (Light& l : seq.lights)
    for (Vec3& v : l.vertices) v += t;
  for (CameraKey& k : seq.cameraKeys) {
    k.position += t;
    k.lookAt += t;
  }
  return seq;
}

struct Tolerance {
  double distance;      // metres from the origin
  double silhouette;    // fraction of pixels whose surface may differ
  double risPixelsOff;  // fraction of ris pixels more than 1% (and 1e-3 absolute) apart
};


class Translation : public ::testing::TestWithParam<Tolerance> {};

TEST_P(Translation, FlagshipRendersAsAtTheOrigin) {
  const Tolerance tol = GetParam();
  const Vec3 t = static_cast<float>(tol.distance) * glm::normalize(Vec3(0.8f, 0.36f, -0.48f));
  const Sequence near = LoadSequence("sequences/window_bars_pan.json");
  const Sequence far = Translated(near, t);
  const int w = 96, h = 54;
  FrameLoop a(near, w, h), b(far, w, h);
  std::vector<Pipeline> pa, pb;
  for (const Preset& p : AllPresets()) pa.emplace_back(p.settings), pb.emplace_back(p.settings);
  const float spacing = std::nextafter(static_cast<float>(tol.distance + 10.0), INFINITY) -
                        static_cast<float>(tol.distance + 10.0);
  for (int frame = 0; frame < 3; ++frame) {
    a.BeginFrame(frame);
    b.BeginFrame(frame);
    const GBuffer& ga = a.Gbuffer();
    const GBuffer& gb = b.Gbuffer();
    size_t differentSurface = 0, surfaces = 0;
    double worstPosition = 0.0, worstNormal = 0.0, worstDepth = 0.0, worstReprojection = 0.0;
    for (size_t i = 0; i < ga.Size(); ++i) {
      // Another object, or another face of it (normals of one face differ by float rounding only).
      const double normalDifference = glm::length(ga.GeometricNormal(i) - gb.GeometricNormal(i));
      if (ga.objectId[i] != gb.objectId[i] || normalDifference > 0.05) {
        ++differentSurface;
        continue;
      }
      if (ga.objectId[i] < 0) continue;
      ++surfaces;
      const glm::dvec3 pa3(ga.Position(i)), pb3(gb.Position(i));
      worstPosition = std::max(worstPosition, glm::length(pb3 - glm::dvec3(t) - pa3) / spacing);
      worstNormal = std::max(worstNormal, normalDifference);
      worstDepth = std::max(worstDepth, std::fabs(double(ga.depth[i]) - gb.depth[i]) / ga.depth[i]);
      if (ga.prevValid[i] && gb.prevValid[i])
        worstReprojection = std::max({worstReprojection, std::fabs(double(ga.prevX[i]) - gb.prevX[i]),
                                      std::fabs(double(ga.prevY[i]) - gb.prevY[i])});
    }
    std::printf("%g m, frame %d: %zu of %zu pixels on another surface; position %.1f spacings, normal %.2g, "
                "depth %.2g, reprojection %.2g px\n",
                tol.distance, frame, differentSurface, ga.Size(), worstPosition, worstNormal, worstDepth,
                worstReprojection);
    EXPECT_LE(double(differentSurface), tol.silhouette * ga.Size()) << frame;
    // A few spacings: the camera's own basis and each vertex are rounded at that scale.
    EXPECT_LE(worstPosition, 16.0) << frame;
    // A face's normal from vertices rounded to `spacing`: the sphere's smallest edges are 2 cm.
    EXPECT_LT(worstNormal, 1e-5 + 50.0 * spacing) << frame;
    EXPECT_LT(worstDepth, 1e-6 + 32.0 * spacing) << frame;
    // Pixels are 4 cm across at the bars: 50 spacings at 1 km are 3 mm, a thirteenth of a pixel.
    EXPECT_LT(worstReprojection, 1e-4 + 50.0 * spacing) << frame;

    for (size_t k = 0; k < pb.size(); ++k) {
      const FrameResult ra = a.Render(pa[k], 11), rb = b.Render(pb[k], 11);
      double sumA = 0.0, sumDifference = 0.0, sumSquares = 0.0;
      size_t off = 0;
      for (size_t i = 0; i < ra.image.pixels.size(); ++i) {
        const double la = Luminance(ra.image.pixels[i]), lb = Luminance(rb.image.pixels[i]);
        sumA += la;
        sumDifference += lb - la;
        sumSquares += (lb - la) * (lb - la);
        off += std::fabs(la - lb) > std::max(1e-3, 0.01 * std::max(la, lb));
      }
      const double bound = 1e-4 * sumA + 4.0 * std::sqrt(sumSquares);
      const std::string& name = AllPresets()[k].name;
      if (frame == 2)
        std::printf("  %-16s mean luminance %+.3f%% (bound %.3f%%), %.2f%% of pixels more than 1%% apart\n",
                    name.c_str(), 100.0 * sumDifference / sumA, 100.0 * bound / sumA,
                    100.0 * off / ra.image.pixels.size());
      EXPECT_LE(std::fabs(sumDifference), bound) << name << " frame " << frame;
      if (name == "ris") {
        EXPECT_LE(double(off), tol.risPixelsOff * ra.image.pixels.size()) << "frame " << frame;
      }
    }
    a.EndFrame();
    b.EndFrame();
    (void)surfaces;
  }
}

INSTANTIATE_TEST_SUITE_P(Distances, Translation,
                         ::testing::Values(Tolerance{10.0, 0.001, 0.002}, Tolerance{1000.0, 0.002, 0.01},
                                           Tolerance{10000.0, 0.005, 0.1}),
                         [](const ::testing::TestParamInfo<Tolerance>& info) {
                           return std::to_string(static_cast<int>(info.param.distance)) + "m";
                         });

}  // namespace
}  // namespace restir
