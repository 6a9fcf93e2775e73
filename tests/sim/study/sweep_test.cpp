// `restir-sim sweep`: the grid expands as documented, bad files are located, summaries and the Pareto front
// are what the definitions give, and a real (tiny) sweep writes its three reports.
#include "sim/study/sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "sim/scene/sequence.h"
#include "tests/sim/sweep_fixtures.h"

namespace restir {
namespace {

namespace fs = std::filesystem;
using test::ReadText;
using test::WithoutTimings;

std::string WriteTemp(const std::string& name, const std::string& text) {
  const fs::path p = fs::path(::testing::TempDir()) / name;
  std::ofstream(p) << text;
  return p.string();
}

// The sweep file sits in the temporary directory; its sequence path is relative to it.
std::string SmokePath() { return fs::absolute("sequences/smoke.json").string(); }

TEST(Sweep, GridIsPresetsTimesValuesInFileOrderThenConfigs) {
  const std::string path = WriteTemp("sweep-grid.json", R"({
  "sequence": ")" + SmokePath() + R"(",
  "presets": ["restir-unbiased", "restir-spmis"],
  "grid": {"spatial.neighbours": [3, 5], "spatial.radius": [10, 30.5]},
  "configs": [{"name": "spmis N8", "preset": "restir-spmis", "set": {"spatial.draws": 8}}]
})");
  const SweepSpec s = LoadSweep(path);
  ASSERT_EQ(s.configs.size(), 2u * 2u * 2u + 1u);
  EXPECT_EQ(s.configs[0].name, "restir-unbiased_spatial.neighbours=3_spatial.radius=10");
  EXPECT_EQ(s.configs[1].name, "restir-unbiased_spatial.neighbours=3_spatial.radius=30.5");
  EXPECT_EQ(s.configs[2].overrides, (std::vector<std::string>{"spatial.neighbours=5", "spatial.radius=10"}));
  EXPECT_EQ(s.configs[4].preset, "restir-spmis");
  EXPECT_EQ(s.configs[8].name, "spmis_N8");  // made safe for a directory name
  EXPECT_EQ(s.configs[8].overrides, (std::vector<std::string>{"spatial.draws=8"}));
}

TEST(Sweep, BadFilesNameFileLineColumnAndPath) {
  struct Case {
    std::string text, expect;
  };
  const std::string seq = "\"sequence\": \"" + SmokePath() + "\"";
  const std::vector<Case> cases = {
      {"{" + seq + ", \"presets\": [\"restir-fast\"]}", ":1:" /* same line */},
      {"{\n" + seq + ",\n\"presets\": [\"ris\"],\n\"grid\": {\"spatial.neighbors\": [3]}\n}", ":4:"},
      {"{\n" + seq + ",\n\"presetz\": [\"ris\"]\n}", ":3:1: error at /presetz: unknown key"},
      {"{\n" + seq + ",\n\"configs\": [{\"name\": \"a\", \"preset\": \"ris\", \"set\": {\"initial.candidates\": -4}}]\n}",
       ":3:"},
      {"{\n" + seq + "\n}", "no configurations"},
      {"{\"sequence\": \"nope.json\", \"presets\": [\"ris\"]}", "error at /sequence: no sequence file"},
      {"{\"presets\": [\"ris\"]}", "give 'sequence' (one file) or 'sequences'"},
      {"{" + seq + ",\n\"sequences\": [\"" + SmokePath() + "\"], \"presets\": [\"ris\"]}", "exactly one of them"},
      {"{\"sequences\": [\"" + SmokePath() + "\",\n \"" + SmokePath() + "\"], \"presets\": [\"ris\"]}",
       ":2:2: error at /sequences/1: two sequences named 'smoke'"},
      {"{" + seq + ", \"presets\": [\"ris\"],\n\"seeds\": [1, 2, 1]}", ":2:17: error at /seeds/2: seed 1 is listed twice"},
      {"{" + seq + ", \"presets\": [\"ris\"],\n\"seeds\": [1], \"seed\": 4}", "error at /seeds: give 'seeds'"},
      {"{" + seq + ", \"presets\": [\"ris\"],\n\"seedCount\": 0}", "error at /seedCount"},
      {"{" + seq + ", \"presets\": [\"ris\"],\n\"seed\": 4294967295, \"seedCount\": 2}", "seeds run past"},
      {"{" + seq + ", \"presets\": [\"ris\"],\n\"referenceSpp\": 8, \"referenceError\": 0.01}",
       "error at /referenceError: give 'referenceSpp' or 'referenceError'"},
      {"{\n" + seq + ",\n\"presets\": [\"ris\"],,\n}", "invalid JSON"},
  };
  for (const Case& c : cases) {
    const std::string path = WriteTemp("sweep-bad.json", c.text);
    try {
      LoadSweep(path);
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ":", 0), 0u) << m;
      EXPECT_NE(m.find(c.expect), std::string::npos) << m << "\n  want: " << c.expect;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
}

FrameMetricsRow Row(int frame, double relmse, double ms, double disoccRecent, double relmseDisocc) {
  FrameMetricsRow r;
  r.frame = frame;
  r.preset = "ris";
  r.values = {{"ms_frame", ms},          {"rays_per_pixel_initial", 1.0}, {"rays_per_pixel_shade", 1.0},
              {"relmse", relmse},        {"luma_sum", 9.0},               {"reference_luma_sum", 10.0},
              {"relmse_disocc", relmseDisocc}, {"flicker", 0.5},          {"disocc_recent_fraction", disoccRecent}};
  return r;
}

TEST(Sweep, SummaryMeansFollowTheDefinitions) {
  const std::vector<FrameMetricsRow> rows = {Row(0, 0.4, 100.0, 0.0, 0.0), Row(1, 0.2, 20.0, 0.1, 0.8),
                                             Row(2, 0.3, 30.0, 0.0, 0.0)};
  const SweepPoint p = Summarize(SweepConfig{"c", "ris", {}}, rows);
  EXPECT_EQ(p.seeds, 1);
  EXPECT_TRUE(std::isnan(p.bias2) && std::isnan(p.relmseCi95));
  EXPECT_DOUBLE_EQ(p.relmse, 0.3);
  EXPECT_DOUBLE_EQ(p.relmseDisocc, 0.8);     // only frame 1 had revealed pixels
  EXPECT_DOUBLE_EQ(p.msPerFrame, 25.0);      // the first frame's time is skipped
  EXPECT_DOUBLE_EQ(p.shadowRaysPerPixel, 2.0);
  EXPECT_DOUBLE_EQ(p.lumaRatio, 0.9);
  EXPECT_DOUBLE_EQ(p.efficiency, 1.0 / (0.3 * 0.025));
  EXPECT_TRUE(std::isnan(p.flip));           // no flip column
}

TEST(Sweep, ParetoFrontKeepsOnlyUndominatedPoints) {
  std::vector<SweepPoint> pts(4);
  pts[0].msPerFrame = 10, pts[0].relmse = 0.5;  // fastest
  pts[1].msPerFrame = 20, pts[1].relmse = 0.3;  // trade-off
  pts[2].msPerFrame = 25, pts[2].relmse = 0.4;  // dominated by 1
  pts[3].msPerFrame = 40, pts[3].relmse = 0.1;  // most accurate
  SweepPoint other;                              // another sequence's point dominates all, but not across sequences
  other.sequence = "other", other.msPerFrame = 1, other.relmse = 0.01;
  pts.push_back(other);
  MarkPareto(pts);
  EXPECT_TRUE(pts[0].pareto);
  EXPECT_TRUE(pts[1].pareto);
  EXPECT_FALSE(pts[2].pareto);
  EXPECT_TRUE(pts[3].pareto);
  EXPECT_TRUE(pts[4].pareto);
}

TEST(Sweep, EqualTimeTablePicksTheBestConfigurationWithinBudget) {
  SweepSpec spec;
  spec.path = "x.json";
  spec.sequences.push_back(SweepSequence{"s", "s.json", "", {1}});
  SweepMerge merge;
  std::vector<SweepPoint>& pts = merge.points;
  pts.resize(3);
  for (SweepPoint& p : pts) p.sequence = "s";
  pts[0].config = {"fast", "a", {}}, pts[0].msPerFrame = 10, pts[0].relmse = 0.5;
  pts[1].config = {"slow", "a", {}}, pts[1].msPerFrame = 30, pts[1].relmse = 0.2;
  pts[2].config = {"mid", "b", {}}, pts[2].msPerFrame = 10.4, pts[2].relmse = 0.3;
  const std::string md = SweepMarkdown(spec, merge);
  // At 10 ms (b's 10.4 is within 5%): a's fast config and b's mid; at 30 ms a's slow one.
  EXPECT_NE(md.find("| 10 | 0.5000 (fast) | 0.3000 (mid) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 30 | 0.2000 (slow) | 0.3000 (mid) |"), std::string::npos) << md;
}

TEST(Sweep, TinySweepWritesCsvPlotAndTables) {
  const fs::path out = fs::path(::testing::TempDir()) / "restir-sweep-run";
  fs::remove_all(out);
  const std::string path = WriteTemp("sweep-run.json", R"({
  "sequence": ")" + SmokePath() + R"(", "resolution": [48, 27], "frames": [0, 3], "referenceSpp": 32,
  "presets": ["ris", "restir-unbiased"], "grid": {"initial.candidates": [4, 16]}
})");
  SweepSpec spec = LoadSweep(path);
  spec.base.progress = false;
  spec.base.cacheDir = (out / "cache").string();
  const SweepMerge m = RunSweep(spec, out.string());
  const std::vector<SweepPoint>& pts = m.points;
  ASSERT_EQ(pts.size(), 4u);
  EXPECT_TRUE(m.missing.empty());
  for (const SweepPoint& p : pts) {
    EXPECT_TRUE(std::isfinite(p.relmse) && p.relmse > 0.0) << p.config.name;
    // The sequence's own seed (smoke.json: 7) when the sweep names none.
    EXPECT_TRUE(fs::exists(out / "runs" / "smoke" / p.config.name / "seed-7" / "metrics.csv")) << p.config.name;
    EXPECT_FALSE(fs::exists(out / "runs" / "smoke" / p.config.name / "seed-7" / "relative_error.bin"));
  }
  // More candidates, less error (same preset, same frames and seed): 16 vs 4 candidates for ris.
  EXPECT_LT(pts[1].relmse, pts[0].relmse);
  std::ifstream csv(out / "sweep.csv");
  int lines = 0;
  for (std::string l; std::getline(csv, l);) ++lines;
  EXPECT_EQ(lines, 5);
  std::ifstream svg(out / "sweep.svg");
  const std::string s((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  int circles = 0;
  for (size_t k = s.find("<circle"); k != std::string::npos; k = s.find("<circle", k + 1)) ++circles;
  EXPECT_EQ(circles, 4 + 2);  // one per configuration, one per preset in the legend
  EXPECT_TRUE(fs::exists(out / "sweep.md"));
}

std::string TwoSequenceSweep() {
  return WriteTemp("sweep-jobs.json", R"({
  "sequences": [")" + SmokePath() + R"(", ")" + fs::absolute("sequences/hard/camera_cut.json").string() + R"("],
  "resolution": [40, 24], "frames": [0, 3], "referenceSpp": 16, "seeds": [3, 11, 12],
  "presets": ["restir-unbiased"], "configs": [{"name": "ris4", "preset": "ris", "set": {"initial.candidates": 4}}]
})");
}

TEST(Sweep, PlanHasStableIdsOneJobPerSequenceConfigAndSeed) {
  const SweepSpec spec = LoadSweep(TwoSequenceSweep());
  const std::vector<SweepJob> jobs = PlanSweep(spec);
  ASSERT_EQ(jobs.size(), 2u * 2u * 3u);
  EXPECT_EQ(jobs[0].id, "smoke/restir-unbiased/seed-3");
  EXPECT_EQ(jobs[2].id, "smoke/restir-unbiased/seed-12");
  EXPECT_EQ(jobs[3].id, "smoke/ris4/seed-3");
  EXPECT_EQ(jobs[6].id, "camera_cut/restir-unbiased/seed-3");
  EXPECT_EQ(jobs[11].dir, "runs/camera_cut/ris4/seed-12");
  for (size_t k = 0; k < jobs.size(); ++k) {
    EXPECT_EQ(jobs[k].index, k);
    EXPECT_EQ(&FindSweepJob(spec, jobs, jobs[k].id), &jobs[k]);
    EXPECT_EQ(&FindSweepJob(spec, jobs, std::to_string(k)), &jobs[k]);
  }
  EXPECT_THROW(FindSweepJob(spec, jobs, "12"), InputError);
  EXPECT_THROW(FindSweepJob(spec, jobs, "smoke/ris4/seed-4"), InputError);
  EXPECT_EQ(PlanSweep(LoadSweep(TwoSequenceSweep()))[7].id, jobs[7].id);  // same file, same plan
  const std::string line = SweepJobLine(spec, jobs[4]);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_NE(line.find(R"("index":4,"id":"smoke/ris4/seed-11")"), std::string::npos) << line;
  EXPECT_NE(line.find(R"("set":["initial.candidates=4"],"seed":11)"), std::string::npos) << line;
  std::vector<SweepJob> some = {jobs[0], jobs[1], jobs[2], jobs[3], jobs[7], jobs[9], jobs[10]};
  EXPECT_EQ(SlurmArraySpec(some), "0-3,7,9-10");
}

// The property the cluster relies on: jobs run in any order, in separate processes, merge to the bytes of the
// one-process sweep (timings aside); an incomplete or stale job is reported missing, never merged.
TEST(Sweep, JobsRunApartMergeToTheLocalSweep) {
  const fs::path base = fs::path(::testing::TempDir()) / "restir-sweep-jobs";
  fs::remove_all(base);
  SweepSpec spec = LoadSweep(TwoSequenceSweep());
  spec.base.progress = false;
  spec.base.cacheDir = (base / "cache").string();
  const fs::path local = base / "local", split = base / "split";
  const SweepMerge all = RunSweep(spec, local.string());
  ASSERT_EQ(all.points.size(), 4u);
  for (const SweepPoint& p : all.points) {
    EXPECT_EQ(p.seeds, 3);
    EXPECT_TRUE(std::isfinite(p.bias2) && std::isfinite(p.bias2Ci95) && p.variance > 0.0) << p.config.name;
  }
  std::vector<SweepJob> jobs = PlanSweep(spec);
  // Reverse order, one thread (the local sweep used every core): the same bits.
  spec.base.threads = 1;
  for (auto it = jobs.rbegin(); it != jobs.rend(); ++it)
    if (it->index != 5) RunSweepJob(spec, *it, split.string());
  SweepMerge partial = MergeSweep(spec, split.string());
  EXPECT_EQ(partial.missing, std::vector<std::string>{jobs[5].id});
  EXPECT_EQ(partial.points[1].seeds, 2);  // smoke/ris4 from two seeds
  EXPECT_NE(ReadText(split / "sweep.md").find("## Missing jobs"), std::string::npos);
  RunSweepJob(spec, jobs[5], split.string());
  const SweepMerge merged = MergeSweep(spec, split.string());
  EXPECT_TRUE(merged.missing.empty());
  EXPECT_EQ(WithoutTimings(ReadText(split / "sweep.csv")), WithoutTimings(ReadText(local / "sweep.csv")));
  EXPECT_TRUE(fs::exists(split / "sweep-smoke.svg") && fs::exists(split / "sweep-camera_cut.svg"));
  for (const SweepJob& j : jobs)
    EXPECT_EQ(ReadText(split / j.dir / "relative_error.bin"), ReadText(local / j.dir / "relative_error.bin")) << j.id;

  // A job whose sweep changed (another reference budget) is stale: missing, not merged.
  SweepSpec changed = spec;
  changed.base.referenceSpp = 24;
  std::string why;
  EXPECT_FALSE(SweepJobComplete(changed, jobs[0], split.string(), &why));
  EXPECT_NE(why.find("describes another job"), std::string::npos) << why;
  // A job killed before it finished has no job.json: missing.
  fs::remove(split / jobs[2].dir / "job.json");
  EXPECT_FALSE(SweepJobComplete(spec, jobs[2], split.string(), &why));
  // A damaged relative-error file or a cut metrics.csv makes its job missing, named with the damage, so that
  // --plan --missing lists it and a resubmission reruns it; the merge goes on with the others.
  RunSweepJob(spec, jobs[2], split.string());
  {
    std::fstream f(split / jobs[2].dir / "relative_error.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f.put('\x7f');
  }
  fs::resize_file(split / jobs[7].dir / "metrics.csv", fs::file_size(split / jobs[7].dir / "metrics.csv") - 9);
  const SweepMerge damaged = MergeSweep(spec, split.string());
  ASSERT_EQ(damaged.missing, (std::vector<std::string>{jobs[2].id, jobs[7].id}));
  EXPECT_NE(damaged.missingWhy[0].find("relative_error.bin: error: unusable relative-error file (frame 0: checksum"),
            std::string::npos)
      << damaged.missingWhy[0];
  EXPECT_NE(damaged.missingWhy[1].find("metrics.csv"), std::string::npos) << damaged.missingWhy[1];
  EXPECT_NE(ReadText(split / "sweep.md").find(jobs[2].id + "`: " + (split / jobs[2].dir).string()), std::string::npos);
  RunSweepJob(spec, jobs[2], split.string());
  RunSweepJob(spec, jobs[7], split.string());
  EXPECT_TRUE(MergeSweep(spec, split.string()).missing.empty());
  // The tables that hold no timing are equal too: equal samples and the seed ensembles.
  auto untimed = [&](const fs::path& md) {
    const std::string text = ReadText(md);
    std::string out;
    for (size_t k = text.find("### Equal samples"); k != std::string::npos; k = text.find("### Equal samples", k + 1))
      out += text.substr(k, text.find("\n## ", k) - k);
    return out;
  };
  EXPECT_FALSE(untimed(local / "sweep.md").empty());
  EXPECT_EQ(untimed(split / "sweep.md"), untimed(local / "sweep.md"));
}

}  // namespace
}  // namespace restir
