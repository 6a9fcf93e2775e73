// The report's motion sections from a run's scrub PNGs: the crop encloses what was revealed (grown when small, the
// densest part when large), starts at the frame that revealed most, and its images are the frames' own pixels
// enlarged; nothing is shown where nothing was revealed or the PNGs are missing.
#include "sim/output/report_motion.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "sim/output/scrub_frames.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

struct Rect {
  int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
};

// A fake run of `frames` frames at w x h with one preset "p": each frame's estimate a gradient that moves, and the
// masks revealing `reveals[f]` (disoccluded in that frame, recently revealed in the next two).
MotionInputs FakeRun(const std::string& name, int w, int h, int frames, const std::vector<std::vector<Rect>>& reveals) {
  MotionInputs in;
  in.outDir = (fs::path(::testing::TempDir()) / name).string();
  fs::remove_all(in.outDir);
  fs::create_directories(in.outDir);
  in.width = w, in.height = h, in.hasReference = true, in.presets = {"p"};
  std::vector<std::vector<uint8_t>> now(frames, std::vector<uint8_t>(static_cast<size_t>(w) * h, 0));
  for (int f = 0; f < frames; ++f)
    for (const Rect& r : f < static_cast<int>(reveals.size()) ? reveals[f] : std::vector<Rect>{})
      for (int y = r.y0; y < r.y1; ++y)
        for (int x = r.x0; x < r.x1; ++x) now[f][y * size_t(w) + x] = 1;
  for (int f = 0; f < frames; ++f) {
    in.frames.push_back(f);
    std::vector<uint8_t> recent(now[f].size(), 0);
    bool any = false;
    for (int g = std::max(0, f - 2); g <= f; ++g)
      for (size_t i = 0; i < recent.size(); ++i) recent[i] |= now[g][i], any = any || now[g][i];
    if (any) in.postRevealFrames.push_back(f);
    ImageRgb est(w, h), ref(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        est.pixels[y * size_t(w) + x] = Vec3(0.01f * ((x + 3 * f) % w), 0.02f * y, 0.3f);
        ref.pixels[y * size_t(w) + x] = Vec3(0.01f * x, 0.02f * y, 0.3f);
      }
    const std::vector<float> flip(now[f].size(), 0.25f);
    WriteScrubFrame(in.outDir, f, w, h, &ref, 1.0f, now[f], recent);
    WriteScrubPreset(in.outDir, "p", f, est, &ref, &flip, 1.0f);
  }
  return in;
}

bool Contains(const Crops& c, const Rect& r) {
  return c.x <= r.x0 && c.y <= r.y0 && c.x + c.width >= r.x1 && c.y + c.height >= r.y1;
}

TEST(Crops, ASmallRevealIsEnclosedGrownAndShownFromTheFrameThatRevealedItEnlarged) {
  const Rect reveal{30, 5, 36, 9};
  const MotionInputs in = FakeRun("restir-crop-small", 40, 30, 6, {{}, {}, {reveal}, {{31, 6, 33, 8}}});
  ASSERT_TRUE(ScrubFramesPresent(in));
  const Crops c = WriteCrops(in);
  ASSERT_TRUE(c.present);
  EXPECT_TRUE(Contains(c, reveal)) << c.x << "," << c.y << " " << c.width << "x" << c.height;
  EXPECT_EQ(c.width, 8);  // grown to the 8-pixel floor
  EXPECT_EQ(c.height, 8);
  EXPECT_EQ(c.frames, (std::vector<int>{2, 4}));  // the reveal, then 2 and 6 frames later where they exist
  EXPECT_EQ(c.scale, 40);  // min(430 / 8, 320 / 8)
  // The crop of the estimate is the scrub PNG's pixels, each repeated scale x scale times.
  ASSERT_GE(c.rows.size(), 2u);
  EXPECT_EQ(c.rows[0].first, "reference");
  EXPECT_EQ(c.rows[1].first, "p");
  const std::vector<unsigned char> src =
      ReadScrubPng(in.outDir + "/" + ScrubPresetPath("p", 4, ScrubLayer::kEstimate), 40, 30);
  const std::vector<unsigned char> crop =
      ReadScrubPng(in.outDir + "/" + c.rows[1].second[1], c.width * c.scale, c.height * c.scale);
  for (int y = 0; y < c.height * c.scale; y += 13)
    for (int x = 0; x < c.width * c.scale; x += 11)
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_EQ(crop[(static_cast<size_t>(y) * c.width * c.scale + x) * 3 + ch],
                  src[(static_cast<size_t>(c.y + y / c.scale) * 40 + c.x + x / c.scale) * 3 + ch]);
}

TEST(Crops, ALargeRevealShowsItsDensestQuarterAndNoRevealShowsNone) {
  const Rect blob{4, 20, 9, 25};
  const MotionInputs in = FakeRun("restir-crop-large", 48, 32, 5, {{}, {{0, 0, 48, 32}, blob}, {blob}});
  const Crops c = WriteCrops(in);
  ASSERT_TRUE(c.present);
  EXPECT_EQ(c.width, 12);  // a quarter of 48
  EXPECT_EQ(c.height, 8);  // a quarter of 32, at the floor
  EXPECT_TRUE(Contains(c, blob)) << c.x << "," << c.y << " " << c.width << "x" << c.height;
  EXPECT_EQ(c.frames.front(), 1);

  // A wide frame's crop stays small enough to be shown enlarged: at most 215 x 160, at least twice its size.
  const Rect far{900, 500, 905, 505};
  const MotionInputs wide = FakeRun("restir-crop-wide", 1000, 600, 5, {{}, {{0, 0, 1000, 600}, far}, {far}});
  const Crops cw = WriteCrops(wide);
  ASSERT_TRUE(cw.present);
  EXPECT_EQ(cw.width, 215);
  EXPECT_EQ(cw.height, 150);  // a quarter of 600
  EXPECT_EQ(cw.scale, 2);
  EXPECT_TRUE(Contains(cw, far)) << cw.x << "," << cw.y;

  const MotionInputs none = FakeRun("restir-crop-none", 16, 16, 3, {});
  EXPECT_FALSE(WriteCrops(none).present);
  std::ostringstream html;
  HtmlCrops(html, WriteCrops(none));
  EXPECT_NE(html.str().find("no crops"), std::string::npos);
}

TEST(ScrubFramesPresent, AnyMissingPngMeansNoMotionSections) {
  MotionInputs in = FakeRun("restir-scrub-present", 16, 8, 3, {});
  EXPECT_TRUE(ScrubFramesPresent(in));
  fs::remove(in.outDir + "/" + ScrubPresetPath("p", 1, ScrubLayer::kFlip));
  EXPECT_FALSE(ScrubFramesPresent(in));
  in.hasReference = false;  // without a reference only the estimate and the mask are needed
  EXPECT_TRUE(ScrubFramesPresent(in));
  in.presets = {"q"};
  EXPECT_FALSE(ScrubFramesPresent(in));
}

TEST(Videos, WithoutFfmpegThereAreNoneAndTheReportSaysWhy) {
  const MotionInputs in = FakeRun("restir-videos-none", 16, 8, 2, {});
  const char* old = std::getenv("RESTIR_FFMPEG");
  const std::string saved = old ? old : "";
  setenv("RESTIR_FFMPEG", "", 1);
  const Videos v = WriteVideos(in);
  if (old) setenv("RESTIR_FFMPEG", saved.c_str(), 1);
  else unsetenv("RESTIR_FFMPEG");
  EXPECT_TRUE(v.perPreset.empty());
  EXPECT_TRUE(v.grid.empty());
  EXPECT_NE(v.note.find("ffmpeg"), std::string::npos);
  EXPECT_FALSE(fs::exists(in.outDir + "/videos"));
  std::ostringstream html;
  HtmlVideos(html, v);
  EXPECT_NE(html.str().find("ffmpeg is not installed"), std::string::npos);
}

}  // namespace
}  // namespace restir
