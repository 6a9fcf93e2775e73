#include "sim/scene/shapes.h"

#include <algorithm>
#include <cmath>

namespace restir {

void AddTriangleOutward(Mesh& mesh, uint32_t a, uint32_t b, uint32_t c, const Vec3& inside) {
  const Vec3& pa = mesh.positions[a];
  const Vec3 n = glm::cross(mesh.positions[b] - pa, mesh.positions[c] - pa);
  const Vec3 centroid = (pa + mesh.positions[b] + mesh.positions[c]) / 3.0f;
  if (glm::dot(n, centroid - inside) < 0.0f) std::swap(b, c);
  mesh.triangles.emplace_back(a, b, c);
}

void QuadCorners(const Vec3& c, const Vec3& u, const Vec3& v, Vec3 out[4]) {
  out[0] = c - u - v;
  out[1] = c + u - v;
  out[2] = c + u + v;
  out[3] = c - u + v;
}

void AppendBox(Mesh& mesh, const Vec3& lo, const Vec3& hi) {
  const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
  for (int i = 0; i < 8; ++i) {
    mesh.positions.emplace_back((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
  }
  const Vec3 center = 0.5f * (lo + hi);
  // Each face as four corner indices (bit 0 = x, bit 1 = y, bit 2 = z) going round the face.
  static constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                       {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  for (const auto& f : kFaces) {
    AddTriangleOutward(mesh, base + f[0], base + f[1], base + f[2], center);
    AddTriangleOutward(mesh, base + f[0], base + f[2], base + f[3], center);
  }
}

Mesh MakeSphere(const Vec3& center, float radius, int segments) {
  Mesh mesh;
  const int rings = std::max(2, segments / 2);
  auto addVertex = [&](const Vec3& n) {
    mesh.positions.push_back(center + radius * n);
    mesh.normals.push_back(n);
  };
  addVertex(Vec3(0.0f, 1.0f, 0.0f));
  for (int r = 1; r < rings; ++r) {
    const float theta = kPi * static_cast<float>(r) / static_cast<float>(rings);
    for (int s = 0; s < segments; ++s) {
      const float phi = 2.0f * kPi * static_cast<float>(s) / static_cast<float>(segments);
      addVertex(Vec3(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)));
    }
  }
  addVertex(Vec3(0.0f, -1.0f, 0.0f));
  const uint32_t bottom = static_cast<uint32_t>(mesh.positions.size() - 1);
  auto ringVertex = [&](int r, int s) {
    return static_cast<uint32_t>(1 + (r - 1) * segments + s % segments);
  };
  for (int s = 0; s < segments; ++s) {
    AddTriangleOutward(mesh, 0, ringVertex(1, s), ringVertex(1, s + 1), center);
    AddTriangleOutward(mesh, bottom, ringVertex(rings - 1, s), ringVertex(rings - 1, s + 1), center);
    for (int r = 1; r + 1 < rings; ++r) {
      AddTriangleOutward(mesh, ringVertex(r, s), ringVertex(r + 1, s), ringVertex(r + 1, s + 1), center);
      AddTriangleOutward(mesh, ringVertex(r, s), ringVertex(r + 1, s + 1), ringVertex(r, s + 1), center);
    }
  }
  return mesh;
}

Mesh MakeQuad(const Vec3& c, const Vec3& u, const Vec3& v) {
  Mesh mesh;
  Vec3 corners[4];
  QuadCorners(c, u, v, corners);
  mesh.positions.assign(corners, corners + 4);
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

void AppendWindowBars(Mesh& mesh, const Vec3& origin, int count, float spacing, float thickness, float height,
                      float depth) {
  for (int i = 0; i < count; ++i) {
    const Vec3 lo = origin + Vec3(static_cast<float>(i) * spacing, 0.0f, 0.0f);
    AppendBox(mesh, lo, lo + Vec3(thickness, height, depth));
  }
}

}  // namespace restir
