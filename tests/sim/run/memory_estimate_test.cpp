// The run's memory estimate against what real runs take: measured by the kernel (wait4's peak resident set of a
// restir-sim child), not by the estimator's own arithmetic.
#include "sim/run/memory_estimate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "core/light.h"
#include "sim/scene/embree_scene.h"
#include "sim/util/input_file.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/presets.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::RunSimMeasured;

TEST(ParseByteSize, AcceptsUnitsAndRejectsTheRest) {
  EXPECT_EQ(*ParseByteSize("512M"), 512.0 * 1048576.0);
  EXPECT_EQ(*ParseByteSize("8G"), 8.0 * 1073741824.0);
  EXPECT_EQ(*ParseByteSize("1.5GiB"), 1.5 * 1073741824.0);
  EXPECT_EQ(*ParseByteSize("2gb"), 2.0 * 1073741824.0);
  EXPECT_EQ(*ParseByteSize("100000"), 100000.0);
  EXPECT_EQ(*ParseByteSize("64K"), 65536.0);
  for (const char* bad : {"", "G", "-1G", "0", "1e400", "nan", "inf", "12Q", "8 G", " 8G", "8GG", "0x10"})
    EXPECT_FALSE(ParseByteSize(bad).has_value()) << bad;
}

// The count bounds what the reference's frames select from: the groups MakeLightGroups forms over the frame's own
// light list (BuildLightTriangles, every light on), for quads whose halves shine alike and quads whose
// imported halves do not (then they are two groups), beside a lone triangle.
TEST(CountLightGroups, IsAtLeastWhatTheFramesLightListForms) {
  auto quad = [](float x0, std::vector<Vec3> triangleRadiance) {
    Light l;
    l.vertices = {Vec3(x0, 2, 0), Vec3(x0 + 1, 2, 0), Vec3(x0 + 1, 2, 1),
                  Vec3(x0, 2, 0), Vec3(x0 + 1, 2, 1), Vec3(x0, 2, 1)};
    l.radiance = Vec3(3.0f);
    l.triangleRadiance = std::move(triangleRadiance);
    return l;
  };
  Light lone;
  lone.vertices = {Vec3(5, 2, 0), Vec3(6, 2, 0), Vec3(5, 2, 1)};
  const std::vector<std::vector<Light>> scenes = {
      {quad(0, {})},
      {quad(0, {Vec3(1), Vec3(1)})},
      {quad(0, {Vec3(1), Vec3(2)})},
      {quad(0, {Vec3(1), Vec3(0)}), quad(3, {}), lone},
  };
  const int64_t expected[] = {1, 1, 2, 4};
  for (size_t k = 0; k < scenes.size(); ++k) {
    Sequence seq;
    seq.lights = scenes[k];
    const std::vector<LightTriangle> frame = BuildLightTriangles(seq, FrameState{});
    const int64_t formed = static_cast<int64_t>(MakeLightGroups(frame).first.size());
    EXPECT_EQ(formed, expected[k]) << k;
    EXPECT_GE(CountLightGroups(scenes[k]), formed) << k;
  }
}

TEST(MachineMemoryLimit, IsPositiveAndAtMostTheMachinesMemory) {
  const std::optional<MemoryLimit> limit = MachineMemoryLimit();
  ASSERT_TRUE(limit.has_value());
  EXPECT_GT(limit->bytes, 64.0 * 1048576.0);
  EXPECT_LE(limit->bytes, double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE)) * 1.0001);
  EXPECT_FALSE(limit->source.empty());
}

TEST(EstimateRunMemory, GrowsWithEveryDimension) {
  RunShape base;
  base.width = 640;
  base.height = 360;
  base.frames = 10;
  base.presets = 1;
  const double b = EstimateRunMemory(base).bytes;
  auto with = [&](auto change) {
    RunShape s = base;
    change(s);
    return EstimateRunMemory(s).bytes;
  };
  EXPECT_GT(with([](RunShape& s) { s.width *= 2; }), b);
  EXPECT_GT(with([](RunShape& s) { s.presets = 3; }), b);
  EXPECT_GT(with([](RunShape& s) { s.members = 4; }), b);
  EXPECT_GT(with([](RunShape& s) { s.frames = 100000; }), b);
  EXPECT_GT(with([](RunShape& s) { s.sceneTriangles = 1 << 20; }), b);
  // The frame's shared initial passes: one reservoir buffer per configuration and member.
  EXPECT_NEAR(with([](RunShape& s) { s.sharedInitialPasses = 3; s.members = 2; }) -
                  with([](RunShape& s) { s.sharedInitialPasses = 0; s.members = 2; }),
              640.0 * 360.0 * 3 * 2 * sizeof(StoredReservoir), 1.0);
  EXPECT_LT(with([](RunShape& s) { s.reference = false; }), b);
  // --reference-error: a block of 16 pixels may take 65536 samples each, held at once (over 100 MB a thread).
  EXPECT_GT(with([](RunShape& s) { s.referenceSamplesPerPixel = 65536; }), b + 1e8);
  // The case: 16384² is valid by the format's limits; it needs far more than any ordinary machine.
  EXPECT_GT(with([](RunShape& s) { s.width = s.height = 16384; s.frames = 100000; }), 64.0 * 1073741824.0);
}

// The estimate bounds the measured peak from above, and not by so much that a run the machine could hold is
// refused: measured <= estimate <= 1.6 x measured over a grid of resolutions, preset counts, ensembles, with and
// without reference and images. The process's own part is what `restir-sim presets` takes (the same libraries).
TEST(EstimateRunMemory, BoundsTheMeasuredPeakOfRealRuns) {
  const std::string out = (fs::path(::testing::TempDir()) / "restir-memory-estimate").string();
  const test::ShellResult idle = RunSimMeasured({"presets"});
  ASSERT_TRUE(idle.exited && idle.status == 0);
  const Sequence seq = LoadSequence("sequences/smoke.json");
  int64_t sceneTriangles = 0, lightTriangles = 0;
  for (const Object& o : seq.objects) sceneTriangles += int64_t(o.mesh.triangles.size());
  for (const Light& l : seq.lights) lightTriangles += int64_t(l.vertices.size() / 3);

  struct Config {
    int width, height, frames;
    std::vector<std::string> presets;
    int ensemble;
    bool reference, images;
  };
  const Config configs[] = {
      {256, 144, 2, {"ris"}, 1, true, true},
      {640, 640, 2, {"ris"}, 1, true, true},
      {1024, 1024, 2, {"ris"}, 1, false, false},
      {512, 512, 2, {"ris", "restir-unbiased", "restir-spmis"}, 1, true, true},
      {512, 512, 2, {"ris"}, 3, true, false},
      {960, 540, 2, {"restir-biased"}, 1, true, true},
      // Long enough for the background writer's queue to fill (one fast preset, large frames).
      {1280, 720, 5, {"ris"}, 1, true, true},
      {960, 540, 4, {"ris"}, 3, true, true},
  };
  for (const Config& c : configs) {
    std::string presetList;
    for (const std::string& p : c.presets) presetList += (presetList.empty() ? "" : ",") + p;
    std::vector<std::string> args = {"run", "sequences/smoke.json", "--preset", presetList, "--resolution",
                                     std::to_string(c.width) + "x" + std::to_string(c.height), "--frames",
                                     "0:" + std::to_string(c.frames), "--reference-spp", "1", "--cache-dir", "",
                                     "--ensemble", std::to_string(c.ensemble), "--no-progress", "--no-report",
                                     "--max-memory", "none", "--out", out};
    if (!c.reference) args.push_back("--no-reference");
    if (!c.images) args.push_back("--no-images");
    const test::ShellResult r = RunSimMeasured(args);
    ASSERT_TRUE(r.exited && r.status == 0) << presetList;
    RunShape s;
    s.width = c.width;
    s.height = c.height;
    s.frames = c.frames;
    s.presets = int64_t(c.presets.size());
    // The initial passes the run keeps for other presets: configurations two or more of its presets run.
    std::vector<InitialSamplingParams> initial;
    for (const std::string& name : c.presets)
      for (const Preset& p : AllPresets())
        if (p.name == name) initial.push_back(p.settings.initial);
    ASSERT_EQ(initial.size(), c.presets.size());
    for (size_t i = 0; i < initial.size(); ++i)
      if (std::count(initial.begin(), initial.end(), initial[i]) >= 2 &&
          std::find(initial.begin(), initial.end(), initial[i]) == initial.begin() + ptrdiff_t(i))
        ++s.sharedInitialPasses;
    s.members = c.reference ? c.ensemble : 1;
    s.reference = c.reference;
    s.writeImages = c.images;
    s.sceneTriangles = sceneTriangles;
    s.lightTriangles = lightTriangles;
    s.lightGroups = CountLightGroups(seq.lights);
    ReferenceParams spp1;
    spp1.samplesPerPixel = 1;  // as --reference-spp 1 above
    s.referenceSamplesPerPixel = ReferenceMaxSamplesPerPixel(spp1);
    s.processBytes = idle.peakBytes;
    const double estimate = EstimateRunMemory(s).bytes;
    const std::string what = std::to_string(c.width) + "x" + std::to_string(c.height) + " " + presetList +
                             " ensemble " + std::to_string(c.ensemble) + (c.reference ? "" : " no-reference") +
                             (c.images ? "" : " no-images") + ": measured " + FormatBytes(r.peakBytes) +
                             ", estimate " + FormatBytes(estimate);
    std::printf("%s\n", what.c_str());
    EXPECT_GE(estimate, r.peakBytes) << what;
    EXPECT_LE(estimate, 1.6 * r.peakBytes) << what;
  }
  fs::remove_all(out);
}

}  // namespace
}  // namespace restir
