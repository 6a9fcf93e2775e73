// Metrics against independent computations: OpenImageIO's own image comparison, hand-computed stability and
// flicker, the G-buffer's disocclusion flags (through the frame EXR), and the accumulation's reset rule.
#include <gtest/gtest.h>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "core/rng.h"
#include "sim/metrics/metrics.h"
#include "sim/run/runner.h"

namespace restir {
namespace {

OIIO::ImageBuf ToImageBuf(const ImageRgb& img) {
  OIIO::ImageBuf b(OIIO::ImageSpec(img.width, img.height, 3, OIIO::TypeDesc::FLOAT));
  b.set_pixels(OIIO::ROI(0, img.width, 0, img.height, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, img.pixels.data());
  return b;
}

// rmse is OpenImageIO's rms_error (over every pixel and channel) on random HDR images.
TEST(MetricsAgreement, RmseEqualsOpenImageIoCompare) {
  Sampler s(RngKey{3, 0, 0, static_cast<uint32_t>(RngPass::kTest)});
  ImageRgb a(37, 23), b(37, 23);
  for (size_t i = 0; i < a.Size(); ++i) {
    a.pixels[i] = Vec3(s.Next(), 10.0f * s.Next(), 0.01f * s.Next());
    b.pixels[i] = Vec3(s.Next(), 10.0f * s.Next(), 0.01f * s.Next());
  }
  const OIIO::ImageBufAlgo::CompareResults c = OIIO::ImageBufAlgo::compare(ToImageBuf(a), ToImageBuf(b), 0.0f, 0.0f);
  const AccuracyMetrics m = MeasureAccuracy(a, b);
  EXPECT_NEAR(m.rmse, c.rms_error, 1e-6 * c.rms_error);
}

// Two 2x1 frames with hand-computed luminance differences.
TEST(MetricsAgreement, StabilityAndFlickerMatchHandComputedValues) {
  ImageRgb i0(2, 1), i1(2, 1), r0(2, 1), r1(2, 1);
  i0.pixels = {Vec3(1.0f), Vec3(0.0f)};
  i1.pixels = {Vec3(3.0f), Vec3(1.0f)};  // ΔY = 2, 1
  r0.pixels = {Vec3(1.0f), Vec3(1.0f)};
  r1.pixels = {Vec3(2.0f), Vec3(1.0f)};  // ΔY_ref = 1, 0
  EXPECT_NEAR(StabilityLumaRmse(i1, i0), std::sqrt((4.0 + 1.0) / 2.0), 1e-6);
  EXPECT_NEAR(Flicker(i1, i0, r1, r0), std::sqrt((1.0 + 1.0) / 2.0), 1e-6);
}

std::map<std::string, double> Columns(const FrameMetricsRow& row) {
  return std::map<std::string, double>(row.values.begin(), row.values.end());
}

// On the second frame of a run the "last 4 frames" mask is exactly the G-buffer's disocclusion flags (no older
// reveal exists yet): relmse_disocc recomputed from the frame EXR's own layers over disocclusion.Y = 1 equals the
// column, and rest + disocc partition the pixels. Later frames' masks contain the current flags.
TEST(MetricsAgreement, DisoccludedMetricsUseTheGbufferFlags) {
  const std::string out = (std::filesystem::path(::testing::TempDir()) / "restir-mask-agree").string();
  std::filesystem::remove_all(out);
  RunOptions o;
  o.sequencePath = "sequences/window_bars_pan.json";
  o.presets = {"ris"};
  o.frameEnd = 4;
  o.width = 160, o.height = 90;
  o.referenceSpp = 16;
  o.outDir = out;
  o.cacheDir = out + "/cache";
  o.progress = false;
  o.report = false;
  o.imageFrames = *ParseImageFrames("1:2");  // the frame whose EXR is read below
  const RunResult r = restir::Run(o);
  ASSERT_EQ(r.rows.size(), 4u);
  for (int f = 1; f < 4; ++f) {
    const auto c = Columns(r.rows[f]);
    EXPECT_GT(c.at("disocc_fraction"), 0.0) << f;
    EXPECT_GE(c.at("disocc_recent_fraction"), c.at("disocc_fraction")) << f;
    if (f == 1) {
      EXPECT_EQ(c.at("disocc_recent_fraction"), c.at("disocc_fraction"));
    }
  }
  OIIO::ImageBuf exr(out + "/frames/ris/0001.exr");
  ASSERT_TRUE(exr.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << exr.geterror();
  const OIIO::ImageSpec& spec = exr.spec();
  const int d = spec.channelindex("disocclusion.Y"), ref = spec.channelindex("reference.R");
  ASSERT_GE(d, 0);
  ASSERT_GE(ref, 0);
  double rel = 0.0;
  size_t n = 0, flagged = 0;
  for (int y = 0; y < spec.height; ++y)
    for (int x = 0; x < spec.width; ++x) {
      if (exr.getchannel(x, y, 0, d) == 0.0f) continue;
      ++flagged;
      for (int ch = 0; ch < 3; ++ch) {
        const double e = exr.getchannel(x, y, 0, ch), rv = exr.getchannel(x, y, 0, ref + ch);
        rel += (e - rv) * (e - rv) / (rv * rv + 0.01);
        ++n;
      }
    }
  const auto c1 = Columns(r.rows[1]);
  EXPECT_EQ(double(flagged) / (spec.width * spec.height), c1.at("disocc_fraction"));
  EXPECT_NEAR(c1.at("relmse_disocc"), rel / double(n), 1e-6 * c1.at("relmse_disocc"));
  // disocc and rest partition the pixels: their relmse values average back to the whole frame's.
  const double fd = c1.at("disocc_recent_fraction");
  EXPECT_NEAR(fd * c1.at("relmse_disocc") + (1.0 - fd) * c1.at("relmse_rest"), c1.at("relmse"),
              1e-6 * c1.at("relmse"));
}

// The running mean restarts whenever the camera, an object or a light changes: every frame of the panning
// flagship is its own running mean (accum_rmse = rmse), while the static room accumulates 1, 2, 3 frames.
TEST(MetricsAgreement, AccumulationResetsWhenTheCameraMoves) {
  for (const char* seq : {"sequences/window_bars_pan.json", "sequences/static_room.json"}) {
    const std::string out = (std::filesystem::path(::testing::TempDir()) / "restir-accum").string();
    std::filesystem::remove_all(out);
    RunOptions o;
    o.sequencePath = seq;
    o.presets = {"ris"};
    o.frameEnd = 3;
    o.width = 48, o.height = 27;
    o.referenceSpp = 16;
    o.outDir = out;
    o.cacheDir = out + "/cache";
    o.progress = false;
    o.report = false;
    o.writeImages = false;
    const RunResult r = restir::Run(o);
    const bool moving = std::string(seq).find("pan") != std::string::npos;
    for (int f = 0; f < 3; ++f) {
      const auto c = Columns(r.rows[f]);
      EXPECT_EQ(c.at("accum_frames"), moving ? 1.0 : f + 1.0) << seq << " frame " << f;
      if (moving || f == 0) {
        EXPECT_NEAR(c.at("accum_rmse"), c.at("rmse"), 1e-6 * c.at("rmse")) << seq;
      } else {
        EXPECT_LT(c.at("accum_rmse"), c.at("rmse")) << seq;  // the mean of independent ris frames
      }
    }
  }
}

}  // namespace
}  // namespace restir
