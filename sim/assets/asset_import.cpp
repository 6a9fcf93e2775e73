// The Assimp half of sim/assets/asset_import.h: one aiScene → ImportedAsset, in whichever process calls it.
#include "sim/assets/asset_import.h"

#include <assimp/GltfMaterial.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/SceneCombiner.h>
#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>

#include "sim/assets/gltf_buffers.h"  // ResolveGltfUriFile
#include "sim/assets/gltf_document.h"
#include "sim/util/input_file.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

constexpr size_t kMaxAssetFileBytes = size_t(1) << 30;
constexpr size_t kMaxTextureFileBytes = size_t(256) << 20;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(OneLine(path + ": error: " + what));
}

// How a material reads one of its textures (glTF 2.0 section 5.22 textureInfo, 5.26 sampler; KHR_texture_transform),
// which Assimp 5.2 either does not keep (the transform is only its own re-parametrisation, whose composition with
// its TransformUVCoords step is not the extension's) or keeps per material slot (set, wrap), so it is read here from
// the JSON with the material's other keys.
struct GltfTextureUse {
  bool present = false;
  std::string image;  // images[source].uri ("" for an image in a buffer view): tells materials apart
  int texCoord = 0;   // the UV set (TEXCOORD_n); the transform's own texCoord overrides the textureInfo's
  // KHR_texture_transform, in glTF's texture space (s right, t down from the top-left corner): (s', t') = offset +
  // R diag(scale) (s, t) with R = [cos r, sin r; -sin r, cos r]. The extension's own example (offset (0, 1),
  // rotation pi/2, scale 1/2 selects the lower-left quadrant) and Khronos' TextureTransformTest model (its arrow
  // points at the green marker) agree on this R; the GLSL in the extension's text, read as column-major, gives
  // the transpose, with which the model's arrow points at its red "rotated the wrong way" marker.
  double offset[2] = {0.0, 0.0};
  double rotation = 0.0;
  double scale[2] = {1.0, 1.0};
  TextureWrap wrapS = TextureWrap::kRepeat;
  TextureWrap wrapT = TextureWrap::kRepeat;
  bool Transformed() const {
    return offset[0] != 0.0 || offset[1] != 0.0 || rotation != 0.0 || scale[0] != 1.0 || scale[1] != 1.0;
  }
  // The same UVs: set and transform (the sampler aside).
  bool SameUvs(const GltfTextureUse& o) const {
    return texCoord == o.texCoord && offset[0] == o.offset[0] && offset[1] == o.offset[1] &&
           rotation == o.rotation && scale[0] == o.scale[0] && scale[1] == o.scale[1];
  }
  bool operator==(const GltfTextureUse& o) const {
    return present == o.present && image == o.image && SameUvs(o) && wrapS == o.wrapS && wrapT == o.wrapT;
  }
  // A UV as Assimp delivers it (v up: v = 1 - t) through the transform, back in the same convention. In double,
  // then rounded once.
  Vec2 Apply(const Vec2& uv) const {
    const double s = uv.x, t = 1.0 - double(uv.y);
    const double c = std::cos(rotation), n = std::sin(rotation);
    const double ss = scale[0] * s, st = scale[1] * t;
    const double s2 = offset[0] + c * ss + n * st, t2 = offset[1] - n * ss + c * st;
    // Out of float range: not finite (Texcoords refuses it), never a conversion out of range.
    constexpr double kMax = std::numeric_limits<float>::max();
    const double u = s2, v = 1.0 - t2;
    return Vec2(std::fabs(u) <= kMax ? static_cast<float>(u) : INFINITY,
                std::fabs(v) <= kMax ? static_cast<float>(v) : INFINITY);
  }
};

// KHR_materials_emissive_strength, which Assimp 5.2 does not read. Assimp numbers glTF materials in the order its
// reader first meets them, not the file's, so each file material is kept with what identifies it (its name and
// factors), and an Assimp material takes the strength and the texture uses of the file materials that look exactly
// like it.
struct GltfMaterialKey {
  std::string name;
  Vec3 baseColor{1.0f};  // baseColorFactor rgb
  Vec3 emissive{0.0f};   // emissiveFactor
  float metallic = 1.0f;
  float roughness = 1.0f;
  float strength = 1.0f;  // emissiveStrength, 1 where absent
  GltfTextureUse baseColorTexture;
  GltfTextureUse emissiveTexture;
};

// glTF's sampler wrap enums (OpenGL's values); an unknown value reads as the default, REPEAT.
TextureWrap WrapOf(int gl) {
  return gl == 33071 ? TextureWrap::kClampToEdge : gl == 33648 ? TextureWrap::kMirroredRepeat : TextureWrap::kRepeat;
}

// The triangles the checked glTF document's scene places (every node reachable from its scene, or from the first
// scene, once per node that instances a mesh): what Assimp will build, counted before it does.
uint64_t GltfTriangles(const nlohmann::json& doc) {
  if (!doc.contains("scenes")) return 0;
  const nlohmann::json& scene = doc["scenes"][doc.value("scene", size_t(0))];
  std::vector<uint64_t> open;
  if (scene.contains("nodes")) open = scene["nodes"].get<std::vector<uint64_t>>();
  uint64_t triangles = 0;
  while (!open.empty()) {  // the hierarchy is a forest (sim/assets/gltf_schema.h): each node is met once
    const nlohmann::json& node = doc["nodes"][open.back()];
    open.pop_back();
    if (node.contains("children"))
      for (const auto& c : node["children"]) open.push_back(c.get<uint64_t>());
    if (!node.contains("mesh")) continue;
    for (const auto& p : doc["meshes"][node["mesh"].get<size_t>()]["primitives"]) {
      const auto& accessor = doc["accessors"][(p.contains("indices") ? p["indices"]
                                                                      : p["attributes"].begin().value()).get<size_t>()];
      const uint64_t n = accessor["count"].get<uint64_t>(), mode = p.value("mode", uint64_t(4));
      triangles += mode == 4 ? n / 3 : mode == 5 || mode == 6 ? (n > 2 ? n - 2 : 0) : 0;
    }
  }
  return triangles;
}

// Each material's keys and texture uses from the asset's checked glTF JSON.
std::vector<GltfMaterialKey> GltfMaterialKeys(const nlohmann::json& doc, const std::string& path) {
  using Json = nlohmann::json;
  std::vector<GltfMaterialKey> keys;
  const auto materials = doc.find("materials");
  if (materials == doc.end() || !materials->is_array()) return keys;
  auto number = [](const Json& o, const char* k, float fallback) {
    const auto v = o.is_object() ? o.find(k) : o.end();
    return v != o.end() && v->is_number() ? v->get<float>() : fallback;
  };
  auto vec3 = [](const Json& o, const char* k, Vec3 fallback) {
    const auto v = o.is_object() ? o.find(k) : o.end();
    if (v == o.end() || !v->is_array() || v->size() < 3) return fallback;
    for (int c = 0; c < 3; ++c)
      if (!(*v)[c].is_number()) return fallback;
    return Vec3((*v)[0].get<float>(), (*v)[1].get<float>(), (*v)[2].get<float>());
  };
  static const Json kNone = Json::object();
  auto member = [](const Json& o, const char* k) -> const Json& {
    return o.is_object() && o.contains(k) ? o[k] : kNone;
  };
  auto element = [&](const char* array, const Json& index) -> const Json& {
    const Json& a = member(doc, array);
    if (!a.is_array() || !index.is_number_unsigned() || index.get<uint64_t>() >= a.size()) return kNone;
    return a[index.get<size_t>()];
  };
  // k's value where it is a non-negative integer below 2^20; `absent` where there is none, `invalid` otherwise.
  auto integer = [](const Json& o, const char* k, int absent, int invalid) {
    const auto v = o.is_object() ? o.find(k) : o.end();
    if (v == o.end()) return absent;
    return v->is_number_unsigned() && v->get<uint64_t>() < (uint64_t(1) << 20) ? v->get<int>() : invalid;
  };
  auto textureUse = [&](const Json& holder, const char* k) {
    GltfTextureUse use;
    const Json& info = member(holder, k);
    if (!info.is_object() || !info.contains("index")) return use;
    use.present = true;
    const Json& texture = element("textures", info["index"]);
    const Json& image = element("images", member(texture, "source"));
    if (image.contains("uri") && image["uri"].is_string()) use.image = image["uri"].get<std::string>();
    const Json& sampler = element("samplers", member(texture, "sampler"));
    use.wrapS = WrapOf(integer(sampler, "wrapS", 10497, 10497));
    use.wrapT = WrapOf(integer(sampler, "wrapT", 10497, 10497));
    use.texCoord = integer(info, "texCoord", 0, -1);
    const Json& t = member(member(info, "extensions"), "KHR_texture_transform");
    if (t.is_object()) {
      auto pair = [&](const char* name, double* out) {
        const Json& v = member(t, name);
        if (v.is_array() && v.size() == 2 && v[0].is_number() && v[1].is_number())
          out[0] = v[0].get<double>(), out[1] = v[1].get<double>();
      };
      pair("offset", use.offset);
      pair("scale", use.scale);
      if (member(t, "rotation").is_number()) use.rotation = t["rotation"].get<double>();
      use.texCoord = integer(t, "texCoord", use.texCoord, -1);
      if (!std::isfinite(use.offset[0]) || !std::isfinite(use.offset[1]) || !std::isfinite(use.rotation) ||
          !std::isfinite(use.scale[0]) || !std::isfinite(use.scale[1]))
        Fail(path, std::string("material texture '") + k + "' has a non-finite KHR_texture_transform");
    }
    return use;
  };
  for (const Json& m : *materials) {
    GltfMaterialKey k;
    if (!m.is_object()) {
      keys.push_back(k);
      continue;
    }
    if (m.contains("name") && m["name"].is_string()) k.name = m["name"].get<std::string>();
    const Json& pbr = m.contains("pbrMetallicRoughness") ? m["pbrMetallicRoughness"] : kNone;
    k.baseColor = vec3(pbr, "baseColorFactor", Vec3(1.0f));
    k.metallic = number(pbr, "metallicFactor", 1.0f);
    k.roughness = number(pbr, "roughnessFactor", 1.0f);
    k.emissive = vec3(m, "emissiveFactor", Vec3(0.0f));
    const Json& ext = m.contains("extensions") ? m["extensions"] : kNone;
    const Json& es = ext.is_object() && ext.contains("KHR_materials_emissive_strength")
                         ? ext["KHR_materials_emissive_strength"]
                         : kNone;
    k.strength = number(es, "emissiveStrength", 1.0f);
    k.baseColorTexture = textureUse(pbr, "baseColorTexture");
    k.emissiveTexture = textureUse(m, "emissiveTexture");
    keys.push_back(k);
  }
  return keys;
}

// glTF 2.0 (section 3.7.4): "When a mesh primitive uses any triangle-based topology, the determinant of the node's
// global transform defines the winding order of that primitive": counter-clockwise front faces where it is
// positive, clockwise where it is negative. The simulator keeps one rule, counter-clockwise (an emitter's front is
// cross(e1, e2)), so the triangles of every mesh placed by a mirroring node (negative determinant) are reversed
// before the transforms are baked; a mesh placed both by mirroring and other nodes is copied for the mirroring
// ones. OBJ and PLY have no node transforms, so this only ever concerns glTF.
void ReverseMirroredWinding(aiScene& scene) {
  if (!scene.mRootNode || scene.mNumMeshes == 0) return;
  // Each node with meshes and whether its global transform mirrors (parent × local, as Assimp composes them).
  std::vector<std::pair<aiNode*, bool>> placed;
  std::vector<std::pair<aiNode*, aiMatrix4x4>> stack{{scene.mRootNode, scene.mRootNode->mTransformation}};
  std::set<const aiNode*> seen;  // Assimp refuses cyclic node graphs; this loop does not rely on it
  while (!stack.empty()) {
    auto [node, global] = stack.back();
    stack.pop_back();
    if (!seen.insert(node).second) continue;
    const double a[3][3] = {{global.a1, global.a2, global.a3}, {global.b1, global.b2, global.b3},
                            {global.c1, global.c2, global.c3}};
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                       a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                       a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if (node->mNumMeshes > 0 && node->mMeshes) placed.emplace_back(node, det < 0.0);
    for (unsigned c = 0; c < node->mNumChildren; ++c)
      if (node->mChildren[c]) stack.emplace_back(node->mChildren[c], global * node->mChildren[c]->mTransformation);
  }
  // Per mesh: placed by a mirroring node, by another node.
  std::vector<uint8_t> mirrored(scene.mNumMeshes, 0), plain(scene.mNumMeshes, 0);
  for (const auto& [node, mirrors] : placed)
    for (unsigned k = 0; k < node->mNumMeshes; ++k)
      if (node->mMeshes[k] < scene.mNumMeshes) (mirrors ? mirrored : plain)[node->mMeshes[k]] = 1;
  // The mesh the mirroring nodes use: the mesh itself, reversed, or a reversed copy appended to the scene.
  std::vector<unsigned> reversedIndex(scene.mNumMeshes);
  std::vector<aiMesh*> copies;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    reversedIndex[m] = m;
    if (!mirrored[m]) continue;
    aiMesh* target = scene.mMeshes[m];
    if (plain[m]) {
      aiMesh* copy = nullptr;
      Assimp::SceneCombiner::Copy(&copy, target);
      copies.push_back(copy);
      reversedIndex[m] = scene.mNumMeshes + static_cast<unsigned>(copies.size() - 1);
      target = copy;
    }
    for (unsigned f = 0; f < target->mNumFaces; ++f) {
      aiFace& face = target->mFaces[f];
      if (face.mNumIndices == 3) std::swap(face.mIndices[1], face.mIndices[2]);
    }
  }
  if (!copies.empty()) {
    aiMesh** meshes = new aiMesh*[scene.mNumMeshes + copies.size()];
    std::copy(scene.mMeshes, scene.mMeshes + scene.mNumMeshes, meshes);
    std::copy(copies.begin(), copies.end(), meshes + scene.mNumMeshes);
    delete[] scene.mMeshes;
    scene.mMeshes = meshes;
    scene.mNumMeshes += static_cast<unsigned>(copies.size());
  }
  for (const auto& [node, mirrors] : placed)
    if (mirrors)
      for (unsigned k = 0; k < node->mNumMeshes; ++k)
        if (node->mMeshes[k] < reversedIndex.size()) node->mMeshes[k] = reversedIndex[node->mMeshes[k]];
}

class Converter {
 public:
  Converter(const std::string& path, const aiScene& scene, const AssetLimits& limits)
      : path_(path), scene_(scene), limits_(limits) {}

  ImportedAsset Convert(const std::vector<GltfMaterialKey>& gltfMaterials, bool gltf) {
    gltf_ = gltf;
    for (unsigned m = 0; m < scene_.mNumMaterials; ++m)
      asset_.materials.push_back(ConvertMaterial(*scene_.mMaterials[m], gltfMaterials, gltf));
    if (asset_.materials.empty()) asset_.materials.push_back(AssetMaterial{});
    uint64_t triangles = 0;
    for (unsigned i = 0; i < scene_.mNumMeshes; ++i) {
      const aiMesh& m = *scene_.mMeshes[i];
      if (!(m.mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || m.mNumVertices == 0) {
        asset_.skippedPrimitives += m.mNumFaces;
        continue;
      }
      AssetMesh out;
      out.name = m.mName.C_Str();
      out.material = m.mMaterialIndex < asset_.materials.size() ? m.mMaterialIndex : 0;
      out.positions.reserve(m.mNumVertices);
      for (unsigned v = 0; v < m.mNumVertices; ++v)
        out.positions.emplace_back(m.mVertices[v].x, m.mVertices[v].y, m.mVertices[v].z);
      if (m.mNormals) {
        for (unsigned v = 0; v < m.mNumVertices; ++v)
          out.normals.emplace_back(m.mNormals[v].x, m.mNormals[v].y, m.mNormals[v].z);
      }
      // The base-colour texture's UVs (else the emission texture's, else the first set as it is); the emission
      // texture's apart where they differ.
      const MaterialUvs& uvs = out.material < materialUvs_.size() ? materialUvs_[out.material] : MaterialUvs{};
      out.texcoords = Texcoords(m, uvs.baseColor.present ? uvs.baseColor : uvs.emission, false, i);
      if (uvs.baseColor.present && uvs.emission.present && !uvs.baseColor.SameUvs(uvs.emission))
        out.emissionTexcoords = Texcoords(m, uvs.emission, true, i);
      for (unsigned f = 0; f < m.mNumFaces; ++f) {
        const aiFace& face = m.mFaces[f];
        if (face.mNumIndices != 3) {
          ++asset_.skippedPrimitives;
          continue;
        }
        for (unsigned k = 0; k < 3; ++k) {
          if (face.mIndices[k] >= m.mNumVertices)
            Fail(path_, "mesh '" + out.name + "' (#" + std::to_string(i) + ") face " + std::to_string(f) +
                            " uses vertex " + std::to_string(face.mIndices[k]) + " of " +
                            std::to_string(m.mNumVertices));
        }
        out.triangles.emplace_back(face.mIndices[0], face.mIndices[1], face.mIndices[2]);
      }
      triangles += out.triangles.size();
      if (triangles > limits_.maxTriangles)
        Fail(path_, "the asset holds more than " + std::to_string(limits_.maxTriangles) + " triangles");
      if (!out.triangles.empty()) asset_.meshes.push_back(std::move(out));
    }
    return std::move(asset_);
  }

 private:
  // UV set `use.texCoord` of `m`, through the use's transform. A mesh without UVs at all (no set 0) reads every
  // texture at (0, 0): `fill` then gives one (0, 0) per vertex (where the texture's UVs must differ from the
  // mesh's other texture's), else none. A set that is not a small integer, or that the mesh lacks while it has
  // set 0, is an error, as is a transform that takes a UV out of float range.
  std::vector<Vec2> Texcoords(const aiMesh& m, const GltfTextureUse& use, bool fill, size_t meshIndex) const {
    std::vector<Vec2> out;
    const std::string mesh = "mesh '" + std::string(m.mName.C_Str()) + "' (#" + std::to_string(meshIndex) + ")";
    if (use.texCoord < 0 || use.texCoord >= AI_MAX_NUMBER_OF_TEXTURECOORDS)
      Fail(path_, mesh + ": a texture names a UV set that is not one of TEXCOORD_0 to TEXCOORD_" +
                      std::to_string(AI_MAX_NUMBER_OF_TEXTURECOORDS - 1));
    const unsigned set = static_cast<unsigned>(use.texCoord);
    if (!m.mTextureCoords[set]) {
      if (set > 0 && m.mTextureCoords[0])
        Fail(path_, mesh + ": a texture reads UV set TEXCOORD_" + std::to_string(set) +
                        ", which the mesh does not have");
      if (fill) out.assign(m.mNumVertices, Vec2(0.0f));
      return out;
    }
    out.reserve(m.mNumVertices);
    const bool transformed = use.Transformed();
    for (unsigned v = 0; v < m.mNumVertices; ++v) {
      const Vec2 uv(m.mTextureCoords[set][v].x, m.mTextureCoords[set][v].y);
      const Vec2 t = transformed ? use.Apply(uv) : uv;
      if (transformed && !(std::isfinite(t.x) && std::isfinite(t.y)))
        Fail(path_, mesh + ": its KHR_texture_transform takes vertex " + std::to_string(v) + "'s UV out of range");
      out.push_back(t);
    }
    return out;
  }

  // Which file materials `m` may be (Assimp keeps no index into the file's list): those with its name and factors,
  // else, as Assimp names an unnamed material itself, those with its factors.
  std::vector<const GltfMaterialKey*> Candidates(const AssetMaterial& m,
                                                 const std::vector<GltfMaterialKey>& keys) const {
    std::vector<const GltfMaterialKey*> out;
    for (const bool byName : {true, false}) {
      for (const GltfMaterialKey& k : keys)
        if (!((byName && k.name != m.name) || k.baseColor != m.baseColor || k.emissive != m.emission ||
              k.metallic != m.metallic || k.roughness != m.roughness))
          out.push_back(&k);
      if (!out.empty()) break;
    }
    return out;
  }

  // How the material reads its texture of `type` (Assimp's reference `ref`): the file's textureInfo among the
  // candidates; where they disagree, those whose image is `ref`; still disagreeing, an error, since which one Assimp
  // gave this material is unknowable. Without candidates (Assimp's default material), glTF's defaults.
  GltfTextureUse UseOf(const std::vector<const GltfMaterialKey*>& candidates, GltfTextureUse GltfMaterialKey::*field,
                       const std::string& ref, const std::string& materialName) const {
    std::vector<GltfTextureUse> uses;
    for (const GltfMaterialKey* k : candidates)
      if ((k->*field).present) uses.push_back(k->*field);
    auto agree = [](const std::vector<GltfTextureUse>& u) {
      return std::all_of(u.begin(), u.end(), [&](const GltfTextureUse& x) { return x == u.front(); });
    };
    if (!agree(uses)) {
      std::vector<GltfTextureUse> same;
      for (const GltfTextureUse& u : uses)
        if (u.image == ref) same.push_back(u);
      if (same.empty() || !agree(same))
        Fail(path_, "materials like '" + materialName + "' look the same but read their textures differently "
                    "(UV set, KHR_texture_transform or sampler); Assimp does not say which is which (give them "
                    "distinct names)");
      uses = same;
    }
    GltfTextureUse use = uses.empty() ? GltfTextureUse{} : uses.front();
    use.present = true;
    return use;
  }

  // The wrap modes Assimp read for a texture (OBJ's -clamp), as the sampler's.
  static GltfTextureUse AssimpUse(const aiMaterial& mat, aiTextureType type) {
    GltfTextureUse use;
    use.present = true;
    auto wrap = [&](const char* key) {
      int mode = aiTextureMapMode_Wrap;
      if (mat.Get(key, type, 0, mode) != AI_SUCCESS) return TextureWrap::kRepeat;
      return mode == aiTextureMapMode_Clamp    ? TextureWrap::kClampToEdge
             : mode == aiTextureMapMode_Mirror ? TextureWrap::kMirroredRepeat
                                               : TextureWrap::kRepeat;
    };
    use.wrapS = wrap(_AI_MATKEY_MAPPINGMODE_U_BASE);
    use.wrapT = wrap(_AI_MATKEY_MAPPINGMODE_V_BASE);
    return use;
  }

  static std::string TextureRef(const aiMaterial& mat, aiTextureType type) {
    aiString ref;
    return mat.GetTextureCount(type) > 0 && mat.GetTexture(type, 0, &ref) == AI_SUCCESS ? ref.C_Str() : "";
  }

  AssetMaterial ConvertMaterial(const aiMaterial& mat, const std::vector<GltfMaterialKey>& gltfMaterials,
                                bool gltf) {
    AssetMaterial out;
    // The textures (Assimp's references, "" for none) and how they read the UVs, set by either format below.
    std::string baseRef;
    const std::string emissionRef = TextureRef(mat, aiTextureType_EMISSIVE);
    MaterialUvs uvs;
    aiString name;
    if (mat.Get(AI_MATKEY_NAME, name) == AI_SUCCESS) out.name = name.C_Str();
    aiColor4D c4;
    aiColor3D c3;
    float f = 0.0f;
    if (gltf) {
      // glTF 2.0 metallic-roughness: the spec's defaults are base colour 1, metallic 1, roughness 1.
      out.baseColor = Vec3(1.0f);
      out.metallic = 1.0f;
      out.roughness = 1.0f;
      if (mat.Get(AI_MATKEY_BASE_COLOR, c4) == AI_SUCCESS) out.baseColor = Vec3(c4.r, c4.g, c4.b);
      else if (mat.Get(AI_MATKEY_COLOR_DIFFUSE, c4) == AI_SUCCESS) out.baseColor = Vec3(c4.r, c4.g, c4.b);
      if (mat.Get(AI_MATKEY_METALLIC_FACTOR, f) == AI_SUCCESS) out.metallic = f;
      if (mat.Get(AI_MATKEY_ROUGHNESS_FACTOR, f) == AI_SUCCESS) out.roughness = f;
      out.specular = 0.04f;
      if (mat.Get(AI_MATKEY_COLOR_EMISSIVE, c3) == AI_SUCCESS) out.emission = Vec3(c3.r, c3.g, c3.b);
      const std::vector<const GltfMaterialKey*> candidates = Candidates(out, gltfMaterials);
      baseRef = TextureRef(mat, aiTextureType_BASE_COLOR);
      if (baseRef.empty()) baseRef = TextureRef(mat, aiTextureType_DIFFUSE);
      if (!baseRef.empty()) uvs.baseColor = UseOf(candidates, &GltfMaterialKey::baseColorTexture, baseRef, out.name);
      if (!emissionRef.empty())
        uvs.emission = UseOf(candidates, &GltfMaterialKey::emissiveTexture, emissionRef, out.name);
      out.emission *= EmissiveStrength(out, candidates);
    } else {
      // OBJ/MTL and PLY: Kd, Ks, Ns, Ke as the table in docs/sequence-format.md maps them.
      Vec3 kd(0.6f), ks(0.0f);
      if (mat.Get(AI_MATKEY_COLOR_DIFFUSE, c3) == AI_SUCCESS) kd = Vec3(c3.r, c3.g, c3.b);
      if (mat.Get(AI_MATKEY_COLOR_SPECULAR, c3) == AI_SUCCESS) ks = Vec3(c3.r, c3.g, c3.b);
      float ns = 0.0f;
      mat.Get(AI_MATKEY_SHININESS, ns);
      const float kmax = std::max({ks.x, ks.y, ks.z});
      out.specular = std::isfinite(kmax) ? std::clamp(kmax, 0.0f, 1.0f) : 0.0f;
      out.metallic = 0.0f;
      const float diffuseShare = 1.0f - out.specular;
      out.baseColor = diffuseShare > 0.0f ? kd / diffuseShare : Vec3(0.0f);
      // Phong exponent to GGX width, alpha = sqrt(2 / (Ns + 2)) (Walter et al. 2007, Sec. 5.2).
      const float alpha = std::sqrt(2.0f / (std::max(ns, 0.0f) + 2.0f));
      out.roughness = std::sqrt(alpha);
      if (mat.Get(AI_MATKEY_COLOR_EMISSIVE, c3) == AI_SUCCESS) out.emission = Vec3(c3.r, c3.g, c3.b);
      // The first UV set as it is; the wrap modes Assimp read (MTL's -clamp).
      baseRef = TextureRef(mat, aiTextureType_DIFFUSE);
      if (!baseRef.empty()) uvs.baseColor = AssimpUse(mat, aiTextureType_DIFFUSE);
      if (!emissionRef.empty()) uvs.emission = AssimpUse(mat, aiTextureType_EMISSIVE);
    }
    out.baseColorTexture = TextureOf(baseRef, uvs.baseColor);
    out.emissionTexture = TextureOf(emissionRef, uvs.emission);
    materialUvs_.push_back(uvs);
    return out;
  }

  // The strength of the candidate file materials (Candidates); refused when they carry different strengths, since
  // which one Assimp gave this mesh is unknowable.
  float EmissiveStrength(const AssetMaterial& m, const std::vector<const GltfMaterialKey*>& candidates) const {
    if (!(std::max({m.emission.x, m.emission.y, m.emission.z}) > 0.0f) || candidates.empty()) return 1.0f;
    for (const GltfMaterialKey* k : candidates)
      if (k->strength != candidates.front()->strength)
        Fail(path_, "materials like '" + m.name + "' look the same but carry different emissive strengths; "
                    "Assimp does not say which is which (give them distinct names or factors)");
    return candidates.front()->strength;
  }

  // The texture Assimp calls `key` (TextureRef), read once per distinct reference and wrap modes (`use`'s); -1 for
  // none ("").
  int32_t TextureOf(const std::string& key, const GltfTextureUse& use) {
    if (key.empty()) return -1;
    const std::string indexKey =
        key + "|" + std::to_string(int(use.wrapS)) + std::to_string(int(use.wrapT));
    if (auto it = textureIndex_.find(indexKey); it != textureIndex_.end()) return it->second;
    EncodedTexture t;
    t.wrapU = use.wrapS;
    t.wrapV = use.wrapT;
    if (const aiTexture* et = scene_.GetEmbeddedTexture(key.c_str())) {
      t.name = path_ + "#" + key + "." + (et->achFormatHint[0] ? et->achFormatHint : "img");
      if (!et->pcData) Fail(path_, "embedded texture '" + key + "' has no data");
      if (et->mHeight == 0) {
        t.bytes.assign(reinterpret_cast<const char*>(et->pcData), et->mWidth);
      } else {
        if (et->mWidth > 16384 || et->mHeight > 16384) Fail(path_, "embedded texture '" + key + "' is too large");
        t.rawWidth = static_cast<int>(et->mWidth);
        t.rawHeight = static_cast<int>(et->mHeight);
        t.bytes.assign(reinterpret_cast<const char*>(et->pcData), size_t(et->mWidth) * et->mHeight * sizeof(aiTexel));
      }
    } else {
      namespace fs = std::filesystem;
      // Windows separators are common in MTL files ("map_Kd .\\wood.jpg"); a file name never holds a backslash.
      std::string portable = key;
      std::replace(portable.begin(), portable.end(), '\\', '/');
      fs::path file = fs::path(portable);
      if (file.is_relative()) file = fs::path(path_).parent_path() / file;
      // A glTF image's URI is percent-encoded, which Assimp passes on as written.
      if (gltf_) file = ResolveGltfUriFile(file.string());
      t.name = file.lexically_normal().string();
      std::string problem;
      if (!TryReadRegularFile(t.name, kMaxTextureFileBytes, t.bytes, problem))
        Fail(path_, "cannot read texture '" + t.name + "' (" + problem + ")");
    }
    const int32_t index = static_cast<int32_t>(asset_.encodedTextures.size());
    asset_.encodedTextures.push_back(std::move(t));
    textureIndex_.emplace(indexKey, index);
    return index;
  }

  const std::string& path_;
  const aiScene& scene_;
  const AssetLimits& limits_;
  bool gltf_ = false;  // the asset is glTF: its texture references are URIs
  ImportedAsset asset_;
  std::map<std::string, int32_t> textureIndex_;
  // Per material (asset_.materials' order): how its textures read the mesh's UVs.
  struct MaterialUvs {
    GltfTextureUse baseColor;  // present: the material has a base-colour texture
    GltfTextureUse emission;   // present: it has an emission texture
  };
  std::vector<MaterialUvs> materialUvs_;
};

// glTF's URIs are percent-encoded (RFC 3986: a file "Box Textured.bin" is "Box%20Textured.bin"), and Assimp 5.2
// opens them as written: each file but the asset itself is opened as sim/assets/gltf_buffers.h resolves it, so that
// Assimp reads the file the checks read.
class GltfUriIOSystem : public Assimp::DefaultIOSystem {
 public:
  explicit GltfUriIOSystem(std::string asset) : asset_(std::move(asset)) {}
  bool Exists(const char* file) const override { return DefaultIOSystem::Exists(Resolve(file).c_str()); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return DefaultIOSystem::Open(Resolve(file).c_str(), mode);
  }

 private:
  std::string Resolve(const char* file) const { return file == asset_ ? asset_ : ResolveGltfUriFile(file); }
  const std::string asset_;
};

}  // namespace

bool IsSupportedAssetExtension(const std::string& e) {
  const std::string x = Lower(e);
  return x == ".gltf" || x == ".glb" || x == ".obj" || x == ".ply";
}

void DecodeAssetTextures(ImportedAsset& asset) {
  std::vector<EncodedImage> encoded;
  for (const EncodedTexture& e : asset.encodedTextures) {
    if (e.rawWidth <= 0) {
      encoded.push_back(EncodedImage{&e.bytes, e.name});
      continue;
    }
    if (e.rawWidth > 16384 || e.rawHeight <= 0 || e.rawHeight > 16384 ||
        e.bytes.size() != size_t(e.rawWidth) * size_t(e.rawHeight) * 4)
      throw InputError(OneLine(e.name + ": error: the embedded texture's size does not match its texels"));
  }
  std::vector<Texture> decoded = DecodeTextures(encoded);
  asset.textures.clear();
  size_t next = 0;
  for (const EncodedTexture& e : asset.encodedTextures) {
    if (e.rawWidth <= 0) {
      asset.textures.push_back(std::move(decoded[next++]));
      asset.textures.back().wrapU = e.wrapU;
      asset.textures.back().wrapV = e.wrapV;
      continue;
    }
    // Raw BGRA8 texels (their size checked above), sRGB-encoded like every 8-bit colour texture.
    Texture t;
    t.name = e.name;
    t.width = e.rawWidth;
    t.height = e.rawHeight;
    t.wrapU = e.wrapU;
    t.wrapV = e.wrapV;
    t.rgb.resize(size_t(t.width) * t.height * 3);
    for (size_t p = 0; p < size_t(t.width) * t.height; ++p)
      for (int c = 0; c < 3; ++c)  // aiTexel is b, g, r, a
        t.rgb[3 * p + c] = SrgbToLinear(static_cast<unsigned char>(e.bytes[4 * p + 2 - c]) / 255.0f);
    asset.textures.push_back(std::move(t));
  }
  asset.encodedTextures.clear();
}

ImportedAsset ImportAssetInProcess(const std::string& path, const AssetLimits& limits) {
  ImportedAsset asset = ImportAssetGeometry(path, limits);
  DecodeAssetTextures(asset);
  ValidateAsset(asset, path, limits);
  return asset;
}

ImportedAsset ImportAssetGeometry(const std::string& path, const AssetLimits& limits) {
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  if (!IsSupportedAssetExtension(ext))
    Fail(path, "unsupported asset format '" + ext + "' (supported: .gltf, .glb, .obj, .ply)");
  // Refuse what is not a regular file before Assimp opens it (a FIFO would block it); glTF's JSON is read from
  // these bytes too.
  std::string bytes, problem;
  if (!TryReadRegularFile(path, kMaxAssetFileBytes, bytes, problem))
    Fail(path, "cannot read the file (" + problem + ")");
  if (bytes.empty()) Fail(path, "the file is empty");
  const bool gltf = ext == ".gltf" || ext == ".glb";
  std::vector<GltfMaterialKey> gltfMaterials;
  if (gltf) {
    const GltfDocument doc = ReadGltfDocument(bytes, path, ext == ".glb", kMaxAssetFileBytes);
    // Before Assimp allocates them (a thousand primitives instancing a million vertices each exhaust its memory).
    if (GltfTriangles(doc.json) > limits.maxTriangles)
      Fail(path, "the asset holds more than " + std::to_string(limits.maxTriangles) + " triangles");
    gltfMaterials = GltfMaterialKeys(doc.json, path);
  }
  if (!gltf) std::string().swap(bytes);  // only glTF needs them; Assimp reads the file itself
  Assimp::Importer importer;
  if (gltf) importer.SetIOHandler(new GltfUriIOSystem(path));  // the importer owns it
  // SortByPType puts points and lines in meshes of their own, which are skipped.
  const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure;
  const aiScene* scene = importer.ReadFile(path, flags);
  if (!scene) Fail(path, std::string("cannot import the asset (Assimp: ") + importer.GetErrorString() + ")");
  if (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) Fail(path, "the asset is incomplete (Assimp flagged it)");
  // PreTransformVertices then bakes every node's transform into its meshes' vertices (and normals), so the asset
  // arrives in its root space; it keeps the winding of meshes under a mirroring node, which glTF says to reverse
  // first. Assimp's importer owns the scene and lets it be edited between the two calls.
  ReverseMirroredWinding(const_cast<aiScene&>(*scene));
  // PreTransformVertices merges meshes by material, whatever their primitives: SortByPType splits them again.
  scene = importer.ApplyPostProcessing(aiProcess_PreTransformVertices | aiProcess_SortByPType);
  if (!scene) Fail(path, std::string("cannot import the asset (Assimp: ") + importer.GetErrorString() + ")");
  ImportedAsset asset = Converter(path, *scene, limits).Convert(gltfMaterials, gltf);
  if (asset.meshes.empty()) Fail(path, "the asset has no triangles");
  return asset;
}

}  // namespace restir
