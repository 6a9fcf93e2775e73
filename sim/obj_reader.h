// Wavefront OBJ meshes for the sequence's "mesh" shape (docs/sequence-format.md): v, vn and f (v, v/vt, v//vn,
// v/vt/vn; negative indices; polygons fan-triangulated). Other statements (vt, o, g, s, usemtl, mtllib, l ...) are
// ignored.
#pragma once

#include <string>

#include "sim/sequence.h"

namespace restir {

// The mesh in `bytes`, read from `objPath`. Errors are one InputError naming objPath, line and column, followed by
// `origin` (where the sequence asked for the mesh).
Mesh ParseObjMesh(const std::string& bytes, const std::string& objPath, const std::string& origin);

}  // namespace restir
