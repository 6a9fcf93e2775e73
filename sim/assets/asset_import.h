// Third-party assets through Assimp (docs/sequence-format.md "Assets"): glTF 2.0 (.gltf with external or embedded
// buffers, .glb), Wavefront OBJ with its MTL, and PLY. The importer hands back triangle meshes with the node
// hierarchy's transforms applied, one material per mesh, and the textures those materials use, decoded; the
// sequence reader turns them into objects, materials and emissive triangles (sim/scene/sequence_assets.cpp).
//
// Assimp runs in a child process (ImportAsset): a file that crashes or hangs it, or asks for more memory than a
// scene can have, becomes one InputError naming the file, never a crash of the simulator. The child only parses;
// textures come back as the file holds them and are decoded by OpenImageIO, all of an asset's in one child of their
// own (sim/assets/texture.h DecodeTextures), so that a texture that crashes its decoder is one InputError too.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"
#include "sim/assets/texture.h"

namespace restir {

// A material in the metallic-roughness form every supported format maps to (the table in
// docs/sequence-format.md); sim/scene/shading_point.cpp turns it into core/'s layered BSDF.
struct AssetMaterial {
  std::string name;               // the file's name for it (may be empty or repeated)
  Vec3 baseColor{0.8f};           // linear RGB in [0, 1]: glTF baseColorFactor, or MTL Kd / (1 - max Ks)
  float metallic = 0.0f;          // in [0, 1]
  float roughness = 1.0f;         // perceptual roughness in (0, 1]: GGX alpha = roughness^2
  float specular = 0.04f;         // dielectric reflectance at normal incidence in [0, 1]: 0.04 (glTF), max Ks (MTL)
  int32_t baseColorTexture = -1;  // index into ImportedAsset::textures, multiplies baseColor; -1: none
  Vec3 emission{0.0f};            // emitted radiance factor, >= 0: glTF emissiveFactor x emissiveStrength, MTL Ke
  int32_t emissionTexture = -1;   // index into ImportedAsset::textures, multiplies emission; -1: none
};

// A triangle mesh with one material, in the asset's root space (node transforms applied).
struct AssetMesh {
  std::string name;                   // the file's name for it (may be empty or repeated)
  uint32_t material = 0;              // index into ImportedAsset::materials
  std::vector<Vec3> positions;        // finite
  std::vector<Vec3> normals;          // per position, or empty (flat shading)
  std::vector<Vec2> texcoords;        // per position (v up), or empty: the base-colour texture's UV set (glTF
                                      // texCoord; the first elsewhere) with its KHR_texture_transform applied
  std::vector<Vec2> emissionTexcoords;  // the emission texture's, where its set or transform differ; else empty
  std::vector<glm::uvec3> triangles;  // indices into positions, all in range
};

// A texture as the asset holds it, before decoding: an image file's bytes (rawWidth = 0), or raw BGRA8 texels.
struct EncodedTexture {
  std::string name;   // the file it was read from, or "<asset>#<reference>.<format hint>" for an embedded image
  std::string bytes;  // the encoded image, or rawWidth x rawHeight x 4 bytes
  int rawWidth = 0;   // > 0: raw texels
  int rawHeight = 0;
  TextureWrap wrapU = TextureWrap::kRepeat;  // the sampler's, carried to the decoded Texture
  TextureWrap wrapV = TextureWrap::kRepeat;
};

struct ImportedAsset {
  std::vector<AssetMesh> meshes;
  std::vector<AssetMaterial> materials;
  std::vector<Texture> textures;                // decoded (DecodeAssetTextures), indexed by the materials
  std::vector<EncodedTexture> encodedTextures;  // the same, before decoding; empty once decoded
  uint64_t skippedPrimitives = 0;  // points and lines, which have no area to render (counted, not an error)
};

// What ImportAsset refuses to go beyond (a hostile file must not take the machine).
struct AssetLimits {
  uint64_t maxTriangles = uint64_t(1) << 22;  // over all meshes
  double maxCoordinate = 1e7;                 // |x|, |y|, |z| of every position (kMaxSequenceNumber)
  double timeoutSeconds = 60.0;               // wall time of Assimp's parse (Assimp 5.2's PLY reader can spin forever)
  uint64_t maxMemoryBytes = uint64_t(12) << 30;  // the importer process's address space (not under sanitizers)
};

// The formats by extension (lower-case, with the dot): ".gltf", ".glb", ".obj", ".ply".
bool IsSupportedAssetExtension(const std::string& extension);

// Imports `path` in a child process and validates the result (finite coordinates within limits, indices in range,
// materials and textures consistent). Throws InputError "<path>: error: <what>" on any problem, including the
// importer crashing, hanging or running out of memory.
ImportedAsset ImportAsset(const std::string& path, const AssetLimits& limits = {});

// The same work in this process, without the isolation (tests, benchmarks).
ImportedAsset ImportAssetInProcess(const std::string& path, const AssetLimits& limits = {});

// The child's half: Assimp's parse and the conversion, textures left encoded. Throws InputError.
ImportedAsset ImportAssetGeometry(const std::string& path, const AssetLimits& limits);

// Decodes encodedTextures into textures (sim/assets/texture.h DecodeTextures); throws InputError naming the texture.
void DecodeAssetTextures(ImportedAsset& asset);

// The bytes the child sends the parent, and back; DeserializeAsset throws InputError naming `path` on any
// inconsistency, so a child that dies half-way is caught (sim/assets/asset_bytes.cpp; fuzzed by
// tests/fuzz/asset_fuzz.cpp).
std::string SerializeAsset(const ImportedAsset& asset);
ImportedAsset DeserializeAsset(const std::string& bytes, const std::string& path);

// Throws InputError naming `path` unless every index, coordinate, texture reference and texel is valid.
void ValidateAsset(const ImportedAsset& asset, const std::string& path, const AssetLimits& limits);

}  // namespace restir
