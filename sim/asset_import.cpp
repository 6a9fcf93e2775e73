// The Assimp half of sim/asset_import.h: one aiScene → ImportedAsset, in whichever process calls it.
#include "sim/asset_import.h"

#include <assimp/GltfMaterial.h>
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
#include <map>
#include <set>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>

#include "sim/input_file.h"
#include "sim/sequence.h"  // InputError
#include "sim/text.h"

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

// KHR_materials_emissive_strength, which Assimp 5.2 does not read. Assimp numbers glTF materials in the order its
// reader first meets them, not the file's, so each file material is kept with what identifies it (its name and
// factors), and an Assimp material takes the strength of the file materials that look exactly like it.
struct GltfMaterialKey {
  std::string name;
  Vec3 baseColor{1.0f};  // baseColorFactor rgb
  Vec3 emissive{0.0f};   // emissiveFactor
  float metallic = 1.0f;
  float roughness = 1.0f;
  float strength = 1.0f;  // emissiveStrength, 1 where absent
};

// `bytes` is the file at `path` (read once by the caller, which Assimp then reads again itself).
std::vector<GltfMaterialKey> GltfMaterialKeys(const std::string& bytes, const std::string& path, bool binary) {
  std::string_view json = bytes;
  if (binary) {
    // GLB header: magic, version, length; then chunk 0: length, type "JSON", data (glTF 2.0 spec, "GLB File Format").
    auto u32 = [&](size_t at) {
      uint32_t v = 0;
      std::memcpy(&v, bytes.data() + at, 4);
      return v;
    };
    if (bytes.size() < 20 || bytes.compare(0, 4, "glTF") != 0) Fail(path, "not a binary glTF file (no 'glTF' header)");
    const uint32_t chunk = u32(12);
    if (u32(16) != 0x4E4F534Au || chunk > bytes.size() - 20) Fail(path, "the binary glTF's first chunk is not its JSON");
    json = std::string_view(bytes).substr(20, chunk);
  }
  using Json = nlohmann::json;
  std::vector<GltfMaterialKey> keys;
  const Json doc = Json::parse(json.begin(), json.end(), nullptr, false);
  if (!doc.is_object()) return keys;  // Assimp will say what is wrong with it
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
    if (node->mNumMeshes > 0) placed.emplace_back(node, det < 0.0);
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
      if (m.mTextureCoords[0]) {
        for (unsigned v = 0; v < m.mNumVertices; ++v)
          out.texcoords.emplace_back(m.mTextureCoords[0][v].x, m.mTextureCoords[0][v].y);
      }
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
  AssetMaterial ConvertMaterial(const aiMaterial& mat, const std::vector<GltfMaterialKey>& gltfMaterials,
                                bool gltf) {
    AssetMaterial out;
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
      out.baseColorTexture = TextureOf(mat, aiTextureType_BASE_COLOR);
      if (out.baseColorTexture < 0) out.baseColorTexture = TextureOf(mat, aiTextureType_DIFFUSE);
      if (mat.Get(AI_MATKEY_COLOR_EMISSIVE, c3) == AI_SUCCESS) out.emission = Vec3(c3.r, c3.g, c3.b);
      out.emission *= EmissiveStrength(out, gltfMaterials);
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
      out.baseColorTexture = TextureOf(mat, aiTextureType_DIFFUSE);
      if (mat.Get(AI_MATKEY_COLOR_EMISSIVE, c3) == AI_SUCCESS) out.emission = Vec3(c3.r, c3.g, c3.b);
    }
    out.emissionTexture = TextureOf(mat, aiTextureType_EMISSIVE);
    return out;
  }

  // The strength of the file materials that match `m` exactly (name and factors as Assimp read them); refused when
  // materials that look the same carry different strengths, since which one Assimp gave this mesh is unknowable.
  float EmissiveStrength(const AssetMaterial& m, const std::vector<GltfMaterialKey>& keys) const {
    if (!(std::max({m.emission.x, m.emission.y, m.emission.z}) > 0.0f)) return 1.0f;
    // By name and factors first; Assimp names an unnamed material itself, so then by factors alone.
    for (const bool byName : {true, false}) {
      float strength = 1.0f;
      bool found = false;
      for (const GltfMaterialKey& k : keys) {
        if ((byName && k.name != m.name) || k.baseColor != m.baseColor || k.emissive != m.emission ||
            k.metallic != m.metallic || k.roughness != m.roughness)
          continue;
        if (found && k.strength != strength)
          Fail(path_, "materials like '" + m.name + "' look the same but carry different emissive strengths; "
                      "Assimp does not say which is which (give them distinct names or factors)");
        strength = k.strength;
        found = true;
      }
      if (found) return strength;
    }
    return 1.0f;
  }

  // The material's first texture of `type`, read once per distinct reference; -1 when it has none.
  int32_t TextureOf(const aiMaterial& mat, aiTextureType type) {
    if (mat.GetTextureCount(type) == 0) return -1;
    aiString ref;
    if (mat.GetTexture(type, 0, &ref) != AI_SUCCESS) return -1;
    const std::string key = ref.C_Str();
    if (auto it = textureIndex_.find(key); it != textureIndex_.end()) return it->second;
    EncodedTexture t;
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
      t.name = file.lexically_normal().string();
      std::string problem;
      if (!TryReadRegularFile(t.name, kMaxTextureFileBytes, t.bytes, problem))
        Fail(path_, "cannot read texture '" + t.name + "' (" + problem + ")");
    }
    const int32_t index = static_cast<int32_t>(asset_.encodedTextures.size());
    asset_.encodedTextures.push_back(std::move(t));
    textureIndex_.emplace(key, index);
    return index;
  }

  const std::string& path_;
  const aiScene& scene_;
  const AssetLimits& limits_;
  ImportedAsset asset_;
  std::map<std::string, int32_t> textureIndex_;
};

}  // namespace

bool IsSupportedAssetExtension(const std::string& e) {
  const std::string x = Lower(e);
  return x == ".gltf" || x == ".glb" || x == ".obj" || x == ".ply";
}

void DecodeAssetTextures(ImportedAsset& asset) {
  asset.textures.clear();
  for (const EncodedTexture& e : asset.encodedTextures) {
    if (e.rawWidth <= 0) {
      asset.textures.push_back(DecodeTexture(e.bytes, e.name));
      continue;
    }
    // Raw BGRA8 texels, sRGB-encoded like every 8-bit colour texture.
    if (e.rawWidth > 16384 || e.rawHeight <= 0 || e.rawHeight > 16384 ||
        e.bytes.size() != size_t(e.rawWidth) * size_t(e.rawHeight) * 4)
      throw InputError(OneLine(e.name + ": error: the embedded texture's size does not match its texels"));
    Texture t;
    t.name = e.name;
    t.width = e.rawWidth;
    t.height = e.rawHeight;
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
  if (!TryReadRegularFile(path, kMaxAssetFileBytes, bytes, problem)) Fail(path, "cannot read the file (" + problem + ")");
  if (bytes.empty()) Fail(path, "the file is empty");
  const bool gltf = ext == ".gltf" || ext == ".glb";
  const std::vector<GltfMaterialKey> gltfMaterials =
      gltf ? GltfMaterialKeys(bytes, path, ext == ".glb") : std::vector<GltfMaterialKey>{};
  if (!gltf) std::string().swap(bytes);  // only glTF needs them; Assimp reads the file itself
  Assimp::Importer importer;
  // SortByPType puts points and lines in meshes of their own, which are skipped.
  const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure;
  const aiScene* scene = importer.ReadFile(path, flags);
  if (!scene) Fail(path, std::string("cannot import the asset (Assimp: ") + importer.GetErrorString() + ")");
  if (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) Fail(path, "the asset is incomplete (Assimp flagged it)");
  // PreTransformVertices then bakes every node's transform into its meshes' vertices (and normals), so the asset
  // arrives in its root space; it keeps the winding of meshes under a mirroring node, which glTF says to reverse
  // first. Assimp's importer owns the scene and lets it be edited between the two calls.
  ReverseMirroredWinding(const_cast<aiScene&>(*scene));
  scene = importer.ApplyPostProcessing(aiProcess_PreTransformVertices);
  if (!scene) Fail(path, std::string("cannot import the asset (Assimp: ") + importer.GetErrorString() + ")");
  ImportedAsset asset = Converter(path, *scene, limits).Convert(gltfMaterials, gltf);
  if (asset.meshes.empty()) Fail(path, "the asset has no triangles");
  return asset;
}

}  // namespace restir
