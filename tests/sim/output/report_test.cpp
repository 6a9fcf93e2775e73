// summary.json and report.html (sim/output/report.h): hand-computed summaries of a synthetic metrics.csv, recovery time
// on a series with a known answer, the HTML's plots and rows, determinism, bad input, and a real run rendered in
// headless Chromium.
#include "sim/output/report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "sim/output/scrub_frames.h"
#include "sim/scene/sequence.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

// Headless Chromium from disk, with nothing of its own reaching the network.
const std::string kChromiumFlags =
    " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking "
    "--disable-component-update --disable-sync";

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / (name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}

std::string ReadText(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

// Preset a: four frames with a reveal at frames 1-2; preset b: constant, never disoccluded. `flip` and
// `brand_new_metric` stand for columns this code has never heard of: they must be summarized like any other.
const char* kSyntheticCsv =
    "frame,preset,ms_frame,relmse,relmse_disocc,luma_sum,reference_luma_sum,disocc_recent_fraction,flip,"
    "brand_new_metric,image_hash\n"
    "0,a,10,0.1,9,1,2,0,0.5,1,00000000000000a0\n"
    "0,b,5,0.5,0,3,3,0,0.25,2,00000000000000b0\n"
    "1,a,20,0.2,0.9,2,2,0.5,0.5,2,00000000000000a1\n"
    "1,b,5,0.5,0,3,3,0,0.25,2,00000000000000b1\n"
    "2,a,30,0.3,0.4,3,2,0.25,0.25,3,00000000000000a2\n"
    "2,b,5,0.5,0,3,3,0,0.25,2,00000000000000b2\n"
    "3,a,40,0.4,7,4,2,0,0.75,6,00000000000000a3\n"
    "3,b,5,0.5,0,3,3,0,0.25,2,00000000000000b3\n";

fs::path SyntheticRun(const std::string& name) {
  const fs::path dir = FreshDir(name);
  WriteText(dir / "metrics.csv", kSyntheticCsv);
  WriteText(dir / "run.json", "{\n  \"sequence\": {\"name\": \"synthetic\", \"path\": \"s.json\"},\n"
                              "  \"resolution\": [4, 2],\n  \"seed\": 3\n}\n");
  return dir;
}

TEST(Report, SummaryMeansEqualHandComputedValues) {
  const fs::path dir = SyntheticRun("restir-report-summary");
  WriteReport(dir.string());
  const nlohmann::json s = nlohmann::json::parse(ReadText(dir / "summary.json"));
  EXPECT_EQ(s["sequence"], "synthetic");
  const nlohmann::json& a = s["presets"]["a"];
  EXPECT_EQ(a["frames"], 4);
  // Timings leave out the first frame (sim/metrics/summary.h MeanSkipsFirstFrame): (20 + 30 + 40) / 3.
  EXPECT_NEAR(a["mean"]["ms_frame"].get<double>(), 30.0, 1e-12);
  EXPECT_NEAR(a["mean"]["relmse"].get<double>(), 0.25, 1e-12);
  EXPECT_NEAR(a["mean"]["relmse_disocc"].get<double>(), (9 + 0.9 + 0.4 + 7) / 4.0, 1e-12);
  EXPECT_NEAR(a["mean"]["flip"].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(a["mean"]["brand_new_metric"].get<double>(), 3.0, 1e-12);
  EXPECT_FALSE(a["mean"].contains("image_hash"));
  EXPECT_FALSE(a["mean"].contains("frame"));
  // Post-reveal window: frames 1 and 2 (disocc_recent_fraction > 0), every *_disocc column.
  EXPECT_EQ(a["post_reveal"]["frames"], 2);
  EXPECT_NEAR(a["post_reveal"]["mean"]["relmse_disocc"].get<double>(), (0.9 + 0.4) / 2.0, 1e-12);
  // s = 30 ms; efficiency = 1 / (0.25 * 0.030) = 133.33.
  EXPECT_NEAR(a["seconds_per_frame"].get<double>(), 0.030, 1e-15);
  EXPECT_NEAR(a["efficiency"].get<double>(), 1.0 / (0.25 * 0.030), 1e-9);
  // Σ luma_sum / Σ reference_luma_sum = 10 / 8.
  EXPECT_NEAR(a["luma_ratio_accumulated"].get<double>(), 1.25, 1e-12);
  // Steady = relmse of frame 3 (frame 0, the first, has no history) = 0.4, threshold 0.8: frame 1 (0.9) is
  // above, frame 2 (0.4) below.
  EXPECT_NEAR(a["recovery"]["steady_relmse"].get<double>(), 0.4, 1e-12);
  ASSERT_EQ(a["recovery"]["windows"].size(), 1u);
  EXPECT_EQ(a["recovery"]["windows"][0]["reveal_frame"], 1);
  EXPECT_EQ(a["recovery"]["windows"][0]["frames_to_recover"], 1);

  const nlohmann::json& b = s["presets"]["b"];
  EXPECT_NEAR(b["mean"]["relmse"].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(b["efficiency"].get<double>(), 1.0 / (0.5 * 0.005), 1e-9);
  EXPECT_NEAR(b["luma_ratio_accumulated"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(b["post_reveal"]["frames"], 0);
  EXPECT_TRUE(b["post_reveal"]["mean"]["relmse_disocc"].is_null());  // no post-reveal frame: no mean
  EXPECT_TRUE(b["recovery"]["windows"].empty());
}

TEST(Report, RecoveryCountsFramesUntilDisoccludedErrorIsWithinTwiceSteady) {
  // Steady frames (no recent disocclusion, the first left out: its 50 is the no-history start-up) have relmse 1,
  // so the threshold is 2. The first reveal (frames 3-6)
  // recovers two frames after it (relmse_disocc 10, 5, 1.5); the second (frames 9-10) never does.
  const std::vector<int> frames{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  const std::vector<double> recent{0, 0, 0, 0.1, 0.1, 0.1, 0.1, 0, 0, 0.2, 0.2, 0};
  const std::vector<double> relmse{50, 1, 1, 3, 2, 1, 1, 1, 1, 4, 3, 1};
  const std::vector<double> disocc{0, 0, 0, 10, 5, 1.5, 1, 0, 0, 10, 9, 0};
  const Recovery r = ComputeRecovery(frames, recent, relmse, disocc);
  EXPECT_EQ(r.steadyRelmse, 1.0);
  EXPECT_FALSE(r.steadyFromAllFrames);
  ASSERT_EQ(r.windows.size(), 2u);
  EXPECT_EQ(r.windows[0].startFrame, 3);
  EXPECT_EQ(r.windows[0].length, 4);
  EXPECT_EQ(r.windows[0].framesToRecover, 2);
  EXPECT_EQ(r.windows[1].startFrame, 9);
  EXPECT_EQ(r.windows[1].length, 2);
  EXPECT_EQ(r.windows[1].framesToRecover, -1);

  // A camera that never stops revealing: one window, steady level from every frame but the first (median of
  // 1, 3, 2 = 2, threshold 4).
  const Recovery all = ComputeRecovery({0, 1, 2, 3}, {0.1, 0.1, 0.1, 0.1}, {40, 1, 3, 2}, {20, 6, 5, 1});
  EXPECT_TRUE(all.steadyFromAllFrames);
  EXPECT_EQ(all.steadyRelmse, 2.0);
  ASSERT_EQ(all.windows.size(), 1u);
  EXPECT_EQ(all.windows[0].framesToRecover, 3);  // 6 and 5 > 4, 1 <= 4

  // A gap in the frames splits a window.
  const Recovery gap = ComputeRecovery({0, 1, 5, 6}, {0.1, 0.1, 0.1, 0.1}, {1, 1, 1, 1}, {9, 9, 1, 9});
  ASSERT_EQ(gap.windows.size(), 2u);
  EXPECT_EQ(gap.windows[0].framesToRecover, -1);
  EXPECT_EQ(gap.windows[1].startFrame, 5);
  EXPECT_EQ(gap.windows[1].framesToRecover, 0);
}

TEST(Report, HtmlHasOneSvgPerPlottedMetricAndOneSummaryRowPerPreset) {
  const fs::path dir = SyntheticRun("restir-report-html");
  WriteReport(dir.string());
  const std::string html = ReadText(dir / "report.html");
  // Plotted metrics present in the synthetic file: relmse, flip, relmse_disocc, ms_frame, disocc_recent_fraction.
  size_t plotted = 0;
  const MetricsTable t = ReadMetricsCsv((dir / "metrics.csv").string());
  for (const std::string& m : ReportPlotMetrics())
    if (t.Column(m) >= 0) {
      ++plotted;
      EXPECT_EQ(Count(html, "<svg class=\"plot\" data-metric=\"" + m + "\""), 1u) << m;
    }
  EXPECT_EQ(plotted, 5u);
  // Besides the per-frame plots, speed against error: relmse and flip against ms/frame, a marker per preset.
  EXPECT_EQ(Count(html, "<svg"), plotted + 2);
  EXPECT_EQ(Count(html, "<svg class=\"speed\" data-metric=\"relmse\""), 1u);
  EXPECT_EQ(Count(html, "<svg class=\"speed\" data-metric=\"flip\""), 1u);
  EXPECT_EQ(Count(html, "stroke-width=\"1.5\" data-preset="), plotted * 2);  // a polyline per preset per plot
  EXPECT_EQ(Count(html, "<tr class=\"summary-row\""), 2u);
  EXPECT_NE(html.find("<tr class=\"summary-row\" data-preset=\"a\"><td>a</td>"), std::string::npos);
  EXPECT_NE(html.find("<tr class=\"summary-row\" data-preset=\"b\"><td>b</td>"), std::string::npos);
  EXPECT_NE(html.find("<th>flip</th>"), std::string::npos);                    // flip is present: its column shows
  EXPECT_NE(html.find("<title>ReSTIR Sim report: synthetic</title>"), std::string::npos);
  EXPECT_NE(html.find("&quot;seed&quot;: 3"), std::string::npos);             // run.json verbatim in the <pre>
  EXPECT_NE(html.find("--no-images"), std::string::npos);                      // no frames: says so
  EXPECT_EQ(html.find("<img"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);                         // self-contained
  EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org/2000/svg"));  // the SVG namespace only
  EXPECT_EQ(html.find("https://"), std::string::npos);
}

TEST(Report, WriteReportIsByteIdenticalWhenRepeated) {
  const fs::path dir = SyntheticRun("restir-report-determinism");
  WriteReport(dir.string());
  const std::string html = ReadText(dir / "report.html"), summary = ReadText(dir / "summary.json");
  WriteReport(dir.string());
  EXPECT_EQ(ReadText(dir / "report.html"), html);
  EXPECT_EQ(ReadText(dir / "summary.json"), summary);
  // Nothing but the two outputs (no temporaries left behind).
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 4u);  // metrics.csv, run.json, summary.json, report.html
}

TEST(Report, MalformedMetricsThrowsNamingFileAndLine) {
  const fs::path dir = FreshDir("restir-report-bad");
  WriteText(dir / "metrics.csv", "frame,preset,relmse\n0,a,0.5\n1,a,zero\n");
  try {
    WriteReport(dir.string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "metrics.csv").string() + ":3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("relmse"), std::string::npos) << e.what();
  }
  WriteText(dir / "metrics.csv", "frame,preset,relmse\n0,a,0.5,7\n");
  EXPECT_THROW(WriteReport(dir.string()), InputError);
  WriteText(dir / "metrics.csv", "frame,preset,relmse\n0,a,0.5\n0,a,0.6\n");  // a frame twice
  EXPECT_THROW(WriteReport(dir.string()), InputError);
  EXPECT_THROW(WriteReport((dir / "does-not-exist").string()), InputError);
  fs::remove(dir / "metrics.csv");
  EXPECT_THROW(WriteReport(dir.string()), InputError);
}

// ---- the binary, and the browser ----

using Result = restir::test::ShellResult;
using restir::test::Shell;
using restir::test::SimBinary;

TEST(ReportCli, BadOrMissingRunDirectoryExitsTwoNamingFileAndLine) {
  const fs::path dir = FreshDir("restir-report-cli-bad");
  WriteText(dir / "metrics.csv", "frame,preset,relmse\n0,a,0.5\n1,a\n");
  Result r = Shell(SimBinary() + " report " + dir.string() + " 2>&1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((dir / "metrics.csv").string() + ":3:"), std::string::npos) << r.output;
  EXPECT_EQ(Count(r.output, "\n"), 1u) << r.output;  // one message
  r = Shell(SimBinary() + " report " + (dir / "nope").string() + " 2>&1");
  EXPECT_EQ(r.status, 2) << r.output;
  r = Shell(SimBinary() + " report 2>&1");
  EXPECT_EQ(r.status, 2) << r.output;
}

// A frame file put in the place of a run's own (another resolution, another sequence's, one without the reference
// layers the run writes, a preview of another size) is refused with exit 2 naming the file and what differs from
// run.json, where the report showed it as the run's frame.
TEST(ReportCli, FramesThatAreNotTheRunsAreRefusedNamingTheDifference) {
  const fs::path dir = FreshDir("restir-report-cli-foreign");
  auto run = [&](const std::string& name, const std::string& args) {
    const Result r = Shell(SimBinary() + " run " + args + " --preset ris --frames 0:3 --no-progress --no-report " +
                           "--cache-dir " + (dir / "cache").string() + " --out " + (dir / name).string() + " 2>&1");
    EXPECT_EQ(r.status, 0) << r.output;
    return dir / name / "frames" / "ris";
  };
  const fs::path own = run("own", "sequences/smoke.json --resolution 48x27 --reference-spp 8");
  const fs::path smaller = run("smaller", "sequences/smoke.json --resolution 32x18 --reference-spp 8");
  const fs::path other = run("other", "sequences/static_room.json --resolution 48x27 --reference-spp 8");
  const fs::path bare = run("bare", "sequences/smoke.json --resolution 48x27 --no-reference");
  ASSERT_EQ(Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1").status, 0);
  const std::string ownExr = ReadText(own / "0001.exr"), ownPng = ReadText(own / "0001.png");
  struct Case {
    fs::path from;
    const char* file;
    const char* said;
  };
  for (const Case& c : {Case{smaller, "0001.exr", "32x18 pixels where run.json's resolution is 48x27"},
                        Case{other, "0001.exr", "rendered from sequence"},
                        Case{bare, "0001.exr", "no channel reference.R"},
                        Case{smaller, "0001.png", "a 64x18 preview where run.json's 48x27 run writes 96x27"}}) {
    fs::copy_file(c.from / c.file, own / c.file, fs::copy_options::overwrite_existing);
    const Result r = Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1");
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find((own / c.file).string() + ": error: not a frame of this run"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find(c.said), std::string::npos) << r.output;
    EXPECT_EQ(Count(r.output, "\n"), 1u) << r.output;
    std::ofstream(own / "0001.exr", std::ios::binary | std::ios::trunc) << ownExr;
    std::ofstream(own / "0001.png", std::ios::binary | std::ios::trunc) << ownPng;
  }
  EXPECT_EQ(Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1").status, 0);
  // The scrub PNGs the videos and crops are made from: another run's, or one cut short, is refused the same way.
  const fs::path scrub = dir / "own" / "scrub" / "presets" / "ris";
  const std::string ownScrub = ReadText(scrub / "0001_error.png");
  fs::copy_file(dir / "smaller" / "scrub" / "presets" / "ris" / "0001_error.png", scrub / "0001_error.png",
                fs::copy_options::overwrite_existing);
  Result r = Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((scrub / "0001_error.png").string() + ": error: not a frame of this run (32x18"),
            std::string::npos) << r.output;
  EXPECT_EQ(Count(r.output, "\n"), 1u) << r.output;
  std::ofstream(scrub / "0001_error.png", std::ios::binary | std::ios::trunc) << ownScrub.substr(0, ownScrub.size() / 2);
  r = Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((scrub / "0001_error.png").string() + ": error: cannot read"), std::string::npos)
      << r.output;
  EXPECT_EQ(Count(r.output, "\n"), 1u) << r.output;
  std::ofstream(scrub / "0001_error.png", std::ios::binary | std::ios::trunc) << ownScrub;
  EXPECT_EQ(Shell(SimBinary() + " report " + (dir / "own").string() + " 2>&1").status, 0);
}

// The run the browser tests load: smoke's 6 frames at 64 x 36 with two presets, into `out`.
bool RunSmokeForScrubber(const fs::path& dir, const fs::path& out) {
  const Result r = Shell(SimBinary() + " run sequences/smoke.json --preset ris,temporal --resolution 64x36 "
                                       "--reference-spp 32 --no-progress --cache-dir " +
                         (dir / "cache").string() + " --out " + out.string() + " 2>&1");
  EXPECT_EQ(r.status, 0) << r.output;
  return r.status == 0;
}

// Renders the report of a real run in Debian's headless Chromium (installed by scripts/setup.sh: a missing
// browser fails this test) and checks what a reader would see: a non-blank page, every plot with a polyline per
// preset, and every image it references on disk.
TEST(ReportBrowser, RealRunRendersInHeadlessChromiumWithPlotsAndImages) {
  const std::string chromium = "/usr/bin/chromium";
  ASSERT_EQ(::access(chromium.c_str(), X_OK), 0)
      << chromium << " is missing: scripts/setup.sh installs Debian's chromium package, which this test needs";
  const fs::path dir = FreshDir("restir-report-browser");
  const fs::path out = dir / "run";
  ASSERT_TRUE(RunSmokeForScrubber(dir, out));
  Result r = Shell(SimBinary() + " report " + out.string() + " 2>&1");
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_TRUE(fs::exists(out / "report.html"));
  ASSERT_TRUE(fs::exists(out / "summary.json"));

  // Generated images are deterministic too: a second report rewrites the same bytes.
  std::map<std::string, std::string> images;
  for (const auto& e : fs::recursive_directory_iterator(out / "report_images"))
    if (e.is_regular_file()) images[e.path().string()] = ReadText(e.path());
  EXPECT_FALSE(images.empty());
  r = Shell(SimBinary() + " report " + out.string() + " 2>&1");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const auto& [path, bytes] : images) EXPECT_EQ(ReadText(path), bytes) << path;

  const std::string flags = kChromiumFlags + " --window-size=1280,2000";
  const std::string url = "file://" + fs::absolute(out / "report.html").string();
  const fs::path shot = dir / "screenshot.png";
  const auto t0 = std::chrono::steady_clock::now();
  r = Shell("timeout 180 " + chromium + flags + " --user-data-dir=" + (dir / "profile-shot").string() +
            " --screenshot=" + shot.string() + " " + url + " 2>&1");
  EXPECT_EQ(r.status, 0) << r.output;
  const Result dom = Shell("timeout 180 " + chromium + flags + " --user-data-dir=" + (dir / "profile-dom").string() +
                           " --dump-dom " + url + " 2>/dev/null");
  EXPECT_EQ(dom.status, 0);
  std::fprintf(stderr, "chromium: %.1f s for screenshot and DOM\n",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());

  // The screenshot exists and is not one flat colour.
  ASSERT_TRUE(fs::exists(shot)) << r.output;
  auto in = OIIO::ImageInput::open(shot.string());
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec spec = in->spec();
  EXPECT_EQ(spec.width, 1280);
  std::vector<unsigned char> px(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, px.data()));
  size_t differing = 0;
  for (size_t i = 0; i < static_cast<size_t>(spec.width) * spec.height; ++i)
    for (int c = 0; c < std::min(3, spec.nchannels); ++c)
      if (px[i * spec.nchannels + c] != px[c]) {
        ++differing;
        break;
      }
  EXPECT_GT(differing, 1000u) << "the screenshot is (nearly) a single flat colour";

  // The DOM: one <svg class="plot"> per plotted metric present in metrics.csv, each with one polyline per preset.
  const MetricsTable t = ReadMetricsCsv((out / "metrics.csv").string());
  size_t plotted = 0;
  for (const std::string& m : ReportPlotMetrics()) plotted += t.Column(m) >= 0;
  EXPECT_GE(plotted, 9u);  // relmse, luma_rmse, flicker, stability, relmse_disocc, ms_frame, acceptance, disocc ...
  const std::string& html = dom.output;
  EXPECT_EQ(Count(html, "<svg class=\"plot\""), plotted) << html.substr(0, 2000);
  const std::regex svgRe("<svg class=\"plot\"[\\s\\S]*?</svg>");
  size_t svgs = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), svgRe); it != std::sregex_iterator(); ++it, ++svgs)
    EXPECT_EQ(Count(it->str(), "<polyline"), 2u) << it->str().substr(0, 200);
  EXPECT_EQ(svgs, plotted);
  EXPECT_EQ(Count(html, "class=\"summary-row\""), 2u);

  // Images: first, middle and last frame (0, 3, 5) x two presets x (preview, error, FLIP when the EXR has it);
  // each referenced file exists beside the report.
  const std::regex imgRe("<img src=\"([^\"]+)\"");
  size_t imgs = 0, previews = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), imgRe); it != std::sregex_iterator(); ++it, ++imgs) {
    const std::string src = (*it)[1].str();
    EXPECT_TRUE(fs::is_regular_file(out / src)) << src;
    previews += src.rfind("frames/", 0) == 0;
  }
  EXPECT_EQ(previews, 6u);
  const size_t maps = t.Column("flip") >= 0 ? 2 : 1;  // error heat map, and the FLIP map when flip is computed
  EXPECT_EQ(imgs, 6u * (1 + maps));
}


// A screenshot's pixels, 8 bits a channel.
struct Screenshot {
  int w = 0, h = 0, channels = 0;
  std::vector<unsigned char> px;
};

// The screenshot a browser wrote to `shot` (`status`: its exit status, `log`: what it printed); fails the test
// (empty result) when there is none.
Screenshot ReadShot(int status, const std::string& log, const fs::path& shot) {
  Screenshot s;
  EXPECT_EQ(status, 0) << log;
  auto in = OIIO::ImageInput::open(shot.string());
  EXPECT_TRUE(in) << OIIO::geterror();
  if (!in) return s;
  s.w = in->spec().width, s.h = in->spec().height, s.channels = in->spec().nchannels;
  s.px.resize(static_cast<size_t>(s.w) * s.h * s.channels);
  EXPECT_TRUE(in->read_image(0, 0, 0, s.channels, OIIO::TypeDesc::UINT8, s.px.data()));
  return s;
}

// Takes a screenshot of `url` in Chromium with `flags`; fails the test (empty result) when it cannot.
Screenshot Shoot(const std::string& chromium, const std::string& flags, const fs::path& profile, const fs::path& shot,
                 const std::string& url) {
  const auto r = restir::test::Shell("timeout 180 " + chromium + flags + " --user-data-dir=" + profile.string() +
                                     " --screenshot=" + shot.string() + " '" + url + "' 2>&1");
  return ReadShot(r.status, r.output, shot);
}

// An image found in a screenshot: the top-left corner where every pixel of `want` (w x h RGB) equals the
// screenshot's, or (-1, -1).
std::pair<int, int> Find(const Screenshot& s, const std::vector<unsigned char>& want, int w, int h) {
  const std::vector<unsigned char>& shot = s.px;
  const int sw = s.w, sh = s.h, sc = s.channels;
  auto same = [&](int ox, int oy, int x, int y) {
    for (int c = 0; c < 3; ++c)
      if (shot[(static_cast<size_t>(oy + y) * sw + ox + x) * sc + c] != want[(static_cast<size_t>(y) * w + x) * 3 + c])
        return false;
    return true;
  };
  for (int oy = 0; oy + h <= sh; ++oy)
    for (int ox = 0; ox + w <= sw; ++ox) {
      if (!same(ox, oy, 0, 0) || !same(ox, oy, w - 1, 0)) continue;
      bool all = true;
      for (int y = 0; y < h && all; ++y)
        for (int x = 0; x < w && all; ++x) all = same(ox, oy, x, y);
      if (all) return {ox, oy};
    }
  return {-1, -1};
}

// The screenshot shows `png` (a 64 x 36 scrub PNG of `frame`, relative to `out`) with its exact pixels, and not the
// same PNG of frame `other`.
void ExpectShowsFrame(const Screenshot& px, const fs::path& out, const std::string& png, int frame, int other) {
  SCOPED_TRACE(png);
  const std::vector<unsigned char> want = ReadScrubPng((out / png).string(), 64, 36);
  EXPECT_GE(Find(px, want, 64, 36).first, 0) << "the linked frame's PNG is not in the screenshot";
  std::string otherPng = png;
  const std::string from = "000" + std::to_string(frame), to = "000" + std::to_string(other);
  otherPng.replace(otherPng.find(from), from.size(), to);
  const std::vector<unsigned char> unwanted = ReadScrubPng((out / otherPng).string(), 64, 36);
  ASSERT_NE(unwanted, want) << "the test needs frames that differ";
  EXPECT_EQ(Find(px, unwanted, 64, 36).first, -1) << otherPng << " is shown too";
}

// The frame scrubber in Debian's headless Chromium, from disk: a link to a frame, layer and preset shows that
// frame's PNG with its exact pixels (found in the screenshot); another frame's is not what is shown. Without
// JavaScript the scrubber stays hidden and the rest of the page (strips, videos) is there. The videos have the
// run's frame count and size (ffprobe).
TEST(ReportBrowser, TheScrubberShowsTheLinkedFramesOwnPixelsAndTheVideosHaveEveryFrame) {
  const std::string chromium = "/usr/bin/chromium";
  ASSERT_EQ(::access(chromium.c_str(), X_OK), 0) << chromium << " is missing: scripts/setup.sh installs it";
  const fs::path dir = FreshDir("restir-report-scrubber");
  const fs::path out = dir / "run";
  ASSERT_TRUE(RunSmokeForScrubber(dir, out));
  // Pixels as the PNGs hold them (sRGB, one device pixel a CSS pixel), the images loaded before the shot.
  const std::string flags = kChromiumFlags +
                            " --force-color-profile=srgb --force-device-scale-factor=1 --hide-scrollbars "
                            "--virtual-time-budget=4000 --window-size=1280,4000";
  const std::string url = "file://" + fs::absolute(out / "report.html").string();
  struct View {
    int frame;
    std::string layer, preset, png;  // png: what the panel must show
    int other;                       // a frame whose PNG must not be what is shown
  };
  const View views[] = {{3, "estimate", "ris", "scrub/presets/ris/0003_estimate.png", 0},
                        {5, "error", "temporal", "scrub/presets/temporal/0005_error.png", 2},
                        {1, "reference", "ris", "scrub/reference/0001.png", 4}};
  int shots = 0;
  for (const View& v : views) {
    const fs::path shot = dir / ("scrub" + std::to_string(shots++) + ".png");
    const std::string link = url + "#frame=" + std::to_string(v.frame) + "&layer=" + v.layer + "&presets=" + v.preset;
    const Screenshot px = Shoot(chromium, flags, dir / "profile", shot, link);
    ASSERT_FALSE(px.px.empty());
    ExpectShowsFrame(px, out, v.png, v.frame, v.other);
  }

  // Without JavaScript: the page a browser shows that runs no script (here: the report with its scripts taken out,
  // beside the original so its links resolve; Chromium's own switch for it also stops --dump-dom and --screenshot).
  // The scrubber stays hidden and the rest is there: the strips' previews, the videos, and the crops, found with
  // their own pixels in a screenshot.
  std::string page = ReadText(out / "report.html");
  for (size_t at = page.find("<script"); at != std::string::npos; at = page.find("<script", at)) {
    const size_t end = page.find("</script>", at);
    ASSERT_NE(end, std::string::npos);
    page.erase(at, end + 9 - at);
  }
  WriteText(out / "report_nojs.html", page);
  const std::string nojs = "file://" + fs::absolute(out / "report_nojs.html").string();
  const Result dom = Shell("timeout 180 " + chromium + flags + " --user-data-dir=" + (dir / "profile-nojs").string() +
                           " --dump-dom " + nojs + " 2>/dev/null");
  ASSERT_EQ(dom.status, 0);
  EXPECT_NE(dom.output.find("<section id=\"scrubber\" hidden=\"\">"), std::string::npos) << dom.output.substr(0, 3000);
  EXPECT_EQ(dom.output.find("class=\"scrub-image\""), std::string::npos);
  EXPECT_EQ(Count(dom.output, "<img src=\"frames/"), 6u);  // the strips' previews
  EXPECT_NE(dom.output.find("videos/all_presets.mp4"), std::string::npos);
  const nlohmann::json crop = nlohmann::json::parse(ReadText(out / "summary.json"))["crop"];
  ASSERT_TRUE(crop.is_object()) << "smoke reveals pixels: the report has a crop";
  {
    const Screenshot px = Shoot(chromium, flags, dir / "profile-nojs-shot", dir / "nojs.png", nojs);
    ASSERT_FALSE(px.px.empty());
    const int cw = crop["width"].get<int>() * crop["scale"].get<int>(), ch = crop["height"].get<int>() * crop["scale"].get<int>();
    char name[64];
    std::snprintf(name, sizeof(name), "report_images/crops/ris_%04d_estimate.png", crop["frames"][0].get<int>());
    const std::vector<unsigned char> want = ReadScrubPng((out / name).string(), cw, ch);
    EXPECT_GE(Find(px, want, cw, ch).first, 0) << name << " is not in the screenshot without scripts";
  }
  // With it, the scrubber is shown with a panel per preset.
  const Result live = Shell("timeout 180 " + chromium + flags + " --user-data-dir=" + (dir / "profile-js").string() +
                            " --dump-dom " + url + " 2>/dev/null");
  ASSERT_EQ(live.status, 0);
  EXPECT_NE(live.output.find("<section id=\"scrubber\">"), std::string::npos);
  EXPECT_EQ(Count(live.output, "class=\"scrub-image\""), 2u);

  // Each video: 6 frames of estimate | reference | error map (3 x 64 wide) under a caption band (36 + 13, even).
  for (const char* video : {"videos/ris.mp4", "videos/temporal.mp4", "videos/all_presets.mp4"}) {
    const Result probe = Shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                               "stream=codec_name,width,height,pix_fmt,nb_read_frames -of csv=p=0 " +
                               (out / video).string() + " 2>&1");
    ASSERT_EQ(probe.status, 0) << video << ": " << probe.output;
    if (std::string(video) == "videos/all_presets.mp4")
      EXPECT_EQ(probe.output, "h264,128,112,yuv420p,6\n") << video;  // 2 x 2 tiles of 64 x (36 + 13) under a 13-row band
    else
      EXPECT_EQ(probe.output, "h264,192,50,yuv420p,6\n") << video;
  }
  const nlohmann::json summary = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ(summary["videos"]["per_preset"]["ris"], "videos/ris.mp4");
  EXPECT_TRUE(summary["speed_vs_error"]["metrics"]["relmse"].is_array());
  EXPECT_EQ(summary["speed_vs_error"]["metrics"]["relmse"].size(), 2u);
}

// The same scrubber in Debian's Firefox ESR (the issue asks for Chromium and Firefox; installed by scripts/setup.sh:
// a missing one fails this test), headless, from disk: a link to a frame, layer and presets shows that frame's PNGs
// with their exact pixels, and not another frame's. Firefox's --screenshot waits for the page's load event, which
// waits for the images the scrubber's inline script set while the page was parsed.
TEST(ReportBrowser, FirefoxShowsTheLinkedFramesOwnPixels) {
  const std::string firefox = "/usr/bin/firefox-esr";
  ASSERT_EQ(::access(firefox.c_str(), X_OK), 0) << firefox << " is missing: scripts/setup.sh installs it";
  const fs::path dir = FreshDir("restir-report-firefox");
  const fs::path out = dir / "run";
  ASSERT_TRUE(RunSmokeForScrubber(dir, out));
  // One CSS pixel a device pixel, no colour management of the PNGs, nothing of its own reaching the network.
  const fs::path profile = dir / "profile";
  fs::create_directories(profile);
  WriteText(profile / "user.js",
            "user_pref(\"layout.css.devPixelsPerPx\", \"1.0\");\n"
            "user_pref(\"gfx.color_management.mode\", 0);\n"
            "user_pref(\"browser.shell.checkDefaultBrowser\", false);\n"
            "user_pref(\"app.update.auto\", false);\n"
            "user_pref(\"datareporting.policy.dataSubmissionEnabled\", false);\n"
            "user_pref(\"toolkit.telemetry.enabled\", false);\n"
            "user_pref(\"network.captive-portal-service.enabled\", false);\n"
            "user_pref(\"network.connectivity-service.enabled\", false);\n");
  const std::string url = "file://" + fs::absolute(out / "report.html").string();
  struct View {
    int frame;
    std::string layer, presets;
    std::vector<std::string> pngs;  // what the panels must show
    int other;                      // a frame whose PNGs must not be shown
  };
  const View views[] = {
      {4, "error", "ris,temporal", {"scrub/presets/ris/0004_error.png", "scrub/presets/temporal/0004_error.png"}, 1},
      {2, "disocclusion", "temporal", {"scrub/disocclusion/0002.png"}, 5}};
  int shots = 0;
  for (const View& v : views) {
    const fs::path shot = dir / ("firefox" + std::to_string(shots++) + ".png");
    const std::string link =
        url + "#frame=" + std::to_string(v.frame) + "&layer=" + v.layer + "&presets=" + v.presets;
    const Result run = Shell("HOME=" + dir.string() + " timeout 180 " + firefox + " --headless --no-remote --profile " +
                             profile.string() + " --window-size=1280,4000 --screenshot " + shot.string() + " '" +
                             link + "' 2>&1");
    const Screenshot px = ReadShot(run.status, run.output, shot);
    ASSERT_FALSE(px.px.empty());
    for (const std::string& png : v.pngs) ExpectShowsFrame(px, out, png, v.frame, v.other);
  }
}

}  // namespace
}  // namespace restir
