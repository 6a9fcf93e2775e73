// Outputs are written to a temporary name beside the target and renamed, so a reader never sees a
// half-written file and a crash leaves the previous version intact (DESIGN §10).
#pragma once

#include <functional>
#include <string>

namespace restir {

// Writes `bytes` to `path` atomically (creating parent directories). Throws std::runtime_error on failure.
void WriteFileAtomic(const std::string& path, const std::string& bytes);

// Lets `writer` produce the file at a temporary path (for libraries that write files themselves), then renames
// it onto `path`. The temporary keeps the target's extension so format-sniffing writers pick the right format.
void WriteViaTemporary(const std::string& path, const std::function<void(const std::string& tmpPath)>& writer);

}  // namespace restir
