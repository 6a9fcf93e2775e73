// Runs the restir-sim binary as a user would: exit status and the one-line message on bad input.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace {

struct Result {
  int status = -1;
  std::string output;
};

// ctest passes the binary's path; run by hand, the binary sits beside the test executable.
std::string SimBinary() {
  if (const char* bin = std::getenv("RESTIR_SIM_BIN")) return bin;
  return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "restir-sim").string();
}

Result RunCli(const std::string& args) {
  Result r;
  const std::string cmd = SimBinary() + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p)) r.output += buf.data();
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

class Cli : public ::testing::Test {};

TEST_F(Cli, HelpExitsZeroAndListsCommands) {
  const Result r = RunCli("--help");
  EXPECT_EQ(r.status, 0);
  for (const char* w : {"run", "validate", "presets"}) EXPECT_NE(r.output.find(w), std::string::npos) << w;
  const Result rr = RunCli("run --help");
  EXPECT_EQ(rr.status, 0);
  for (const char* w : {"--preset", "--frames", "--resolution", "--threads", "--seed", "--reference-spp",
                        "--no-reference", "--out"})
    EXPECT_NE(rr.output.find(w), std::string::npos) << w;
}

TEST_F(Cli, PresetsListsRis) {
  const Result r = RunCli("presets");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("ris"), std::string::npos);
}

TEST_F(Cli, ValidatePrintsSummary) {
  const Result r = RunCli("validate sequences/window_bars_pan.json");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("window_bars_pan"), std::string::npos);
}

TEST_F(Cli, BadInputExitsTwoWithOneMessage) {
  const std::string tmp = ::testing::TempDir() + "/restir-cli-bad.json";
  FILE* f = fopen(tmp.c_str(), "w");
  fputs("{\n  \"name\": \"x\",\n  \"frames\": ,\n}\n", f);
  fclose(f);
  Result r = RunCli("validate " + tmp);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find(tmp + ":3:"), std::string::npos) << r.output;
  r = RunCli("run sequences/smoke.json --preset nope --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("nope"), std::string::npos);
  r = RunCli("run sequences/smoke.json --frames 3:1 --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  r = RunCli("run sequences/smoke.json --resolution 0x5 --out " + ::testing::TempDir() + "/restir-cli-out");
  EXPECT_EQ(r.status, 2);
  r = RunCli("run does/not/exist.json");
  EXPECT_EQ(r.status, 2);
  r = RunCli("run");  // missing argument
  EXPECT_EQ(r.status, 2);
}

}  // namespace
