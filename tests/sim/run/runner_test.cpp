#include "sim/run/runner.h"
#include "sim/output/heat_map.h"
#include "sim/output/scrub_frames.h"

#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sim/scene/sequence.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace runner_test {

std::string TempOut(const std::string& name) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  return dir.string();
}

// A row's value in column `name`; a failure (and -1) when the row has no such column.
double ColumnOf(const FrameMetricsRow& row, const std::string& name) {
  for (const auto& [n, v] : row.values)
    if (n == name) return v;
  ADD_FAILURE() << "no column " << name;
  return -1.0;
}

RunOptions SmokeOptions(const std::string& out) {
  RunOptions o;
  o.sequencePath = "sequences/smoke.json";
  o.outDir = out;
  o.cacheDir = out + "/cache";
  o.progress = false;
  o.referenceSpp = 16;
  return o;
}

std::vector<std::string> Hashes(const RunResult& r) {
  std::vector<std::string> h;
  for (const auto& row : r.rows) h.push_back(row.preset + ":" + std::to_string(row.frame) + ":" + row.imageHash);
  return h;
}

// Determinism (DESIGN §3): the same run on 1 and 2 threads writes bit-identical images.
TEST(Run, ImageHashesIdenticalAcrossThreadCounts) {
  RunOptions a = SmokeOptions(TempOut("restir-run-t1"));
  a.threads = 1;
  a.writeImages = false;
  RunOptions b = SmokeOptions(TempOut("restir-run-t2"));
  b.threads = 2;
  b.writeImages = false;
  const RunResult ra = restir::Run(a), rb = restir::Run(b);
  ASSERT_FALSE(ra.rows.empty());
  EXPECT_EQ(Hashes(ra), Hashes(rb));
  // The metrics (not the timings) agree too.
  for (size_t i = 0; i < ra.rows.size(); ++i)
    for (size_t k = 0; k < ra.rows[i].values.size(); ++k) {
      const std::string& name = ra.rows[i].values[k].first;
      if (name.rfind("ms_", 0) == 0 || name == "reference_cached") continue;
      EXPECT_EQ(ra.rows[i].values[k].second, rb.rows[i].values[k].second) << name;
    }
}

// Presets whose initial sampling is the same pass run it once a frame (sim/estimator/pipeline.h
// InitialSamplingShare); each still reports the pass's time and rays. restir-unbiased and restir-balance share
// theirs; ris draws without initial visibility, so it runs its own, which traces no ray.
TEST(Run, PresetsSharingTheirInitialPassEachReportItsTimeAndRays) {
  RunOptions o = SmokeOptions(TempOut("restir-run-share"));
  o.writeImages = false;
  o.reference = false;
  o.frameEnd = 3;
  o.presets = {"restir-unbiased", "ris", "restir-balance"};
  const RunResult r = restir::Run(o);
  ASSERT_EQ(r.rows.size(), 9u);
  for (size_t f = 0; f < 3; ++f) {
    const FrameMetricsRow &unbiased = r.rows[3 * f], &ris = r.rows[3 * f + 1], &balance = r.rows[3 * f + 2];
    ASSERT_EQ(unbiased.preset, "restir-unbiased");
    ASSERT_EQ(balance.preset, "restir-balance");
    EXPECT_GT(ColumnOf(unbiased, "ms_initial"), 0.0);
    EXPECT_EQ(ColumnOf(unbiased, "ms_initial"), ColumnOf(balance, "ms_initial")) << "frame " << f;
    EXPECT_GT(ColumnOf(unbiased, "rays_per_pixel_initial"), 0.0);
    EXPECT_EQ(ColumnOf(unbiased, "rays_per_pixel_initial"), ColumnOf(balance, "rays_per_pixel_initial"));
    EXPECT_GT(ColumnOf(ris, "ms_initial"), 0.0);
    EXPECT_EQ(ColumnOf(ris, "rays_per_pixel_initial"), 0.0);
    EXPECT_GE(ColumnOf(unbiased, "ms_frame"), ColumnOf(unbiased, "ms_initial"));
  }
}

// And each gets the bits it gets alone: restir-unbiased beside two presets (one sharing its initial pass, one not)
// writes the image hashes and every non-timing column it writes run alone, with a reference and an ensemble of 2
// (whose second member shares with the other preset's second member).
TEST(Run, APresetSharingItsInitialPassWritesWhatItWritesAlone) {
  RunOptions o = SmokeOptions(TempOut("restir-run-share-three"));
  o.writeImages = false;
  o.frameEnd = 3;
  o.ensemble = 2;
  o.presets = {"restir-balance", "ris", "restir-unbiased"};
  RunOptions alone = o;
  alone.outDir = TempOut("restir-run-share-alone");
  alone.cacheDir = alone.outDir + "/cache";
  alone.presets = {"restir-unbiased"};
  const RunResult three = restir::Run(o), one = restir::Run(alone);
  std::vector<const FrameMetricsRow*> unbiased;
  for (const FrameMetricsRow& row : three.rows)
    if (row.preset == "restir-unbiased") unbiased.push_back(&row);
  ASSERT_EQ(unbiased.size(), one.rows.size());
  ASSERT_EQ(one.rows.size(), 3u);
  for (size_t f = 0; f < one.rows.size(); ++f) {
    EXPECT_EQ(unbiased[f]->imageHash, one.rows[f].imageHash) << "frame " << f;
    ASSERT_EQ(unbiased[f]->values.size(), one.rows[f].values.size());
    for (size_t k = 0; k < one.rows[f].values.size(); ++k) {
      const std::string& name = one.rows[f].values[k].first;
      if (name.rfind("ms_", 0) == 0 || name == "reference_cached") continue;
      EXPECT_EQ(unbiased[f]->values[k].second, one.rows[f].values[k].second) << name << " frame " << f;
    }
  }
}

TEST(Run, DifferentSeedsGiveDifferentImages) {
  RunOptions a = SmokeOptions(TempOut("restir-run-s1"));
  a.writeImages = false;
  a.reference = false;
  a.frameEnd = 1;
  RunOptions b = a;
  b.outDir = TempOut("restir-run-s2");
  b.seed = 12345;
  EXPECT_NE(Hashes(restir::Run(a)), Hashes(restir::Run(b)));
}

// The outputs exist, every EXR has the documented layers and OpenImageIO reads it, metrics.csv has one row per
// frame and preset with the documented columns, and run.json records the configuration.
TEST(Run, WritesFramesMetricsAndRunRecord) {
  const std::string out = TempOut("restir-run-out");
  RunOptions o = SmokeOptions(out);
  o.frameBegin = 1;
  o.frameEnd = 3;
  const RunResult r = restir::Run(o);
  ASSERT_EQ(r.rows.size(), 2u);
  for (int f : {1, 2}) {
    char name[16];
    std::snprintf(name, sizeof(name), "%04d", f);
    const std::string exr = out + "/frames/ris/" + name + ".exr";
    const std::string png = out + "/frames/ris/" + name + ".png";
    ASSERT_TRUE(std::filesystem::exists(exr)) << exr;
    ASSERT_TRUE(std::filesystem::exists(png)) << png;
    auto in = OIIO::ImageInput::open(exr);
    ASSERT_TRUE(in) << OIIO::geterror();
    const OIIO::ImageSpec& spec = in->spec();
    std::set<std::string> channels(spec.channelnames.begin(), spec.channelnames.end());
    for (const char* c : {"R", "G", "B", "reference.R", "reference.G", "reference.B", "reference_stderr.R",
                          "error.R", "error.G", "error.B", "disocclusion.Y", "depth.Z", "normal.X", "normal.Y",
                          "normal.Z", "flip.Y"})
      EXPECT_TRUE(channels.count(c)) << c;
    EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
    // The flip.Y layer is the per-pixel HDR-FLIP map: within [0, 1], and its mean is the row's `flip` column.
    const int flipChannel = spec.channelindex("flip.Y");
    ASSERT_GE(flipChannel, 0);
    std::vector<float> flip(static_cast<size_t>(spec.width) * spec.height);
    ASSERT_TRUE(in->read_image(0, 0, flipChannel, flipChannel + 1, OIIO::TypeDesc::FLOAT, flip.data()));
    double flipSum = 0.0;
    for (float v : flip) {
      ASSERT_GE(v, 0.0f);
      ASSERT_LE(v, 1.0f);
      flipSum += v;
    }
    double flipColumn = -1.0;
    for (const auto& [name, value] : r.rows[f - 1].values)
      if (name == "flip") flipColumn = value;
    EXPECT_NEAR(flipColumn, flipSum / double(flip.size()), 1e-9);
    in->close();
    auto pin = OIIO::ImageInput::open(png);
    ASSERT_TRUE(pin);
    EXPECT_EQ(pin->spec().width, 2 * spec.width);  // estimate beside reference
  }
  std::ifstream csv(out + "/metrics.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* col : {"frame", "preset", "ms_initial", "ms_shade", "ms_reference", "rays", "rmse",
                          "luma_rmse", "relmse", "luma_ratio", "flip", "flip_disocc", "disocc_fraction",
                          "image_hash"})
    EXPECT_NE(header.find(col), std::string::npos) << col;
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 2);
  std::ifstream rj(out + "/run.json");
  const auto j = nlohmann::json::parse(rj);
  EXPECT_EQ(j["status"], "complete");
  EXPECT_EQ(j["frames"][0], 1);
  EXPECT_TRUE(j["presets"].contains("ris"));
  EXPECT_FALSE(j["sequence"]["contentHash"].get<std::string>().empty());
  // No temporaries left behind.
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
}

// A sequence's render.referenceError is the default: its frames are sampled to the target, and a frame that hits
// render.referenceSppCap says so in its rows (reference_capped, reference_spp within the cap) and in run.json
// (referenceCapped lists it); --reference-spp replaces the target with a fixed budget, and --reference-cap the cap.
TEST(Run, ASequencesErrorTargetIsTheDefaultAndItsCapIsReported) {
  const std::string out = TempOut("restir-run-error-target");
  std::filesystem::create_directories(out);
  std::ifstream in("sequences/smoke.json");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string shipped = "\"referenceError\": 0.02, \"referenceSppCap\": 64}";
  ASSERT_NE(text.find(shipped), std::string::npos);
  text.replace(text.find(shipped), shipped.size(), "\"referenceError\": 0.001, \"referenceSppCap\": 48}");
  const std::string seqPath = out + "/smoke_target.json";
  std::ofstream(seqPath) << text;
  auto runJson = [](const std::string& dir) {
    std::ifstream rj(dir + "/run.json");
    return nlohmann::json::parse(rj);
  };
  RunOptions o = SmokeOptions(out + "/target");
  o.sequencePath = seqPath;
  o.referenceSpp = 0;
  o.frameEnd = 2;
  o.writeImages = false;
  const RunResult capped = restir::Run(o);
  ASSERT_EQ(capped.rows.size(), 2u);
  for (const FrameMetricsRow& row : capped.rows) {
    EXPECT_EQ(ColumnOf(row, "reference_capped"), 1.0);
    EXPECT_GT(ColumnOf(row, "reference_spp"), 32.0);  // the cap spent as a budget: about 48, in whole replicates
    EXPECT_LE(ColumnOf(row, "reference_spp"), 1.25 * 48.0);
  }
  nlohmann::json j = runJson(o.outDir);
  EXPECT_EQ(j["reference"]["targetRelativeError"], 0.001);
  EXPECT_EQ(j["reference"]["sppCap"], 48);
  EXPECT_EQ(j["referenceCapped"]["count"], 2);
  EXPECT_EQ(j["referenceCapped"]["frames"], nlohmann::json::array({0, 1}));

  o.outDir = out + "/wider";
  o.referenceSppCap = 1 << 20;
  o.referenceError = 0.2;  // affordable: nothing capped
  const RunResult free = restir::Run(o);
  for (const FrameMetricsRow& row : free.rows) EXPECT_EQ(ColumnOf(row, "reference_capped"), 0.0);
  j = runJson(o.outDir);
  EXPECT_EQ(j["reference"]["targetRelativeError"], 0.2);
  EXPECT_EQ(j["referenceCapped"]["count"], 0);

  o.outDir = out + "/budget";
  o.referenceSppCap = 0;
  o.referenceError = 0.0;
  o.referenceSpp = 128;
  const RunResult fixed = restir::Run(o);
  for (const FrameMetricsRow& row : fixed.rows) {
    EXPECT_EQ(ColumnOf(row, "reference_capped"), 0.0);
    // Whole replicates per pixel, and no pixel above 16 times the mean: the budget is an upper bound, roughly met.
    EXPECT_GT(ColumnOf(row, "reference_spp"), 64.0);
    EXPECT_LE(ColumnOf(row, "reference_spp"), 1.25 * 128.0);
  }
  j = runJson(o.outDir);
  EXPECT_EQ(j["reference"]["targetRelativeError"], 0.0);
  EXPECT_EQ(j["reference"]["sppCap"], 0);
}

// The frame files are written on a background thread (sim/output/background_writer.h): a file that cannot be written
// in a later frame still ends the run with an error naming it, the frames before it are whole on disk, and no
// temporary is left behind. A directory stands where frame 3's EXR would go, so its rename fails.
TEST(Run, AFrameFileThatCannotBeWrittenInALaterFrameEndsTheRun) {
  const std::string out = TempOut("restir-run-late-failure");
  RunOptions o = SmokeOptions(out);
  o.frameBegin = 0;
  o.frameEnd = 6;
  o.presets = {"ris", "restir-unbiased"};
  o.imageFrames.kind = ImageFrames::Kind::kAll;
  std::filesystem::create_directories(out + "/frames/ris/0003.exr/occupied");
  try {
    restir::Run(o);
    ADD_FAILURE() << "the run went on past a frame file it could not write";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("0003.exr"), std::string::npos) << e.what();
  }
  for (const char* preset : {"ris", "restir-unbiased"})
    for (int f = 0; f < 3; ++f) {
      char name[16];
      std::snprintf(name, sizeof(name), "%04d", f);
      for (const char* ext : {".exr", ".png"}) {
        const std::string path = out + "/frames/" + preset + "/" + name + ext;
        auto in = OIIO::ImageInput::open(path);
        ASSERT_TRUE(in) << path << ": " << OIIO::geterror();
        std::vector<float> pixels(static_cast<size_t>(in->spec().image_pixels()) * in->spec().nchannels);
        EXPECT_TRUE(in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeDesc::FLOAT, pixels.data())) << path;
      }
    }
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().string().find("restir-sim-tmp"), std::string::npos) << e.path();
}

// --images: "report", "all" or a range (with the report's three: it asks for more) chooses which frames get an EXR
// and a preview (run.json lists them); every frame gets its scrub PNGs whichever is chosen. A range that holds none
// of the run's frames is refused before anything is written.
TEST(Run, ImagesChooseWhichFramesGetAnExrAndEveryFrameGetsItsScrubPngs) {
  struct Case {
    std::string images;
    int begin, end;  // the run's frames
    std::vector<int> want;
  };
  const Case cases[] = {{"report", 0, 6, {0, 3, 5}}, {"report", 1, 3, {1, 2}}, {"report", 2, 3, {2}},
                        {"all", 1, 5, {1, 2, 3, 4}}, {"1:3", 0, 6, {0, 1, 2, 3, 5}}, {":2", 1, 6, {1, 3, 5}},
                        {"4:", 0, 6, {0, 3, 4, 5}},  {"5:9", 0, 6, {0, 3, 5}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.images + " over " + std::to_string(c.begin) + ":" + std::to_string(c.end));
    const std::string out = TempOut("restir-run-images");
    RunOptions o = SmokeOptions(out);
    o.frameBegin = c.begin;
    o.frameEnd = c.end;
    o.width = 32;
    o.height = 18;
    o.report = false;
    const std::optional<ImageFrames> images = ParseImageFrames(c.images);
    ASSERT_TRUE(images);
    o.imageFrames = *images;
    restir::Run(o);
    std::vector<int> have;
    for (int f = 0; f < 8; ++f) {
      char name[16];
      std::snprintf(name, sizeof(name), "%04d", f);
      const bool exr = std::filesystem::exists(out + "/frames/ris/" + name + ".exr");
      EXPECT_EQ(exr, std::filesystem::exists(out + "/frames/ris/" + name + ".png")) << f;
      if (exr) have.push_back(f);
      const bool rendered = f >= c.begin && f < c.end;
      for (const std::string& scrub : {ScrubReferencePath(f), ScrubDisocclusionPath(f),
                                       ScrubPresetPath("ris", f, ScrubLayer::kEstimate),
                                       ScrubPresetPath("ris", f, ScrubLayer::kError),
                                       ScrubPresetPath("ris", f, ScrubLayer::kFlip)})
        EXPECT_EQ(std::filesystem::exists(out + "/" + scrub), rendered) << scrub;
    }
    EXPECT_EQ(have, c.want);
    std::ifstream rj(out + "/run.json");
    const auto j = nlohmann::json::parse(rj);
    EXPECT_EQ(j["images"]["selection"], c.images == ":2" ? "0:2" : c.images == "4:" ? "4:" : c.images);
    EXPECT_EQ(j["images"]["frameFiles"].get<std::vector<int>>(), c.want);
  }
  for (const char* none : {"7:9", "6:", ":1"}) {
    SCOPED_TRACE(none);
    const std::string out = TempOut("restir-run-images-none");
    RunOptions o = SmokeOptions(out);
    o.frameBegin = 1;
    o.frameEnd = 6;
    o.imageFrames = *ParseImageFrames(none);
    try {
      restir::Run(o);
      ADD_FAILURE() << "ran";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), "--images: error: " + ImageFramesName(o.imageFrames) + " holds none of the run's frames 1:6");
    }
    EXPECT_FALSE(std::filesystem::exists(out + "/run.json"));
  }
}

// Without a reference the scrub PNGs' one exposure comes from the estimate of the preset whose name sorts first,
// so the order the presets are given in (which a resume may change) does not change a byte of them.
TEST(Run, ScrubPngsWithoutAReferenceDoNotDependOnThePresetsOrder) {
  std::vector<std::vector<unsigned char>> first, last;
  for (const std::vector<std::string>& order :
       {std::vector<std::string>{"restir-unbiased", "ris"}, std::vector<std::string>{"ris", "restir-unbiased"}}) {
    const std::string out = TempOut("restir-run-scrub-order");
    RunOptions o = SmokeOptions(out);
    o.frameEnd = 3;  // at the sequence's 64 x 36: smaller, both presets' exposures happen to agree
    o.report = false;
    o.reference = false;
    o.presets = order;
    restir::Run(o);
    first.push_back(ReadScrubPng(out + "/scrub/presets/ris/0000_estimate.png", 64, 36));
    last.push_back(ReadScrubPng(out + "/scrub/presets/restir-unbiased/0002_estimate.png", 64, 36));
  }
  ASSERT_FALSE(first[0].empty());
  EXPECT_EQ(first[0], first[1]);
  EXPECT_EQ(last[0], last[1]);
}

// The scrub PNGs are the frame's own pixels: the first frame's estimate and reference are its preview's panels (one
// exposure, chosen from that frame's reference), and every frame's error map, FLIP map and mask are the EXR's
// error, flip and disocclusion layers through the report's colour maps.
TEST(Run, ScrubPngsShowTheFramesOwnPixels) {
  const std::string out = TempOut("restir-run-scrub");
  RunOptions o = SmokeOptions(out);
  o.frameEnd = 4;
  o.width = 48;
  o.height = 27;
  o.report = false;
  o.imageFrames.kind = ImageFrames::Kind::kAll;
  restir::Run(o);
  const int w = o.width, h = o.height;
  auto bytes = [&](const std::string& relative) { return ReadScrubPng(out + "/" + relative, w, h); };
  {
    OIIO::ImageInput::unique_ptr in = OIIO::ImageInput::open(out + "/frames/ris/0000.png");
    ASSERT_TRUE(in);
    std::vector<unsigned char> preview(static_cast<size_t>(2 * w) * h * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, preview.data()));
    const std::vector<unsigned char> est = bytes(ScrubPresetPath("ris", 0, ScrubLayer::kEstimate));
    const std::vector<unsigned char> ref = bytes(ScrubReferencePath(0));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(est[(y * w + x) * 3 + c], preview[(y * 2 * w + x) * 3 + c]) << x << "," << y;
          ASSERT_EQ(ref[(y * w + x) * 3 + c], preview[(y * 2 * w + w + x) * 3 + c]) << x << "," << y;
        }
  }
  for (int f = 0; f < 4; ++f) {
    char name[16];
    std::snprintf(name, sizeof(name), "%04d", f);
    OIIO::ImageInput::unique_ptr in = OIIO::ImageInput::open(out + "/frames/ris/" + name + ".exr");
    ASSERT_TRUE(in);
    const int nc = in->spec().nchannels;
    std::vector<float> all(static_cast<size_t>(w) * h * nc);
    ASSERT_TRUE(in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, all.data()));
    auto channel = [&](const char* n) { return in->spec().channelindex(n); };
    std::vector<double> error(static_cast<size_t>(w) * h), flip(error.size());
    std::vector<unsigned char> mask(error.size());
    for (size_t i = 0; i < error.size(); ++i) {
      const float e[3] = {all[i * nc + channel("error.R")], all[i * nc + channel("error.G")],
                          all[i * nc + channel("error.B")]};
      const float r[3] = {all[i * nc + channel("reference.R")], all[i * nc + channel("reference.G")],
                          all[i * nc + channel("reference.B")]};
      error[i] = PixelRelativeError(e, r);
      flip[i] = all[i * nc + channel("flip.Y")];
      mask[i] = all[i * nc + channel("disocclusion.Y")] > 0.5f;
    }
    EXPECT_EQ(bytes(ScrubPresetPath("ris", f, ScrubLayer::kError)), HeatMapRgb(error, ColourMap::kInferno)) << f;
    EXPECT_EQ(bytes(ScrubPresetPath("ris", f, ScrubLayer::kFlip)), HeatMapRgb(flip, ColourMap::kMagma)) << f;
    const std::vector<unsigned char> m = bytes(ScrubDisocclusionPath(f));
    for (size_t i = 0; i < mask.size(); ++i) {
      if (mask[i]) EXPECT_EQ(m[3 * i], kScrubDisoccludedNow) << f << " pixel " << i;
      else EXPECT_NE(m[3 * i], kScrubDisoccludedNow) << f << " pixel " << i;
    }
  }
}

// The EXRs are readable by OpenEXR's and OpenImageIO's own command-line tools (installed by scripts/setup.sh).
TEST(Run, ExrReadableByExrheaderAndOiiotool) {
  const std::string out = TempOut("restir-run-exrheader");
  RunOptions o = SmokeOptions(out);
  o.frameEnd = 1;
  o.reference = false;
  const RunResult r = restir::Run(o);
  // Without a reference there is nothing to compare against: no FLIP column, no flip layer.
  for (const auto& [name, value] : r.rows.at(0).values) EXPECT_EQ(name.rfind("flip", 0), std::string::npos);
  const std::string cmd = "exrheader " + out + "/frames/ris/0000.exr > " + out + "/hdr.txt 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream f(out + "/hdr.txt");
  std::stringstream s;
  s << f.rdbuf();
  EXPECT_NE(s.str().find("disocclusion.Y"), std::string::npos);
  EXPECT_EQ(s.str().find("flip.Y"), std::string::npos);
  const std::string oiio = "oiiotool --info -v " + out + "/frames/ris/0000.exr > " + out + "/oiio.txt 2>&1";
  ASSERT_EQ(std::system(oiio.c_str()), 0);
  std::ifstream g(out + "/oiio.txt");
  std::stringstream t;
  t << g.rdbuf();
  EXPECT_NE(t.str().find("normal.Z"), std::string::npos) << t.str();
}

// --exr-compression reaches the files (OpenEXR's exrheader names it) and run.json; it is not part of what a
// --resume must match, since the pixels are the same whichever is chosen.
TEST(Run, ExrCompressionReachesTheFilesAndRunJsonButNotTheResumeKey) {
  for (ExrCompression c : {ExrCompression::kRle, ExrCompression::kNone}) {
    const std::string out = TempOut(std::string("restir-run-exr-") + ExrCompressionName(c));
    RunOptions o = SmokeOptions(out);
    o.frameEnd = 1;
    o.reference = false;
    o.exrCompression = c;
    restir::Run(o);
    const std::string cmd = "exrheader " + out + "/frames/ris/0000.exr > " + out + "/hdr.txt 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    std::ifstream f(out + "/hdr.txt");
    std::stringstream s;
    s << f.rdbuf();
    const char* expected = c == ExrCompression::kRle ? "compression (type compression): run-length encoding"
                                                     : "compression (type compression): none";
    EXPECT_NE(s.str().find(expected), std::string::npos) << s.str();
    std::ifstream j(out + "/run.json");
    EXPECT_EQ(nlohmann::json::parse(j).at("exrCompression"), ExrCompressionName(c));
    RunOptions again = o;
    again.resume = true;
    again.exrCompression = c == ExrCompression::kRle ? ExrCompression::kNone : ExrCompression::kRle;
    EXPECT_TRUE(restir::Run(again).alreadyComplete);
  }
}

// The run removes only what it made: a killed run's private area of temporaries (its lock free) goes, a user's
// files go nowhere, whatever they are called (the old cleanup matched *.tmp<digits>* and took thesis.tmp2024.tex).
TEST(Run, RemovesItsOwnStaleTemporariesAndNothingOfTheUsers) {
  const std::string out = TempOut("restir-run-stale");
  std::filesystem::create_directories(out + "/frames/ris");
  std::filesystem::create_directories(out + "/.restir-sim-tmp/deadhost-1-2");
  std::ofstream(out + "/.restir-sim-tmp/deadhost-1-2.lock");
  std::ofstream(out + "/.restir-sim-tmp/deadhost-1-2/0-metrics.csv") << "partial";
  const char* mine[] = {"/frames/ris/0003.tmp4242.exr", "/thesis.tmp2024.tex", "/notes.txt", "/.restir-sim-tmp.txt"};
  for (const char* f : mine) std::ofstream(out + f) << "mine";
  RunOptions o = SmokeOptions(out);
  o.frameEnd = 1;
  o.reference = false;
  o.writeImages = false;
  restir::Run(o);
  EXPECT_FALSE(std::filesystem::exists(out + "/.restir-sim-tmp"));
  for (const char* f : mine) EXPECT_TRUE(std::filesystem::exists(out + f)) << f;
}

// indirect.bounces (issue 41) reaches every preset's frames, the reference (its cache key: a run without it renders
// its own) and run.json; metrics.csv reports the indirect pass's time and rays, 0 where it does not run.
TEST(Run, IndirectBouncesReachTheFramesTheReferenceAndRunJson) {
  const std::string out = TempOut("restir-run-indirect");
  RunOptions o = SmokeOptions(out + "/direct");
  o.cacheDir = out + "/cache";
  o.presets = {"ris", "restir-unbiased"};
  o.frameEnd = 2;
  o.writeImages = false;
  const RunResult direct = restir::Run(o);
  o.outDir = out + "/indirect";
  o.settings = {"indirect.bounces=2"};
  const RunResult indirect = restir::Run(o);
  ASSERT_EQ(direct.rows.size(), 4u);
  ASSERT_EQ(indirect.rows.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    const FrameMetricsRow &a = direct.rows[k], &b = indirect.rows[k];
    EXPECT_EQ(ColumnOf(a, "ms_indirect"), 0.0);
    EXPECT_EQ(ColumnOf(a, "rays_per_pixel_indirect"), 0.0);
    EXPECT_GT(ColumnOf(b, "ms_indirect"), 0.0);
    EXPECT_GT(ColumnOf(b, "rays_per_pixel_indirect"), 0.5);  // a path a pixel: at least its first ray, most pixels
    EXPECT_NE(a.imageHash, b.imageHash) << b.preset << " frame " << b.frame;
    // The reference gained the indirect light as well: more light, not the direct-light entry from the cache.
    EXPECT_GT(ColumnOf(b, "reference_luma_sum"), ColumnOf(a, "reference_luma_sum"));
  }
  std::ifstream rj(o.outDir + "/run.json");
  const nlohmann::json j = nlohmann::json::parse(rj);
  EXPECT_EQ(j["reference"]["indirectBounces"], 2);
  EXPECT_EQ(j["presets"]["ris"]["settings"]["indirect.bounces"], "2");
  o.settings = {"indirect.bounces=9"};
  o.outDir = out + "/too-many";
  EXPECT_THROW(restir::Run(o), InputError);
}

// ReSTIR GI's reservoirs have columns of their own (gi_*): set for a preset that reuses paths, with the shares
// ordered as the passes make them (a shaded sample is a reservoir's that contributes), and 0 for a preset whose
// paths are added as they are.
TEST(Run, GiPresetsReportTheirReservoirsInTheGiColumns) {
  const std::string out = TempOut("restir-run-gi-columns");
  RunOptions o = SmokeOptions(out + "/reuse");
  o.cacheDir = out + "/cache";
  o.presets = {"restir-gi-unbiased", "restir-gi-spmis"};
  o.frameEnd = 3;
  o.writeImages = false;
  const RunResult reuse = restir::Run(o);
  ASSERT_EQ(reuse.rows.size(), 6u);
  for (const FrameMetricsRow& row : reuse.rows) {
    const std::string what = row.preset + " frame " + std::to_string(row.frame);
    const double initial = ColumnOf(row, "gi_contrib_initial"), spatial = ColumnOf(row, "gi_contrib_spatial");
    const double shaded = ColumnOf(row, "gi_contrib_shaded");
    EXPECT_GT(initial, 0.0) << what;
    EXPECT_LE(initial, 1.0) << what;
    EXPECT_GT(spatial, 0.0) << what;
    EXPECT_LE(spatial, 1.0) << what;
    EXPECT_LE(shaded, spatial) << what;
    EXPECT_GT(ColumnOf(row, "gi_mean_confidence"), 0.0) << what;
    EXPECT_GT(ColumnOf(row, "gi_targets_per_pixel_spatial"), 0.0) << what;
    EXPECT_GT(ColumnOf(row, "gi_reservoir_reads_per_pixel_spatial"), 0.0) << what;
    EXPECT_GT(ColumnOf(row, "gi_rays_per_pixel_spatial"), 0.0) << what << ": ray-traced bias correction";
    EXPECT_GT(ColumnOf(row, "ms_gi_spatial"), 0.0) << what;
    if (row.frame > 0) EXPECT_GT(ColumnOf(row, "gi_sample_age"), 0.0) << what;
  }
  o.outDir = out + "/paths";
  o.settings = {"indirect.reuse=false"};
  const RunResult paths = restir::Run(o);
  ASSERT_EQ(paths.rows.size(), 6u);
  for (const FrameMetricsRow& row : paths.rows)
    for (const char* name : {"gi_contrib_initial", "gi_contrib_spatial", "gi_contrib_shaded", "gi_mean_confidence",
                             "gi_rays_per_pixel_spatial", "ms_gi_spatial"})
      EXPECT_EQ(ColumnOf(row, name), 0.0) << row.preset << " frame " << row.frame << " " << name;
}

TEST(Run, BadInputThrowsInputError) {
  RunOptions o = SmokeOptions(TempOut("restir-run-bad"));
  o.presets = {"no-such-preset"};
  EXPECT_THROW(restir::Run(o), InputError);
  o.presets = {};
  o.frameBegin = 5;
  o.frameEnd = 500;
  EXPECT_THROW(restir::Run(o), InputError);
  o.frameBegin = 0;
  o.frameEnd = -1;
  o.outDir = "/proc/restir-cannot-write-here";
  EXPECT_THROW(restir::Run(o), InputError);
}

}  // namespace runner_test
}  // namespace restir
