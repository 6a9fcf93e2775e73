#include "sim/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace restir {
namespace {

std::string ReadAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(AtomicFile, WritesAndReplacesWithoutLeavingTemporaries) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / "restir-atomic-test";
  std::filesystem::remove_all(dir);
  const std::string path = (dir / "sub" / "a.txt").string();
  WriteFileAtomic(path, "first");
  WriteFileAtomic(path, "second");
  EXPECT_EQ(ReadAll(path), "second");
  int entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir / "sub")) ++entries, (void)e;
  EXPECT_EQ(entries, 1);
}

// A writer that fails leaves the previous file untouched and no temporary behind.
TEST(AtomicFile, FailedWriterKeepsPreviousVersion) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / "restir-atomic-test2";
  std::filesystem::remove_all(dir);
  const std::string path = (dir / "b.bin").string();
  WriteFileAtomic(path, "good");
  EXPECT_THROW(WriteViaTemporary(path,
                                 [](const std::string& tmp) {
                                   std::ofstream(tmp) << "partial";
                                   throw std::runtime_error("disk full");
                                 }),
               std::runtime_error);
  EXPECT_EQ(ReadAll(path), "good");
  int entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) ++entries, (void)e;
  EXPECT_EQ(entries, 1);
}

}  // namespace
}  // namespace restir
