#include "sim/output/output_manifest.h"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "sim/util/atomic_file.h"
#include "sim/util/hash.h"
#include "sim/util/input_file.h"

namespace restir {

namespace {

std::string Joined(const std::string& outDir, const std::string& relativePath) {
  return (std::filesystem::path(outDir) / relativePath).string();
}

}  // namespace

void OutputManifest::Record(const std::string& relativePath) {
  const std::string path = Joined(outDir_, relativePath);
  std::string bytes, problem;
  if (!TryReadRegularFile(path, std::numeric_limits<size_t>::max(), bytes, problem))
    throw OutputError(path + ": error: cannot read back what was written (" + problem + ")");
  OutputFile f{relativePath, bytes.size(), Fnv1a(bytes.data(), bytes.size())};
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = std::find_if(files_.begin(), files_.end(), [&](const OutputFile& o) { return o.path == relativePath; });
  if (it != files_.end()) {
    *it = std::move(f);
  } else {
    files_.push_back(std::move(f));
  }
}

std::vector<OutputFile> OutputManifest::Files() const {
  std::vector<OutputFile> out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    out = files_;
  }
  std::sort(out.begin(), out.end(), [](const OutputFile& a, const OutputFile& b) { return a.path < b.path; });
  return out;
}

void OutputManifest::Restore(std::vector<OutputFile> files) {
  std::lock_guard<std::mutex> lock(mutex_);
  files_ = std::move(files);
}

nlohmann::json OutputFilesJson(const std::vector<OutputFile>& files) {
  nlohmann::json j = nlohmann::json::object();
  for (const OutputFile& f : files) j[f.path] = {{"bytes", f.bytes}, {"fnv1a", HexHash(f.fnv1a)}};
  return j;
}

bool OutputFilesFromJson(const nlohmann::json& j, std::vector<OutputFile>& files) {
  files.clear();
  if (!j.is_object()) return false;
  for (const auto& [path, record] : j.items()) {
    if (!record.is_object() || !record.contains("bytes") || !record["bytes"].is_number_unsigned() ||
        !record.contains("fnv1a") || !record["fnv1a"].is_string())
      return false;
    const std::string hex = record["fnv1a"].get<std::string>();
    if (hex.size() != 16 || hex.find_first_not_of("0123456789abcdef") != std::string::npos) return false;
    files.push_back({path, record["bytes"].get<uint64_t>(), std::stoull(hex, nullptr, 16)});
  }
  return true;
}

std::vector<std::string> DamagedOutputs(const std::string& outDir, const std::vector<OutputFile>& files) {
  std::vector<std::string> damaged;
  for (const OutputFile& f : files) {
    const std::string path = Joined(outDir, f.path);
    const std::string written = "(written with " + std::to_string(f.bytes) + " bytes)";
    std::string bytes, problem;
    if (!TryReadRegularFile(path, std::numeric_limits<size_t>::max(), bytes, problem)) {
      damaged.push_back(path + (problem == "no such file" ? " is missing " : " cannot be read (" + problem + ") ") +
                        written);
    } else if (bytes.size() != f.bytes) {
      damaged.push_back(path + " has " + std::to_string(bytes.size()) + " bytes " + written);
    } else if (Fnv1a(bytes.data(), bytes.size()) != f.fnv1a) {
      damaged.push_back(path + " has other bytes than were written (checksum " +
                        HexHash(Fnv1a(bytes.data(), bytes.size())) + ", written " + HexHash(f.fnv1a) + ")");
    }
  }
  return damaged;
}

}  // namespace restir
