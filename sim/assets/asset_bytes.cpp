// ImportedAsset as bytes (the child-to-parent message of sim/assets/asset_isolation.cpp) and its validation. Everything
// read is bounds-checked (sim/util/binary_io.h's reader): a child that died half-way, or a hostile byte string, gives
// InputError, never a crash.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "sim/assets/asset_import.h"
#include "sim/util/binary_io.h"  // BinaryWriter, BinaryReader
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

constexpr uint64_t kMagic = 0x3154455353415352ull;  // "RSASSET1" as little-endian bytes

// A reader sizes the list to the count it read; a writer's asset is const and already has that size.
template <typename V>
void Size(V& v, uint64_t n) {
  if constexpr (!std::is_const_v<V>) v.resize(n);
}

// One field list for both directions (sim/util/binary_io.h's writer and reader share their method names).
template <typename IO, typename Asset>
void Fields(IO& io, Asset& a) {
  io.Pod(a.skippedPrimitives);
  uint64_t n = a.materials.size();
  io.Count(n);
  Size(a.materials, n);
  for (auto& m : a.materials) {
    io.String(m.name);
    io.Pod(m.baseColor);
    io.Pod(m.metallic);
    io.Pod(m.roughness);
    io.Pod(m.specular);
    io.Pod(m.baseColorTexture);
    io.Pod(m.emission);
    io.Pod(m.emissionTexture);
  }
  n = a.textures.size();
  io.Count(n);
  Size(a.textures, n);
  for (auto& t : a.textures) {
    io.String(t.name);
    io.Pod(t.width);
    io.Pod(t.height);
    io.Vector(t.rgb);
    io.Pod(t.wrapU);
    io.Pod(t.wrapV);
  }
  n = a.encodedTextures.size();
  io.Count(n);
  Size(a.encodedTextures, n);
  for (auto& t : a.encodedTextures) {
    io.String(t.name);
    io.String(t.bytes);
    io.Pod(t.rawWidth);
    io.Pod(t.rawHeight);
    io.Pod(t.wrapU);
    io.Pod(t.wrapV);
  }
  n = a.meshes.size();
  io.Count(n);
  Size(a.meshes, n);
  for (auto& m : a.meshes) {
    io.String(m.name);
    io.Pod(m.material);
    io.Vector(m.positions);
    io.Vector(m.normals);
    io.Vector(m.texcoords);
    io.Vector(m.emissionTexcoords);
    io.Vector(m.triangles);
  }
}

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(OneLine(path + ": error: " + what));
}

bool FiniteNonNegative(const Vec3& v) {
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(v[c]) || v[c] < 0.0f) return false;
  return true;
}

}  // namespace

std::string SerializeAsset(const ImportedAsset& a) {
  ByteCounter counter;
  counter.Pod(kMagic);
  Fields(counter, a);
  BinaryWriter w;
  w.Reserve(counter.Bytes());
  w.Pod(kMagic);
  Fields(w, a);
  return w.Bytes();
}

ImportedAsset DeserializeAsset(const std::string& bytes, const std::string& path) {
  ImportedAsset a;
  bool whole = false;
  try {
    BinaryReader r(bytes);
    uint64_t magic = 0;
    r.Pod(magic);
    if (magic == kMagic) {
      Fields(r, a);
      whole = r.AtEnd();
    }
  } catch (const std::runtime_error&) {
    whole = false;
  }
  if (!whole) Fail(path, "the importer's result is incomplete or damaged (" + std::to_string(bytes.size()) + " bytes)");
  return a;
}

void ValidateAsset(const ImportedAsset& a, const std::string& path, const AssetLimits& limits) {
  if (a.materials.empty()) Fail(path, "the asset has no material");
  for (size_t i = 0; i < a.textures.size(); ++i) {
    const Texture& t = a.textures[i];
    if (t.width <= 0 || t.height <= 0 || t.width > 16384 || t.height > 16384 ||
        t.rgb.size() != size_t(t.width) * size_t(t.height) * 3)
      Fail(path, "texture " + std::to_string(i) + " ('" + t.name + "') has an inconsistent size");
    for (float v : t.rgb)
      if (!std::isfinite(v) || v < 0.0f) Fail(path, "texture '" + t.name + "' has a negative or non-finite texel");
  }
  auto wrapOk = [](TextureWrap w) { return w <= TextureWrap::kMirroredRepeat; };
  for (const Texture& t : a.textures)
    if (!wrapOk(t.wrapU) || !wrapOk(t.wrapV)) Fail(path, "texture '" + t.name + "' has an unknown wrap mode");
  for (const EncodedTexture& t : a.encodedTextures)
    if (!wrapOk(t.wrapU) || !wrapOk(t.wrapV)) Fail(path, "texture '" + t.name + "' has an unknown wrap mode");
  const size_t textureCount = std::max(a.textures.size(), a.encodedTextures.size());
  auto textureOk = [&](int32_t k) { return k >= -1 && k < static_cast<int32_t>(textureCount); };
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const AssetMaterial& m = a.materials[i];
    const std::string what = "material '" + m.name + "' (#" + std::to_string(i) + ")";
    if (!FiniteNonNegative(m.baseColor) || !FiniteNonNegative(m.emission) || !std::isfinite(m.metallic) ||
        !std::isfinite(m.roughness) || !std::isfinite(m.specular))
      Fail(path, what + " has a negative or non-finite factor");
    if (!textureOk(m.baseColorTexture) || !textureOk(m.emissionTexture))
      Fail(path, what + " refers to a texture the asset does not have");
  }
  uint64_t triangles = 0;
  for (size_t i = 0; i < a.meshes.size(); ++i) {
    const AssetMesh& m = a.meshes[i];
    const std::string what = "mesh '" + m.name + "' (#" + std::to_string(i) + ")";
    if (m.material >= a.materials.size()) Fail(path, what + " uses a material the asset does not have");
    if ((!m.normals.empty() && m.normals.size() != m.positions.size()) ||
        (!m.texcoords.empty() && m.texcoords.size() != m.positions.size()) ||
        (!m.emissionTexcoords.empty() && m.emissionTexcoords.size() != m.positions.size()))
      Fail(path, what + " has normals or texture coordinates for some vertices only");
    for (size_t v = 0; v < m.positions.size(); ++v) {
      for (int c = 0; c < 3; ++c) {
        const float x = m.positions[v][c];
        if (!std::isfinite(x))
          Fail(path, what + " vertex " + std::to_string(v) + " has a non-finite coordinate");
        if (std::fabs(double(x)) > limits.maxCoordinate)
          Fail(path, what + " vertex " + std::to_string(v) + " has a coordinate beyond the limit of 1e7");
      }
    }
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k)
        if (m.triangles[t][k] >= m.positions.size())
          Fail(path, what + " triangle " + std::to_string(t) + " uses vertex " + std::to_string(m.triangles[t][k]) +
                         " of " + std::to_string(m.positions.size()));
    }
    triangles += m.triangles.size();
  }
  if (triangles > limits.maxTriangles)
    Fail(path, "the asset holds " + std::to_string(triangles) + " triangles, more than the limit of " +
                   std::to_string(limits.maxTriangles));
}

}  // namespace restir
