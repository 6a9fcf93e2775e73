// How imported assets read their textures (sim/assets/asset_import.h): glTF's UV sets (textureInfo.texCoord), the
// KHR_texture_transform extension and the sampler's wrap modes, checked against data made by someone else and
// against the specification's formulas written here.
//
// KhronosTextureTransformTestReadsAsItsAuthorsMarkedIt: Khronos' TextureTransformTest model (Debian's
//    assimp-testmodels, glTF2/textureTransform; its README in the glTF-Sample-Models repository says what a
//    correct reader shows). The top row's quads use offsets on the UV texture: each must show the colour of the
//    check mark the offset selects (green "U", blue "V", cyan "UV"), not the yellow "not supported" quadrant an
//    unapplied offset shows. The bottom row's quads use the arrow
//    texture rotated, scaled and both, with a clamping sampler, and place a green marker where the arrow must
//    point (red: the rotation applied the other way; yellow: not applied). The test samples each quad's texture
//    through the imported UVs and SampleBilinear on a 240 × 240 grid over the quad, finds the arrow (dark
//    texels), its axis (principal component) and its head (the end where the dark texels spread widest), and
//    requires the marker it points at (of the quad's markers within 15 degrees of its axis ahead of it, the
//    nearest to its head: the scale's green and yellow markers lie on one line) to be the green one, and no
//    repeated copy of the arrow (clamping: the dark texels form one arrow, all within its length of its centre).
//    The top row: the mean colour of the quad's saturated samples must be the check mark's.
//
// UvSetsAndTransformsFollowTheTextureInfo: a glTF written here with two UV sets, the base colour reading set 1
//    through a transform (offset, rotation, scale) and the emission texture set 0 through another; the imported
//    UVs must be the transforms of the file's, computed here in double from the extension's definition
//    (1e-6), the emission texture's apart.
//
// SamplerWrapModesReachTheTexturePerAxis: assimp-testmodels' BoxTextured-glTF declares MIRRORED_REPEAT on s and
//    CLAMP_TO_EDGE on t, its binary variant the default; the imported textures carry those, axis by axis.
// ImpossibleTextureReadsAreRefused: a UV set the mesh lacks (TEXCOORD_1, TEXCOORD_5000000), a transform out of float
//    range: InputError naming the file.
// MtlClampOptionClampsTheMap: an MTL map with "-clamp on" clamps, one without repeats.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "asset_scene_writer.h"
#include "sim/assets/asset_import.h"
#include "sim/scene/sequence.h"  // InputError
#include "sim/assets/texture.h"

namespace restir {
namespace {

using namespace test;  // asset_scene_writer.h

const std::string kModel = kModels + "glTF2/textureTransform/TextureTransformTest.gltf";

// The meshes of material `name` (Assimp merges a material's meshes into one), as world triangles with UVs.
struct UvTriangle {
  D3 p[3];
  Vec2 uv[3];
};
std::vector<UvTriangle> TrianglesOf(const ImportedAsset& a, const std::string& name, const Texture** texture) {
  std::vector<UvTriangle> out;
  for (const AssetMesh& m : a.meshes) {
    const AssetMaterial& mat = a.materials[m.material];
    if (mat.name != name) continue;
    if (texture) *texture = mat.baseColorTexture >= 0 ? &a.textures[size_t(mat.baseColorTexture)] : nullptr;
    for (const glm::uvec3& t : m.triangles) {
      UvTriangle u;
      for (int k = 0; k < 3; ++k) {
        u.p[k] = D3(m.positions[t[k]]);
        u.uv[k] = m.texcoords.empty() ? Vec2(0.0f) : m.texcoords[t[k]];
      }
      out.push_back(u);
    }
  }
  return out;
}

D3 Centroid(const std::vector<UvTriangle>& tris) {
  D3 c(0.0);
  for (const UvTriangle& t : tris) c += (t.p[0] + t.p[1] + t.p[2]) / 3.0;
  return c / double(std::max<size_t>(1, tris.size()));
}

// The texture over a quad's triangles on an n × n barycentric grid per triangle: world point and colour.
struct Sample {
  D3 p;
  Vec3 rgb;
};
std::vector<Sample> SampleQuad(const std::vector<UvTriangle>& tris, const Texture& tex, int n) {
  std::vector<Sample> out;
  for (const UvTriangle& t : tris)
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        const double b1 = (i + 1.0 / 3.0) / n, b2 = (j + 1.0 / 3.0) / n, b0 = 1.0 - b1 - b2;
        const D3 p = b0 * t.p[0] + b1 * t.p[1] + b2 * t.p[2];
        const glm::dvec2 uv = b0 * glm::dvec2(t.uv[0]) + b1 * glm::dvec2(t.uv[1]) + b2 * glm::dvec2(t.uv[2]);
        out.push_back({p, SampleBilinear(tex, float(uv.x), float(uv.y))});
      }
  return out;
}

TEST(AssetTextureTransform, KhronosTextureTransformTestReadsAsItsAuthorsMarkedIt) {
  ASSERT_TRUE(HaveModel(kModel));
  const ImportedAsset a = ImportAssetInProcess(kModel);

  // Top row: the colour at each quad's centre (the UV texture's check-mark quadrants are saturated primaries).
  struct Top {
    const char* material;
    Vec3 want;  // the dominant channels of the check mark's quadrant, 1 where strong
  };
  for (const Top& q : {Top{"Offset U", {0, 1, 0}}, Top{"Offset V", {0, 0, 1}}, Top{"Offset UV", {0, 1, 1}}}) {
    SCOPED_TRACE(q.material);
    const Texture* tex = nullptr;
    const std::vector<UvTriangle> tris = TrianglesOf(a, q.material, &tex);
    ASSERT_EQ(tris.size(), 2u);
    ASSERT_NE(tex, nullptr);
    // The mean of the saturated samples over the quad (the white mark and the grey border aside).
    glm::dvec3 c(0.0);
    int saturated = 0;
    for (const Sample& s : SampleQuad(tris, *tex, 120)) {
      if (std::max({s.rgb.x, s.rgb.y, s.rgb.z}) - std::min({s.rgb.x, s.rgb.y, s.rgb.z}) < 0.3f) continue;
      c += glm::dvec3(s.rgb);
      ++saturated;
    }
    ASSERT_GT(saturated, 1000);
    c /= double(saturated);
    const double top = std::max({c.x, c.y, c.z});
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_EQ(c[ch] > 0.5 * top, q.want[ch] > 0.5f) << "mean colour (" << c.x << ", " << c.y << ", " << c.z << ")";
  }

  // Markers: each is a small quad; clustered by position, each belongs to the nearest big quad.
  std::map<std::string, std::vector<D3>> markers;  // marker material -> centres
  for (const char* marker : {"Correct", "NotSupported", "Error"}) {
    std::vector<UvTriangle> tris = TrianglesOf(a, marker, nullptr);
    std::vector<std::vector<UvTriangle>> clusters;
    for (const UvTriangle& t : tris) {
      const D3 c = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
      bool placed = false;
      for (auto& cl : clusters)
        if (!placed && glm::length(Centroid(cl) - c) < 0.1) cl.push_back(t), placed = true;
      if (!placed) clusters.push_back({t});
    }
    for (const auto& cl : clusters) markers[marker].push_back(Centroid(cl));
  }
  ASSERT_EQ(markers["Correct"].size(), 3u);  // one per bottom quad

  for (const char* quad : {"Rotation", "Scale", "All"}) {
    SCOPED_TRACE(quad);
    const Texture* tex = nullptr;
    const std::vector<UvTriangle> tris = TrianglesOf(a, quad, &tex);
    ASSERT_EQ(tris.size(), 2u);
    ASSERT_NE(tex, nullptr);
    const D3 centre = Centroid(tris);
    const std::vector<Sample> samples = SampleQuad(tris, *tex, 240);
    // Dark texels: the arrow (the texture's ground is white, its border light grey).
    std::vector<D3> dark;
    for (const Sample& s : samples)
      if (0.2126 * s.rgb.x + 0.7152 * s.rgb.y + 0.0722 * s.rgb.z < 0.2) dark.push_back(s.p);
    ASSERT_GT(dark.size(), 500u);
    D3 mean(0.0);
    for (const D3& p : dark) mean += p;
    mean /= double(dark.size());
    // Principal axis in the quad's plane (z = const here): the 2 × 2 covariance's leading eigenvector.
    double sxx = 0, sxy = 0, syy = 0;
    for (const D3& p : dark) {
      const D3 d = p - mean;
      sxx += d.x * d.x, sxy += d.x * d.y, syy += d.y * d.y;
    }
    const double angle = 0.5 * std::atan2(2 * sxy, sxx - syy);
    D3 axis(std::cos(angle), std::sin(angle), 0.0);
    // The head is the end where the dark texels spread widest across the axis.
    double lo = INFINITY, hi = -INFINITY;
    for (const D3& p : dark) lo = std::min(lo, glm::dot(p - mean, axis)), hi = std::max(hi, glm::dot(p - mean, axis));
    double spreadLo = 0, spreadHi = 0;
    const D3 across(-axis.y, axis.x, 0.0);
    for (const D3& p : dark) {
      const double along = glm::dot(p - mean, axis), off = std::fabs(glm::dot(p - mean, across));
      if (along < lo + 0.2 * (hi - lo)) spreadLo = std::max(spreadLo, off);
      if (along > hi - 0.2 * (hi - lo)) spreadHi = std::max(spreadHi, off);
    }
    if (spreadLo > spreadHi) axis = -axis, std::swap(lo, hi), lo = -lo, hi = -hi;
    // One arrow, not tiled copies: every dark texel within the arrow's length of its mean.
    const double length = hi - lo;
    for (const D3& p : dark) ASSERT_LE(glm::length(p - mean), length) << "a repeated arrow: the sampler clamps";
    // The marker the arrow points at: among this quad's markers (nearest to it) within 15 degrees of the axis
    // ahead of the head, the nearest to the head (the scale's correct and unscaled markers lie on one line).
    const D3 head = mean + hi * axis;
    std::string best;
    double bestAngle = INFINITY, bestDistance = INFINITY;
    for (const auto& [name, centres] : markers)
      for (const D3& m : centres) {
        double nearest = INFINITY;
        for (const char* other : {"Rotation", "Scale", "All"})
          nearest = std::min(nearest, glm::length(m - Centroid(TrianglesOf(a, other, nullptr))));
        if (glm::length(m - centre) > nearest + 1e-9) continue;  // another quad's marker
        const double cosine = glm::dot(glm::normalize(m - mean), axis);
        const double degrees = glm::degrees(std::acos(std::clamp(cosine, -1.0, 1.0)));
        if (degrees < 15.0 && glm::length(m - head) < bestDistance)
          bestAngle = degrees, bestDistance = glm::length(m - head), best = name;
      }
    std::printf("  %s: the arrow points at the %s marker (%.1f degrees off)\n", quad, best.c_str(), bestAngle);
    EXPECT_EQ(best, "Correct");
    EXPECT_LT(bestAngle, 15.0);
  }
}

TEST(AssetTextureTransform, UvSetsAndTransformsFollowTheTextureInfo) {
  const Scratch scratch("uvsets");
  WritePng(*scratch / "a.png", 2, 2, {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255});
  Gltf g;
  const int texture = g.Texture("a.png");
  const Json baseTransform = {{"offset", {0.25, -0.5}}, {"rotation", 0.7}, {"scale", {2.0, 0.5}}};
  const Json emissiveTransform = {{"offset", {-0.125, 0.375}}, {"rotation", -1.9}, {"scale", {0.75, 1.25}}};
  const int material = g.Material(
      {{"name", "two sets"},
       {"pbrMetallicRoughness",
        {{"baseColorTexture",
          {{"index", texture}, {"texCoord", 1}, {"extensions", {{"KHR_texture_transform", baseTransform}}}}}}},
       {"emissiveFactor", {1.0, 1.0, 1.0}},
       {"emissiveTexture", {{"index", texture}, {"extensions", {{"KHR_texture_transform", emissiveTransform}}}}}});
  const std::vector<D3> positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
  const std::vector<glm::dvec2> set0 = {{0.1, 0.2}, {0.9, 0.3}, {0.4, 0.8}};  // (s, t) as the file holds them
  const std::vector<glm::dvec2> set1 = {{-0.3, 1.7}, {2.5, 0.25}, {0.6, -1.1}};
  Json primitive = Gltf::Primitive(g.Positions(positions), g.Indices({0, 1, 2}), material, g.Texcoords(set0));
  primitive["attributes"]["TEXCOORD_1"] = g.Texcoords(set1);
  const int mesh = g.Mesh(Json::array({primitive}));
  WriteText(*scratch / "uv.gltf", g.Text({g.Node({{"name", "n"}, {"mesh", mesh}})}));
  const ImportedAsset a = ImportAssetInProcess((*scratch / "uv.gltf").string());
  ASSERT_EQ(a.meshes.size(), 1u);
  const AssetMesh& m = a.meshes[0];
  ASSERT_EQ(m.texcoords.size(), 3u);
  ASSERT_EQ(m.emissionTexcoords.size(), 3u);
  // KHR_texture_transform (ratified): (s', t') = offset + R diag(scale) (s, t), R's columns (cos, -sin), (sin, cos);
  // the importer's v is 1 - t.
  auto apply = [](const Json& tr, const glm::dvec2& st) {
    const double r = tr["rotation"].get<double>(), c = std::cos(r), s = std::sin(r);
    const double x = tr["scale"][0].get<double>() * st.x, y = tr["scale"][1].get<double>() * st.y;
    return glm::dvec2(tr["offset"][0].get<double>() + c * x + s * y, tr["offset"][1].get<double>() - s * x + c * y);
  };
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 base = apply(baseTransform, set1[k]), emission = apply(emissiveTransform, set0[k]);
    EXPECT_NEAR(m.texcoords[k].x, base.x, 1e-6) << k;
    EXPECT_NEAR(m.texcoords[k].y, 1.0 - base.y, 1e-6) << k;
    EXPECT_NEAR(m.emissionTexcoords[k].x, emission.x, 1e-6) << k;
    EXPECT_NEAR(m.emissionTexcoords[k].y, 1.0 - emission.y, 1e-6) << k;
  }
}

// A sampler written by someone else with a different mode per axis: assimp-testmodels' BoxTextured-glTF has wrapS
// MIRRORED_REPEAT (33648), wrapT CLAMP_TO_EDGE (33071); its .glb and embedded variants the default REPEAT.
TEST(AssetTextureTransform, SamplerWrapModesReachTheTexturePerAxis) {
  const std::string dir = kModels + "glTF2/";
  struct Case {
    const char* file;
    TextureWrap u, v;
  };
  const Case cases[] = {
      {"BoxTextured-glTF/BoxTextured.gltf", TextureWrap::kMirroredRepeat, TextureWrap::kClampToEdge},
      {"BoxTextured-glTF-Binary/BoxTextured.glb", TextureWrap::kRepeat, TextureWrap::kRepeat}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    ASSERT_TRUE(HaveModel(dir + c.file));
    const ImportedAsset a = ImportAssetInProcess(dir + c.file);
    ASSERT_EQ(a.textures.size(), 1u);
    EXPECT_EQ(a.textures[0].wrapU, c.u);
    EXPECT_EQ(a.textures[0].wrapV, c.v);
  }
}

// What the textureInfo asks that the mesh cannot give is an InputError naming the file: a UV set the mesh lacks
// (the emission texture must not fall back to the base colour's UVs), a set beyond TEXCOORD_7, a transform that
// takes UVs out of float range.
TEST(AssetTextureTransform, ImpossibleTextureReadsAreRefused) {
  struct Case {
    const char* name;
    Json base, emissive;  // textureInfo extras
    const char* says;
  };
  const Json shift = {{"extensions", {{"KHR_texture_transform", {{"offset", {0.5, 0.25}}}}}}};
  const std::vector<Case> cases = {
      {"emission on a set the mesh lacks", shift, {{"texCoord", 1}}, "TEXCOORD_1"},
      {"set beyond TEXCOORD_7", {{"texCoord", 5000000}}, Json::object(),
       "reads TEXCOORD_5000000, which the primitive does not have"},
      {"transform out of float range",
       {{"extensions", {{"KHR_texture_transform", {{"scale", {1e308, 1e308}}}}}}},
       Json::object(),
       "out of range"}};
  int index = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Scratch scratch("refused" + std::to_string(index++));
    WritePng(*scratch / "a.png", 2, 2, {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255});
    Gltf g;
    const int texture = g.Texture("a.png");
    Json base = c.base, emissive = c.emissive;
    base["index"] = texture;
    emissive["index"] = texture;
    const int material = g.Material({{"name", "m"},
                                     {"pbrMetallicRoughness", {{"baseColorTexture", base}}},
                                     {"emissiveFactor", {1.0, 1.0, 1.0}},
                                     {"emissiveTexture", emissive}});
    const std::vector<D3> positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
    const int mesh = g.Mesh(Json::array({Gltf::Primitive(g.Positions(positions), g.Indices({0, 1, 2}), material,
                                                         g.Texcoords({{0.1, 0.2}, {0.9, 0.3}, {0.4, 0.8}}))}));
    WriteText(*scratch / "x.gltf", g.Text({g.Node({{"name", "n"}, {"mesh", mesh}})}));
    const std::string path = (*scratch / "x.gltf").string();
    try {
      ImportAssetInProcess(path);
      ADD_FAILURE() << "imported";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(c.says), std::string::npos) << what;
    }
  }
}

// MTL's "-clamp on" (the OBJ counterpart of a clamping sampler) clamps the map; without it the map repeats.
TEST(AssetTextureTransform, MtlClampOptionClampsTheMap) {
  const Scratch scratch("mtlclamp");
  WritePng(*scratch / "t.png", 2, 2, {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255});
  WriteText(*scratch / "a.mtl", "newmtl clamped\nKd 1 1 1\nmap_Kd -clamp on t.png\n"
                                "newmtl repeated\nKd 1 1 1\nmap_Kd t.png\n");
  WriteText(*scratch / "a.obj",
            "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nv 0 1 0\nvt 0 0\nvt 2 0\nvt 0 2\n"
            "usemtl clamped\nf 1/1 2/2 3/3\nusemtl repeated\nf 1/1 3/3 4/2\n");
  const ImportedAsset a = ImportAssetInProcess((*scratch / "a.obj").string());
  int seen = 0;
  for (const AssetMaterial& m : a.materials) {
    if (m.baseColorTexture < 0) continue;
    const Texture& t = a.textures[size_t(m.baseColorTexture)];
    const TextureWrap want = m.name == "clamped" ? TextureWrap::kClampToEdge : TextureWrap::kRepeat;
    EXPECT_EQ(t.wrapU, want) << m.name;
    EXPECT_EQ(t.wrapV, want) << m.name;
    ++seen;
  }
  EXPECT_EQ(seen, 2);
}

}  // namespace
}  // namespace restir
