// What a run wrote, recorded when it was written and checked when the run resumes (`restir-sim run --resume`):
// a frame file deleted or damaged after its frame completed must be written again, not taken as done because the
// checkpoint or run.json says the frame is. Each record is a file's size and FNV-1a 64 checksum, read back from
// disk once the file is in place (what a later reader meets, not what the encoder meant to write).
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace restir {

// One written file.
struct OutputFile {
  std::string path;    // relative to the run's output directory, '/'-separated
  uint64_t bytes = 0;  // its size when written
  uint64_t fnv1a = 0;  // FNV-1a 64 of its bytes when written
};

// The files a run has written so far; Record may be called from the image writer's thread while the frame loop
// reads Files() between frames.
class OutputManifest {
 public:
  explicit OutputManifest(std::string outDir) : outDir_(std::move(outDir)) {}
  // Reads the file at outDir/relativePath back and records it (replacing an earlier record of the same path).
  // Throws OutputError when it cannot be read: a file just written that cannot be read back is a failed write.
  void Record(const std::string& relativePath);
  // The records, sorted by path.
  std::vector<OutputFile> Files() const;
  void Restore(std::vector<OutputFile> files);

  // Checkpoint serialisation (Io: BinaryWriter, ByteCounter or BinaryReader, sim/util/binary_io.h).
  template <typename Io>
  void Transfer(Io& io) {
    std::vector<OutputFile> files = Files();
    uint64_t n = files.size();
    io.Count(n);
    files.resize(n);
    for (OutputFile& f : files) {
      io.String(f.path);
      io.Pod(f.bytes);
      io.Pod(f.fnv1a);
    }
    Restore(std::move(files));
  }

 private:
  std::string outDir_;
  mutable std::mutex mutex_;
  std::vector<OutputFile> files_;
};

// run.json's "outputs": {path: {"bytes": n, "fnv1a": "16 hex digits"}}.
nlohmann::json OutputFilesJson(const std::vector<OutputFile>& files);
// The inverse; false when `j` is not that shape (a run.json from before outputs were recorded has none).
bool OutputFilesFromJson(const nlohmann::json& j, std::vector<OutputFile>& files);

// One line per recorded file that is missing, of another size or another checksum under outDir, e.g.
// "out/frames/ris/0002.exr is missing (written with 123456 bytes)". Empty when every file is as written.
std::vector<std::string> DamagedOutputs(const std::string& outDir, const std::vector<OutputFile>& files);

}  // namespace restir
