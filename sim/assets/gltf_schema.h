// A glTF 2.0 document's JSON checked as the specification defines it, before Assimp reads it leniently
// (Assimp 5.2 reads a string where a number belongs as 0 or as the default, clamps factors, follows an index
// past the end of its array to nothing, and reads a glTF 1.0 file with another reader). What the Khronos
// validator reports as an error in the document's structure is refused here, each with a message naming the
// JSON path inside the asset:
//   - the schema: every property of the core objects of its type (a string where a number belongs), integers,
//     ranges (material factors in [0, 1], a node's rotation a unit quaternion), array lengths, required
//     properties, and every index within the array it refers to; enumerations are open (a later glTF may add
//     values, and the validator only warns), so an unknown value is refused only where the simulator needs it;
//   - the rules beside the schema: asset.version 2.x, extensions declared in extensionsUsed and where their
//     specification puts them, every required one one the simulator reads (a loader that does not support a
//     required extension must fail: glTF 2.0, "Specifying Extensions"), a node with at most one parent, no loop
//     in the hierarchy, a scene's nodes roots, matrix or TRS, camera planes, a mesh primitive's attribute names,
//     formats and counts, and a TEXCOORD_n for every texture its material reads.
// The binary data (buffers, views, accessors, indices) is sim/assets/gltf_buffers.h's.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

namespace restir {

// Throws InputError "<path>: error: <JSON path> ..." on the first violation; `doc` is the parsed JSON of the
// glTF file at `path` (any JSON value).
void CheckGltfSchema(const nlohmann::json& doc, const std::string& path);

}  // namespace restir
