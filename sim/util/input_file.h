// Reading an input file without trusting it (DESIGN §10): regular files only (a FIFO would block the reader and
// /dev/zero never ends), at most a stated size, read once.
#pragma once

#include <cstddef>
#include <string>

namespace restir {

// The file's bytes, or false with `problem` saying why not ("no such file", "not a regular file", "larger than
// 16 MiB", or the system's reason). Never blocks on a FIFO, never reads past maxBytes.
bool TryReadRegularFile(const std::string& path, size_t maxBytes, std::string& bytes, std::string& problem);

// The same checks without reading: for a file another reader (Assimp) will open itself.
bool IsReadableRegularFile(const std::string& path, size_t maxBytes, std::string& problem);

// The same, throwing InputError "<path>: error: cannot read <what> (<problem>)".
std::string ReadInputFile(const std::string& path, size_t maxBytes, const std::string& what);

// "16 MiB", "512 KiB", "3 bytes": a size for messages.
std::string FormatBytes(double bytes);

}  // namespace restir
