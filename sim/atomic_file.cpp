#include "sim/atomic_file.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace restir {

namespace {

std::string TemporaryName(const std::filesystem::path& target) {
  // The pid keeps concurrent runs writing the same target from clobbering each other's temporaries.
  return (target.parent_path() /
          (target.stem().string() + ".tmp" + std::to_string(::getpid()) + target.extension().string()))
      .string();
}

}  // namespace

void WriteViaTemporary(const std::string& path, const std::function<void(const std::string&)>& writer) {
  const std::filesystem::path target(path);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  const std::string tmp = TemporaryName(target);
  try {
    writer(tmp);
    std::filesystem::rename(tmp, target);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
}

void WriteFileAtomic(const std::string& path, const std::string& bytes) {
  WriteViaTemporary(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error("cannot write " + tmp);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    f.close();
    if (!f) throw std::runtime_error("cannot write " + tmp);
  });
}

}  // namespace restir
