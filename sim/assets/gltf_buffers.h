// glTF's binary data checked as the glTF 2.0 specification defines it, before Assimp reads it leniently (Assimp 5.2
// drops a triangle whose index is out of range and imports the rest, reads an external buffer of any size, and
// reads NaN coordinates and zero normals as they come):
//   - every buffer's data found (relative files of at most the asset-size limit together, a base64 data: URI of a
//     buffer's media type, or the GLB's BIN chunk, which is then the first buffer's only source) and at least its
//     byteLength long (§3.6.1);
//   - every buffer view within its buffer, every accessor within its view, aligned to its component size, its
//     view's stride at least its element's size, a sparse accessor's indices strictly increasing and below its
//     count (§3.6.2), an accessor without a view (zeros) within the size limit;
//   - the data as a reader sees it (sparse values in place of the elements they replace): every float of every
//     accessor finite (§3.6.2.2), every index of a mesh primitive below its vertex count and not the
//     primitive-restart value (§3.7.2.1: "indices ... MUST NOT" exceed it, nor be the maximum of their type),
//     every NORMAL of unit length (§3.7.2.1; the Khronos validator's tolerance).
// It runs after sim/assets/gltf_schema.h, which has checked every field's type and every index's target.
#pragma once

#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace restir {

// `doc` is the glTF JSON of the asset at `path`, schema-checked (CheckGltfSchema); `glbBin` its GLB BIN chunk
// (nullopt for a .gltf or a GLB without one); relative buffer URIs resolve against `path`'s directory
// (ResolveGltfUriFile) and may name files of at most `maxBufferBytes` together. Throws InputError "<path>: error:
// <JSON path> ..." on the first violation.
void CheckGltfBuffers(const nlohmann::json& doc, std::optional<std::string_view> glbBin, const std::string& path,
                      size_t maxBufferBytes);

// The file a relative glTF URI joined to its asset's directory names: the path with its %XX escapes decoded (URIs
// are RFC 3986: "Box%20Textured.bin" is the file "Box Textured.bin") where that file exists, else the path as
// written. One function for the checks, Assimp's file system and the textures, so all read the same file.
std::string ResolveGltfUriFile(const std::string& joined);

}  // namespace restir
