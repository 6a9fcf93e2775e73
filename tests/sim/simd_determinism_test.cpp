// Determinism across SIMD targets and thread counts (DESIGN §3; issue 6): for every preset on
// sequences/smoke.json, the frame image hashes are identical whatever SIMD target runs the kernels (the scalar
// twins and every Highway target this CPU supports) and whatever the thread count, and equal to the hashes the
// pipeline gave before the initial pass moved into the SIMD kernel; and batching the passes' targets and shadow
// rays traced exactly the rays the one-pixel-at-a-time passes traced.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/simd.h"
#include "sim/presets.h"
#include "sim/runner.h"

namespace restir {
namespace {

RunOptions SmokeAllPresets(const std::string& name, int threads, int width = 64, int height = 36) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  RunOptions o;
  o.sequencePath = "sequences/smoke.json";
  for (const Preset& p : AllPresets()) o.presets.push_back(p.name);
  o.frameBegin = 0;
  o.frameEnd = 4;
  o.width = width;
  o.height = height;
  o.threads = threads;
  o.reference = false;
  o.writeImages = false;
  o.report = false;
  o.progress = false;
  o.cacheDir = "";
  o.outDir = dir.string();
  return o;
}

std::map<std::string, std::string> Hashes(const RunResult& r) {
  std::map<std::string, std::string> h;
  for (const auto& row : r.rows) h[row.preset + ":" + std::to_string(row.frame)] = row.imageHash;
  return h;
}

// image_hash of `restir-sim run sequences/smoke.json --preset all --resolution 64x36 --frames 0:4
// --no-reference --no-images`, computed with the scalar initial pass before the SIMD kernel replaced it. An
// intentional change of an estimator changes these; a SIMD or threading change never may.
const std::map<std::string, std::string>& PreKernelHashes() {
  static const std::map<std::string, std::string> h = {
      {"ris:0", "5b279bb65e0272ac"},
      {"temporal:0", "5b279bb65e0272ac"},
      {"restir-biased:0", "6619d89262492132"},
      {"restir-vis:0", "4d06550acd0ac392"},
      {"restir-wisvis:0", "a03354636e24bbc5"},
      {"restir-unbiased:0", "33473765231c4274"},
      {"restir-balance:0", "e18c8c39eb625704"},
      {"restir-spmis:0", "6151ca3b9066a673"},
      {"ris:1", "5537834bbfe75328"},
      {"temporal:1", "9525099a32534ef6"},
      {"restir-biased:1", "1758c563316532f8"},
      {"restir-vis:1", "2e5c44fc691b6ac7"},
      {"restir-wisvis:1", "446a6e5df12a2f8e"},
      {"restir-unbiased:1", "51ca8a74e405a366"},
      {"restir-balance:1", "671b1d514969a6e8"},
      {"restir-spmis:1", "899885abb59fa517"},
      {"ris:2", "3fca33e2f2bd4b39"},
      {"temporal:2", "af0e72449b2d7a13"},
      {"restir-biased:2", "dbeb31310bb54ca0"},
      {"restir-vis:2", "e09d7ec2ced11528"},
      {"restir-wisvis:2", "3c2e7be1b6c1e0bd"},
      {"restir-unbiased:2", "3fd0cdd3ad0f74d9"},
      {"restir-balance:2", "f7c8db8b86414d67"},
      {"restir-spmis:2", "48b279d5170a058d"},
      {"ris:3", "d2472082092140be"},
      {"temporal:3", "08e504c58535c5d7"},
      {"restir-biased:3", "43a7d9d0802fc010"},
      {"restir-vis:3", "1b7f0b3214fd0aa3"},
      {"restir-wisvis:3", "af01604c10daa695"},
      {"restir-unbiased:3", "c56dcc69d8dd0d5b"},
      {"restir-balance:3", "92c8e758a392988b"},
      {"restir-spmis:3", "393276900e8a06f5"},
  };
  return h;
}

// The `rays` column of the same run with the passes before they batched their targets and shadow rays (pixel by
// pixel, each entry p̂_j(Y_i) evaluated and traced when a MIS weight first asked for it).
const std::map<std::string, double>& PreBatchingRays() {
  static const std::map<std::string, double> r = {
      {"ris:0", 3852},
      {"temporal:0", 3852},
      {"restir-biased:0", 5382},
      {"restir-vis:0", 5467},
      {"restir-wisvis:0", 5467},
      {"restir-unbiased:0", 10684},
      {"restir-balance:0", 12426},
      {"restir-spmis:0", 17830},
      {"ris:1", 3853},
      {"temporal:1", 3856},
      {"restir-biased:1", 5403},
      {"restir-vis:1", 4798},
      {"restir-wisvis:1", 4798},
      {"restir-unbiased:1", 14329},
      {"restir-balance:1", 14825},
      {"restir-spmis:1", 23591},
      {"ris:2", 3860},
      {"temporal:2", 3861},
      {"restir-biased:2", 5415},
      {"restir-vis:2", 4759},
      {"restir-wisvis:2", 4759},
      {"restir-unbiased:2", 14173},
      {"restir-balance:2", 14583},
      {"restir-spmis:2", 23489},
      {"ris:3", 3853},
      {"temporal:3", 3857},
      {"restir-biased:3", 5406},
      {"restir-vis:3", 4789},
      {"restir-wisvis:3", 4789},
      {"restir-unbiased:3", 14307},
      {"restir-balance:3", 14764},
      {"restir-spmis:3", 23946},
  };
  return r;
}

class SimdDeterminism : public ::testing::Test {
 protected:
  void TearDown() override { SetSimdTarget(SimdTarget::kAuto); }
};

TEST_F(SimdDeterminism, ImageHashesIdenticalAcrossTargetsAndThreadCountsForEveryPreset) {
  std::map<std::string, std::string> first;
  std::string firstName;
  for (SimdTarget t : SupportedSimdTargets()) {
    ASSERT_TRUE(SetSimdTarget(t));
    for (int threads : {1, 2}) {
      const std::string name = std::string(SimdTargetName(t)) + "-t" + std::to_string(threads);
      // 100 pixels wide: a full batch of 64 pixels and a partial one per row, SIMD tails in every kernel.
      const RunResult r = restir::Run(SmokeAllPresets("restir-simd-" + name, threads, 100, 40));
      ASSERT_EQ(r.rows.size(), AllPresets().size() * 4) << name;
      const auto h = Hashes(r);
      if (first.empty()) {
        first = h;
        firstName = name;
        continue;
      }
      EXPECT_EQ(h, first) << name << " differs from " << firstName;
    }
  }
}

TEST_F(SimdDeterminism, ImageHashesEqualThePreKernelScalarCode) {
  ASSERT_FALSE(PreKernelHashes().empty());
  for (SimdTarget t : {SimdTarget::kScalar, SimdTarget::kAuto}) {
    ASSERT_TRUE(SetSimdTarget(t));
    const RunResult r = restir::Run(SmokeAllPresets(std::string("restir-simd-pre-") + SimdTargetName(t), 2));
    const auto h = Hashes(r);
    for (const auto& [key, hash] : PreKernelHashes()) {
      const auto it = h.find(key);
      ASSERT_NE(it, h.end()) << key;
      EXPECT_EQ(it->second, hash) << key << " on " << ActiveSimdTargetName();
    }
  }
}

TEST_F(SimdDeterminism, BatchedPassesTraceExactlyTheRaysOfThePixelByPixelCode) {
  for (int threads : {1, 2}) {
    const RunResult r = restir::Run(SmokeAllPresets("restir-simd-rays-t" + std::to_string(threads), threads));
    ASSERT_EQ(r.rows.size(), PreBatchingRays().size());
    for (const FrameMetricsRow& row : r.rows) {
      const std::string key = row.preset + ":" + std::to_string(row.frame);
      double rays = -1.0;
      for (const auto& [name, value] : row.values)
        if (name == "rays") rays = value;
      EXPECT_EQ(rays, PreBatchingRays().at(key)) << key << " with " << threads << " threads";
    }
  }
}

TEST_F(SimdDeterminism, UnsupportedOrUnknownTargetsAreRefused) {
  for (SimdTarget t : {SimdTarget::kSse4, SimdTarget::kAvx2, SimdTarget::kAvx512})
    if (!SimdTargetSupported(t)) {
      EXPECT_FALSE(SetSimdTarget(t)) << SimdTargetName(t);
    }
  EXPECT_TRUE(SetSimdTarget(SimdTarget::kScalar));
  EXPECT_STREQ(ActiveSimdTargetName(), "scalar");
}

// `restir-sim run --simd NAME`: an unknown name, or a target this CPU lacks, is bad input (exit status 2, one
// message naming the option); a supported one runs.
int RunCliStatus(const std::string& args, std::string& output) {
  const char* env = std::getenv("RESTIR_SIM_BIN");
  const std::string bin =
      env ? env : (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "restir-sim").string();
  FILE* p = popen((bin + " " + args + " 2>&1").c_str(), "r");
  std::array<char, 4096> buf{};
  output.clear();
  while (fgets(buf.data(), buf.size(), p)) output += buf.data();
  const int st = pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

TEST_F(SimdDeterminism, CliSimdOption) {
  const std::string out = ::testing::TempDir() + "/restir-simd-cli";
  const std::string common = "run sequences/smoke.json --frames 0:1 --no-reference --no-images --no-report "
                             "--no-progress --cache-dir '' --out " + out;
  std::string text;
  EXPECT_EQ(RunCliStatus(common + " --simd avx1024", text), 2) << text;
  EXPECT_NE(text.find("--simd"), std::string::npos) << text;
  for (SimdTarget t : {SimdTarget::kSse4, SimdTarget::kAvx2, SimdTarget::kAvx512})
    if (!SimdTargetSupported(t)) {
      EXPECT_EQ(RunCliStatus(common + " --simd " + SimdTargetName(t), text), 2) << text;
    }
  EXPECT_EQ(RunCliStatus(common + " --simd scalar", text), 0) << text;
  EXPECT_EQ(RunCliStatus(common + " --simd auto", text), 0) << text;
}

}  // namespace
}  // namespace restir
