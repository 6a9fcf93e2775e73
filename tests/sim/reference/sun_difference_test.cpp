// The sun under the difference estimator (ReferenceParams::differenceShadows; sim/reference/reference_samples.h
// SkySamples, reference_sky.h SunDifferenceConstant) on the shipped scene it is for: sun_street_pan's frame 0 (a
// street of buildings under a low sun and an environment map, shadows of every size), rendered by the reference with
// the estimator and without it. The estimator without it is the plain mixture of sun, environment and BSDF sampling
// that tests/sim/reference/sky_closed_form_test.cpp holds to closed forms; the estimator with it takes a diffuse
// pixel's sun as its exact contribution, L albedo sin²α cos θ, less what sampled shadows take, wherever the pixel's
// pilot saw the sun at every draw. Every surface pixel with a standard error on either side gives
// z = (with − without) / sqrt(se_with² + se_without²), and their mean z² must lie in tests/stats.h WelchZ2Band
// (false-failure rate 2e-4): a bias of the exact part, of the sun's MIS split, or of the mixture's reshaping moves it
// up; a standard error that hides the shadows the pilot missed moves it up too. Pixels where neither has a spread
// must agree to float rounding. The two renderings take independent random numbers (ReferenceParams::seed). Fixed
// seeds: a failure means a distribution changed. About 1.5 s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/reference/reference.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/sequence.h"
#include "stats.h"

namespace restir {
namespace {

TEST(SunDifference, AgreesWithThePlainSunOnSunStreetPan) {
  const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/sequences/sun_street_pan.json");
  ASSERT_TRUE(seq.sun.present);
  const FrameState state = Evaluate(seq, 0, 96, 54);
  EmbreeScene scene(seq);
  scene.Update(state);
  GBuffer g;
  TracePrimary(scene, state.camera, g);
  ReferenceParams params;
  params.samplesPerPixel = 256;
  const ReferenceImage with = RenderReference(seq, state, scene, g, params);
  params.differenceShadows = false;
  params.seed = 1;  // independent random numbers
  const ReferenceImage without = RenderReference(seq, state, scene, g, params);

  int pixels = 0, exact = 0, bothExact = 0, lower = 0, darkWith = 0, darkWithout = 0;
  double sumZ2 = 0.0, worst = 0.0;
  std::string worstPixel;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    const double a = Luminance(with.mean.pixels[i]), b = Luminance(without.mean.pixels[i]);
    const double sa = with.lumaStandardError[i], sb = without.lumaStandardError[i];
    if (sa == 0.0 && sb == 0.0) {
      ++bothExact;
      EXPECT_NEAR(a, b, 1e-6 * std::fabs(b)) << "pixel " << i;
      continue;
    }
    // A side whose samples all missed (exactly 0, no spread) has no standard error to test by: a pixel lit only
    // through a gap its budget rarely reaches. Both estimators leave a few such pixels at 256 samples (issue 40),
    // counted here: the estimator must not leave more of them than the plain one.
    if ((a == 0.0 && sa == 0.0) || (b == 0.0 && sb == 0.0)) {
      ++(a == 0.0 && sa == 0.0 ? darkWith : darkWithout);
      continue;
    }
    if (sa == 0.0) ++exact;
    if (sa < 0.5 * sb) ++lower;
    const double z = (a - b) / std::sqrt(sa * sa + sb * sb);

    sumZ2 += z * z;
    if (std::fabs(z) > worst) {
      worst = std::fabs(z);
      char buf[160];
      std::snprintf(buf, sizeof buf, "pixel (%zu, %zu): %.6g +- %.2g against %.6g +- %.2g", i % g.width,
                    i / g.width, a, sa, b, sb);
      worstPixel = buf;
    }
    ++pixels;
  }
  const double meanZ2 = sumZ2 / std::max(1, pixels);
  const test::Band band = test::WelchZ2Band(std::max(1, pixels));
  std::printf("  %d pixels (%d exact with the estimator, %d with under half the standard error), %d without a spread "
              "on either side, %d / %d dark with / without; mean z^2 %.3f in [%.3f, %.3f]; worst %s\n",
              pixels, exact, lower, bothExact, darkWith, darkWithout, meanZ2, band.lo, band.hi, worstPixel.c_str());
  EXPECT_LE(darkWith, darkWithout + 10);
  EXPECT_GE(pixels, 1000);
  EXPECT_GE(lower, pixels / 10);  // the estimator did take suns apart
  EXPECT_GE(meanZ2, band.lo);
  EXPECT_LE(meanZ2, band.hi) << "worst " << worstPixel;
}

}  // namespace
}  // namespace restir
