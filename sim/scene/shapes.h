// The shapes a sequence file can generate (DESIGN §8; docs/sequence-format.md "Shapes"), as object-space meshes
// with outward-facing winding.
#pragma once

#include <cstdint>

#include "sim/scene/sequence.h"

namespace restir {

// Appends a triangle whose winding makes its geometric normal point away from `inside`, so generated solids
// are consistently outward-facing without hand-ordering every face.
void AddTriangleOutward(Mesh& mesh, uint32_t a, uint32_t b, uint32_t c, const Vec3& inside);

// Corners center-u-v, center+u-v, center+u+v, center-u+v: counter-clockwise seen from the cross(u, v) side.
void QuadCorners(const Vec3& c, const Vec3& u, const Vec3& v, Vec3 out[4]);

// The quad's two triangles, counter-clockwise seen from the cross(u, v) side.
Mesh MakeQuad(const Vec3& c, const Vec3& u, const Vec3& v);

// An axis-aligned box [lo, hi], 8 vertices and 12 triangles.
void AppendBox(Mesh& mesh, const Vec3& lo, const Vec3& hi);

// A UV sphere with `segments` around and segments/2 rings, with its exact normals as shading normals.
Mesh MakeSphere(const Vec3& center, float radius, int segments);

// `count` boxes thickness x height x depth from `origin`, each `spacing` further along +x.
void AppendWindowBars(Mesh& mesh, const Vec3& origin, int count, float spacing, float thickness, float height,
                      float depth);

}  // namespace restir
