#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <string>

// ctest runs two test processes at once (the presets' "jobs": 2), and many tests name their scratch directories
// after themselves under ::testing::TempDir(). Two processes that picked the same name removed each other's files
// mid-run (the SIMD-determinism tests on smoke.json and on sky_smoke.json did, in CI). So every process gets its
// own directory: TempDir() reads TEST_TMPDIR on each call, and this sets it before any test runs. It is removed
// when every test passed and kept, with its path printed, when one failed.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const char* parentEnv = std::getenv("TEST_TMPDIR");
  std::string parent = parentEnv && *parentEnv ? parentEnv : "/tmp";
  if (parent.back() != '/') parent += '/';
  std::string pattern = parent + "restir-tests-XXXXXX";
  if (!mkdtemp(pattern.data())) {
    std::perror(("mkdtemp " + pattern).c_str());
    return 2;
  }
  setenv("TEST_TMPDIR", pattern.c_str(), 1);
  const int status = RUN_ALL_TESTS();
  std::error_code ec;
  if (status == 0)
    std::filesystem::remove_all(pattern, ec);
  else
    std::fprintf(stderr, "test scratch directory kept: %s\n", pattern.c_str());
  return status;
}
