// A glTF 2.0 asset's JSON (and a GLB's BIN chunk) read and checked before Assimp reads the same file
// leniently: the GLB framing (the specification's "GLB File Format"), the JSON itself, the document's
// structure (sim/assets/gltf_schema.h) and its binary data (sim/assets/gltf_buffers.h). What the Khronos glTF validator
// reports as an error is refused here with one message naming the JSON path inside the asset, but for the
// errors in data the simulator never reads, listed with their reasons in docs/sequence-format.md and checked
// against the validator itself by tests/sim/assets/gltf_validator_oracle_test.cpp.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace restir {

struct GltfDocument {
  nlohmann::json json;                  // the document, every check passed
  std::optional<std::string_view> bin;  // a GLB's BIN chunk, within the bytes given; nullopt for a .gltf or none
};

// `bytes` is the file at `path`, a GLB when `binary`; external buffers resolve against its directory and may
// be at most `maxBufferBytes` long together. Throws InputError "<path>: error: ..." on the first violation.
GltfDocument ReadGltfDocument(const std::string& bytes, const std::string& path, bool binary,
                              size_t maxBufferBytes);

}  // namespace restir
