// The videos: Debian's ffmpeg (installed by scripts/setup.sh; a missing one fails these tests) turns the frames
// given into an H.264 MP4 that ffprobe reads back with their count and size, whose decoded frames hold the colours
// given (the BT.709 matrix and range are tagged as encoded), and whose bytes are the same on a second encode.
#include "sim/output/video.h"
#include "sim/util/atomic_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using restir::test::Shell;

std::string ReadAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Frame k: a flat colour that changes with k, and a white square that moves.
std::vector<unsigned char> TestFrame(int k, int w, int h) {
  std::vector<unsigned char> rgb(static_cast<size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      unsigned char* p = &rgb[(static_cast<size_t>(y) * w + x) * 3];
      const bool square = x >= 4 * k && x < 4 * k + 8 && y < 8;
      p[0] = square ? 255 : static_cast<unsigned char>(30 + 40 * k);
      p[1] = square ? 255 : static_cast<unsigned char>(200 - 30 * k);
      p[2] = square ? 255 : 90;
    }
  return rgb;
}

// ffmpeg's scratch files of this process left in the system's temporary directory.
int ScratchLeft() {
  const std::string prefix = "restir-sim-video-" + std::to_string(::getpid()) + "-";
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::temp_directory_path()))
    n += e.path().filename().string().rfind(prefix, 0) == 0;
  return n;
}

std::string Ffmpeg() {
  const std::optional<std::string> f = FindFfmpeg();
  EXPECT_TRUE(f) << "ffmpeg is missing: scripts/setup.sh installs Debian's ffmpeg, which this test needs";
  return f.value_or("");
}

TEST(Video, FfprobeReadsItsFramesAndSizeAndTheDecodedColoursAreTheFramesOwn) {
  const std::string ffmpeg = Ffmpeg();
  ASSERT_FALSE(ffmpeg.empty());
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-video-test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const int w = 64, h = 36, frames = 5;
  for (const char* name : {"a.mp4", "b.mp4"}) {
    VideoEncoder video(ffmpeg, (dir / name).string(), w, h, 30.0);
    for (int k = 0; k < frames; ++k) video.AddFrame(TestFrame(k, w, h));
    video.Finish();
  }
  EXPECT_EQ(ReadAll(dir / "a.mp4"), ReadAll(dir / "b.mp4")) << "the same frames encoded twice differ";
  for (const auto& e : fs::directory_iterator(dir))  // the videos, and WriteFileAtomic's own area
    EXPECT_TRUE(e.path().extension() == ".mp4" || e.path().filename() == ".restir-sim-tmp") << "left behind: " << e.path();
  EXPECT_EQ(ScratchLeft(), 0);

  const auto probe = Shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                           "stream=codec_name,width,height,pix_fmt,nb_read_frames -of default=noprint_wrappers=1 " +
                           (dir / "a.mp4").string() + " 2>&1");
  ASSERT_EQ(probe.status, 0) << probe.output;
  for (const char* want : {"codec_name=h264", "width=64", "height=36", "pix_fmt=yuv420p", "nb_read_frames=5"})
    EXPECT_NE(probe.output.find(want), std::string::npos) << want << " in " << probe.output;

  // Decoded back to RGB: the flat part of each frame within a few codes of its colour (4:2:0 and CRF 18 lose
  // little on flat colour; a wrong matrix or range moves it by 10 or more).
  const fs::path raw = dir / "decoded.rgb";
  const auto decode = Shell("ffmpeg -v error -y -i " + (dir / "a.mp4").string() + " -f rawvideo -pix_fmt rgb24 " +
                            raw.string() + " 2>&1");
  ASSERT_EQ(decode.status, 0) << decode.output;
  const std::string bytes = ReadAll(raw);
  ASSERT_EQ(bytes.size(), static_cast<size_t>(w) * h * 3 * frames);
  for (int k = 0; k < frames; ++k) {
    const std::vector<unsigned char> want = TestFrame(k, w, h);
    for (int y = 16; y < h; y += 5)
      for (int x = 2; x < w; x += 7)
        for (int c = 0; c < 3; ++c) {
          const size_t i = (static_cast<size_t>(k) * w * h + static_cast<size_t>(y) * w + x) * 3 + c;
          EXPECT_NEAR(static_cast<unsigned char>(bytes[i]), want[(static_cast<size_t>(y) * w + x) * 3 + c], 4)
              << "frame " << k << " pixel " << x << "," << y << " channel " << c;
        }
  }
}

TEST(Video, AFailingEncoderLeavesNoFileAndSaysSo) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-video-fail";
  fs::remove_all(dir);
  fs::create_directories(dir);
  EXPECT_THROW(VideoEncoder(Ffmpeg(), (dir / "odd.mp4").string(), 63, 36, 30.0), std::runtime_error);
  {
    VideoEncoder video("/bin/false", (dir / "x.mp4").string(), 64, 36, 30.0);
    try {
      for (int k = 0; k < 50; ++k) video.AddFrame(TestFrame(k % 5, 64, 36));
      video.Finish();
      ADD_FAILURE() << "an encoder that exits 1 was taken as a success";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("x.mp4"), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(fs::exists(dir / "x.mp4"));
  EXPECT_EQ(ScratchLeft(), 0);
  // An encoder that cannot be started (a directory): one OutputError naming the video, no scratch file left.
  try {
    VideoEncoder video(dir.string(), (dir / "y.mp4").string(), 64, 36, 30.0);
    ADD_FAILURE() << "a directory was started as the encoder";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind((dir / "y.mp4").string() + ": error: ", 0), 0u) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "y.mp4"));
  EXPECT_EQ(ScratchLeft(), 0);
}

// TMPDIR naming no directory: the scratch files go to /tmp and the video is made.
TEST(Video, ATmpdirThatIsNoDirectoryFallsBackToTmp) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("restir-video-tmpdir-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const char* old = std::getenv("TMPDIR");
  const std::string saved = old ? old : "";
  ::setenv("TMPDIR", (dir / "missing").string().c_str(), 1);
  {
    VideoEncoder video(Ffmpeg(), (dir / "v.mp4").string(), 64, 36, 30.0);
    for (int k = 0; k < 3; ++k) video.AddFrame(TestFrame(k, 64, 36));
    video.Finish();
  }
  if (old)
    ::setenv("TMPDIR", saved.c_str(), 1);
  else
    ::unsetenv("TMPDIR");
  EXPECT_TRUE(fs::is_regular_file(dir / "v.mp4"));
  EXPECT_FALSE(fs::exists(dir / "missing"));
  EXPECT_EQ(ScratchLeft(), 0);
  fs::remove_all(dir);
}

TEST(Video, RestirFfmpegChoosesTheEncoderAndEmptyMeansNone) {
  const char* old = std::getenv("RESTIR_FFMPEG");
  const std::string saved = old ? old : "";
  setenv("RESTIR_FFMPEG", "", 1);
  EXPECT_FALSE(FindFfmpeg());
  setenv("RESTIR_FFMPEG", "/bin/true", 1);
  EXPECT_EQ(FindFfmpeg().value_or(""), "/bin/true");
  setenv("RESTIR_FFMPEG", "/no/such/ffmpeg", 1);
  EXPECT_FALSE(FindFfmpeg());
  if (old) setenv("RESTIR_FFMPEG", saved.c_str(), 1);
  else unsetenv("RESTIR_FFMPEG");
}

TEST(Canvas, HalvingAveragesEachTwoByTwoBlockRounded) {
  Canvas c(5, 3, 0);  // odd: the last column and row are dropped
  for (size_t i = 0; i < c.rgb.size(); ++i) c.rgb[i] = static_cast<unsigned char>(i * 7 % 256);
  const Canvas half = Halve(c);
  ASSERT_EQ(half.width, 2);
  ASSERT_EQ(half.height, 1);
  for (int x = 0; x < 2; ++x)
    for (int ch = 0; ch < 3; ++ch) {
      int sum = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) sum += c.rgb[((dy * 5) + 2 * x + dx) * 3 + ch];
      EXPECT_EQ(half.rgb[x * 3 + ch], (sum + 2) / 4);
    }
  Canvas big(4, 4, 7);
  big.Paste(c, 2, -1);  // clipped on two sides
  EXPECT_EQ(big.rgb[0], 7);
  EXPECT_EQ(big.rgb[(0 * 4 + 2) * 3], c.rgb[(1 * 5 + 0) * 3]);
}

}  // namespace
}  // namespace restir
