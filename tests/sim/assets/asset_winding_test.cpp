// Which side of an imported triangle is its front (sim/assets/asset_import.h), against the rule of the glTF 2.0
// specification (section 3.7.4), computed here: "the determinant of the node's global transform defines the
// winding order": counter-clockwise front faces where it is positive, clockwise where it is negative. The
// importer keeps one convention, counter-clockwise, so under a mirroring node it must reverse the file's order.
// The asset is written here: two single-triangle meshes, the first placed by nodes that mirror and by nodes that do
// not (a mesh shared that way must be copied, not reversed in place for all), nested mirrors that cancel, a
// reflection given as a matrix, and the second mesh placed only by a mirroring node. Every imported triangle must
// be one of the instances computed here, corner for corner (8 float ulps of the largest coordinate), with its
// cross product along the front normal computed here: the inverse transpose of the global transform applied to
// the local front. No sampling: every claim is exact geometry. Also: lines beside triangles in one mesh are
// skipped after the transforms are baked (the importer's step order), mirrored or not.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "asset_scene_writer.h"
#include "sim/assets/asset_import.h"

namespace restir {
namespace {

using namespace test;  // asset_scene_writer.h

// A node's transform as the test composes it (double): parent's global × local.
struct Instance {
  std::string node;
  int mesh = 0;
  Affine toRoot;
};

// The local triangles, counter-clockwise seen from −ŷ (their front in the file): cross(b − a, c − a) = −ŷ·|...|.
// Neither is symmetric, so a reflected copy cannot be mistaken for an unreflected one.
const D3 kTriangles[2][3] = {{{0, 0, 0}, {1, 0, 0}, {0.25, 0, 2}}, {{0, 0, 0}, {0.5, 0, 0}, {0, 0, 1.5}}};

TEST(AssetWinding, MirroringNodesReverseTheirTrianglesAsGltfSays) {
  Gltf g;
  const int material =
      g.Material({{"name", "grey"}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}}}});
  int meshes[2];
  for (int m = 0; m < 2; ++m) {
    const std::vector<D3> p(kTriangles[m], kTriangles[m] + 3);
    meshes[m] = g.Mesh(Json::array({Gltf::Primitive(g.Positions(p), g.Indices({0, 1, 2}), material)}));
  }
  // A reflection across the plane through the origin with normal (1, 2, 0) / √5, as a column-major matrix.
  const D3 n = glm::normalize(D3(1, 2, 0));
  const glm::dmat3 reflect = glm::dmat3(1.0) - 2.0 * glm::outerProduct(n, n);
  const D3 reflectAt{0, 0, 7};
  Json matrix = Json::array();
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row)
      matrix.push_back(col < 3 ? (row < 3 ? reflect[col][row] : 0.0) : (row < 3 ? reflectAt[row] : 1.0));
  const Affine identity;
  const auto trs = [](const D3& t, const D3& axis, double degrees, const D3& s) {
    return Affine{QuaternionMatrix(Quaternion(axis, degrees)) * Diagonal(s), t};
  };
  std::vector<Instance> expected;
  std::vector<int> roots;
  const auto node = [&](const std::string& name, int mesh, const D3& t, const D3& axis, double degrees, const D3& s,
                        const Affine& parent, const Json& children = Json::array()) {
    const glm::dvec4 q = Quaternion(axis, degrees);
    Json j = {{"name", name},     {"translation", J(t)}, {"rotation", {q.x, q.y, q.z, q.w}},
              {"scale", J(s)},    {"mesh", meshes[mesh]}};
    if (!children.empty()) j["children"] = children;
    const Affine global = trs(t, axis, degrees, s).Then(parent);
    expected.push_back({name, mesh, global});
    return g.Node(j);
  };
  roots.push_back(node("plain", 0, {0, 0, 0}, {0, 1, 0}, 30, {1, 1, 1}, identity));
  roots.push_back(node("mirrored in x", 0, {5, 0, 0}, {0, 0, 1}, 20, {-1, 1, 1}, identity));
  {
    // A parent mirrored in y holding a child mirrored in z: the parent's instance mirrors, the child's does not.
    const Affine parent = trs({0, 5, 0}, {1, 0, 0}, 10, {1, -1, 1});
    const int child = node("child mirrored in z under it", 0, {0, 0, 1}, {0, 1, 0}, 45, {1, 1, -2}, parent);
    roots.push_back(node("parent mirrored in y", 0, {0, 5, 0}, {1, 0, 0}, 10, {1, -1, 1}, identity,
                         Json::array({child})));
  }
  roots.push_back(g.Node({{"name", "reflection matrix"}, {"matrix", matrix}, {"mesh", meshes[0]}}));
  expected.push_back({"reflection matrix", 0, Affine{reflect, reflectAt}});
  roots.push_back(node("only the second mesh, mirrored in z", 1, {0, 0, -5}, {0, 1, 0}, 0, {1, 1, -2}, identity));

  const Scratch scratch("winding");
  WriteText(*scratch / "mirrors.gltf", g.Text(roots));
  const ImportedAsset asset = ImportAssetInProcess((*scratch / "mirrors.gltf").string());

  std::vector<std::array<D3, 3>> imported;
  double magnitude = 0.0;
  for (const AssetMesh& m : asset.meshes)
    for (const glm::uvec3& t : m.triangles) {
      imported.push_back({D3(m.positions[t.x]), D3(m.positions[t.y]), D3(m.positions[t.z])});
      for (int k = 0; k < 3; ++k) magnitude = std::max(magnitude, CompMax(glm::abs(imported.back()[k])));
    }
  ASSERT_EQ(imported.size(), expected.size());
  std::vector<bool> used(imported.size(), false);
  int mirroring = 0;
  for (const Instance& e : expected) {
    SCOPED_TRACE(e.node);
    const bool mirrors = glm::determinant(e.toRoot.a) < 0.0;
    mirroring += mirrors;
    const D3 front = glm::normalize(glm::transpose(glm::inverse(e.toRoot.a)) * D3(0, -1, 0));
    D3 corners[3];
    for (int k = 0; k < 3; ++k) corners[k] = e.toRoot(kTriangles[e.mesh][k]);
    // The imported triangle with these corners, in any order.
    size_t match = imported.size();
    for (size_t i = 0; i < imported.size() && match == imported.size(); ++i) {
      bool all = true;
      for (int k = 0; k < 3 && all; ++k) {
        bool found = false;
        for (int j = 0; j < 3; ++j)
          found = found || CompMax(glm::abs(imported[i][j] - corners[k])) <= FloatTolerance(magnitude);
        all = found;
      }
      if (all && !used[i]) match = i;
    }
    ASSERT_LT(match, imported.size()) << "no imported triangle has this instance's corners";
    used[match] = true;
    const std::array<D3, 3>& t = imported[match];
    const D3 cross = glm::cross(t[1] - t[0], t[2] - t[0]);
    EXPECT_GT(glm::dot(cross, front), 0.99 * glm::length(cross))
        << (mirrors ? "mirroring" : "non-mirroring") << " node: the imported winding faces ("
        << cross.x << ", " << cross.y << ", " << cross.z << "), the front is (" << front.x << ", " << front.y
        << ", " << front.z << ")";
  }
  EXPECT_EQ(mirroring, 4);  // mirrored in x, the parent, the reflection, the second mesh's node
}

// Points and lines beside triangles in one mesh (same material) stay out of the imported mesh after the node
// transforms are baked, mirrored or not: a line whose vertex lies beyond the importer's 1e7 coordinate limit must
// be skipped and counted, not refused as the mesh's vertex.
TEST(AssetWinding, LinesBesideTrianglesAreSkippedWhereverTheNodeIs) {
  for (const double sx : {1.0, -1.0}) {
    SCOPED_TRACE(sx < 0 ? "mirrored" : "plain");
    Gltf g;
    const int material = g.Material({{"name", "grey"}});
    const std::vector<D3> tri(kTriangles[0], kTriangles[0] + 3);
    Json lines = Gltf::Primitive(g.Positions({{0, 0, 0}, {5e7, 0, 0}}), g.Indices({0, 1}), material);
    lines["mode"] = 1;
    const int mesh = g.Mesh(Json::array({Gltf::Primitive(g.Positions(tri), g.Indices({0, 1, 2}), material), lines}));
    const Scratch scratch("lines");
    WriteText(*scratch / "lines.gltf", g.Text({g.Node({{"name", "n"}, {"mesh", mesh}, {"scale", {sx, 1.0, 1.0}}})}));
    const ImportedAsset a = ImportAssetInProcess((*scratch / "lines.gltf").string());
    ASSERT_EQ(a.meshes.size(), 1u);
    EXPECT_EQ(a.meshes[0].triangles.size(), 1u);
    EXPECT_EQ(a.meshes[0].positions.size(), 3u);
    EXPECT_EQ(a.skippedPrimitives, 1u);
  }
}

}  // namespace
}  // namespace restir
