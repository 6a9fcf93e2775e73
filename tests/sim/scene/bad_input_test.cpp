// The malformed-sequence corpus (tests/data/bad_sequences/): every file is refused by `validate` and by `run`
// with exit status 2 and exactly one message that names the file and the line:column or JSON path listed in
// EXPECTED.txt; no crash, and `run` leaves nothing behind in its output directory (DESIGN §10).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "tests/sim/sim_binary.h"

namespace {

namespace fs = std::filesystem;

const char* kCorpus = "tests/data/bad_sequences";

using Outcome = restir::test::ShellResult;
using restir::test::RunSim;

struct Case {
  std::string file;    // corpus file name
  std::string prefix;  // how the message must begin: the sequence's path, or the OBJ file's for mesh errors
};

std::vector<Case> LoadCorpus() {
  std::vector<Case> cases;
  std::ifstream f(std::string(kCorpus) + "/EXPECTED.txt");
  for (std::string line; std::getline(f, line);) {
    const size_t tab = line.find('\t');
    if (line.empty() || tab == std::string::npos) continue;
    // EXPECTED.txt gives what follows the sequence's path (":line:col: error at /json/path:"), or for an error
    // inside a mesh the mesh file's name relative to the corpus ("bad.obj: error: ...": Assimp gives no line).
    const std::string file = line.substr(0, tab), rest = line.substr(tab + 1);
    const bool inSequence = !rest.empty() && (rest[0] == ':' || rest[0] == ' ');
    cases.push_back({file, std::string(kCorpus) + "/" + (inSequence ? file + rest : rest)});
  }
  return cases;
}

int Lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST(BadInputCorpus, EveryFileIsListedAndTheCorpusIsLarge) {
  const std::vector<Case> cases = LoadCorpus();
  EXPECT_GE(cases.size(), 40u);
  size_t jsonFiles = 0;
  for (const auto& e : fs::directory_iterator(kCorpus)) jsonFiles += e.path().extension() == ".json";
  EXPECT_EQ(jsonFiles, cases.size()) << "every corpus file needs its expected message in EXPECTED.txt";
}

// One `validate` for the whole corpus (each file checked in turn, a refused one reported in its one line): a process
// start costs restir-sim about 0.4 s of dynamic linking (OpenImageIO's 250 libraries), which a process per file paid
// 134 times. `run` below still takes each file in a process of its own, and exits 2 with one line for each.
TEST(BadInputCorpus, ValidateExitsTwoWithOneMessageNamingTheLocation) {
  const std::vector<Case> cases = LoadCorpus();
  std::string files;
  for (const Case& c : cases) files += " " + std::string(kCorpus) + "/" + c.file;
  // stderr alone (the order matters: stderr to the pipe, then stdout away).
  const Outcome r = restir::test::Shell(restir::test::SimBinary() + " validate" + files + " 2>&1 >/dev/null");
  EXPECT_TRUE(r.exited) << "crashed";
  EXPECT_EQ(r.status, 2) << r.output;
  std::vector<std::string> lines;
  std::stringstream in(r.output);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), cases.size()) << "one line per refused file:\n" << r.output;
  for (size_t k = 0; k < cases.size(); ++k)
    EXPECT_EQ(lines[k].rfind(cases[k].prefix, 0), 0u)
        << cases[k].file << "\n  got:  " << lines[k] << "\n  want: " << cases[k].prefix;
}

TEST(BadInputCorpus, RunExitsTwoAndWritesNothing) {
  for (const Case& c : LoadCorpus()) {
    const std::string path = std::string(kCorpus) + "/" + c.file;
    const fs::path out = fs::path(::testing::TempDir()) / ("restir-bad-run-" + c.file);
    fs::remove_all(out);
    const Outcome r = RunSim("run " + path + " --no-progress --out " + out.string());
    EXPECT_TRUE(r.exited) << c.file << " crashed";
    EXPECT_EQ(r.status, 2) << c.file << ": " << r.output;
    EXPECT_EQ(Lines(r.output), 1) << c.file << ": " << r.output;
    EXPECT_EQ(r.output.rfind(c.prefix, 0), 0u) << c.file << ": " << r.output;
    const bool empty = !fs::exists(out) || fs::is_empty(out);
    EXPECT_TRUE(empty) << c.file << " left output in " << out;
  }
}

TEST(BadInput, UnwritableOutputDirectoryExitsTwo) {
  // A regular file where the output directory should be: writable by nobody as a directory, even as root.
  const fs::path blocker = fs::path(::testing::TempDir()) / "restir-bad-out-is-a-file";
  std::ofstream(blocker) << "not a directory";
  const Outcome r = RunSim("run sequences/smoke.json --no-reference --no-progress --out " + (blocker / "sub").string());
  EXPECT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(Lines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("not writable"), std::string::npos) << r.output;
}

}  // namespace
