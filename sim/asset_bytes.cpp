// ImportedAsset as bytes (the child-to-parent message of sim/asset_isolation.cpp) and its validation. Everything
// read is bounds-checked: a child that died half-way, or a hostile byte string, gives InputError, never a crash.
#include <cmath>
#include <cstring>
#include <type_traits>

#include "sim/asset_import.h"
#include "sim/sequence.h"  // InputError
#include "sim/text.h"

namespace restir {

namespace {

constexpr char kMagic[8] = {'R', 'S', 'A', 'S', 'S', 'E', 'T', '1'};

class Writer {
 public:
  template <typename T>
  void Pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void String(const std::string& s) {
    Pod<uint64_t>(s.size());
    out += s;
  }
  template <typename T>
  void Vector(const std::vector<T>& v) {
    Pod<uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string out;
};

class Reader {
 public:
  Reader(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path) {}
  template <typename T>
  T Pod() {
    T v;
    Need(sizeof(T));
    std::memcpy(&v, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  std::string String() {
    const uint64_t n = Pod<uint64_t>();
    Need(n);
    std::string s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  template <typename T>
  std::vector<T> Vector() {
    const uint64_t n = Pod<uint64_t>();
    if (n > (bytes_.size() - at_) / sizeof(T)) Broken();
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(T));
    at_ += n * sizeof(T);
    return v;
  }
  bool AtEnd() const { return at_ == bytes_.size(); }
  [[noreturn]] void Broken() const {
    throw InputError(OneLine(path_ + ": error: the importer's result is incomplete or damaged (byte " +
                             std::to_string(at_) + " of " + std::to_string(bytes_.size()) + ")"));
  }

 private:
  void Need(uint64_t n) const {
    if (n > bytes_.size() - at_) Broken();
  }
  const std::string& bytes_;
  const std::string& path_;
  size_t at_ = 0;
};

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
  Writer w;
  w.out.append(kMagic, sizeof(kMagic));
  w.Pod<uint64_t>(a.skippedPrimitives);
  w.Pod<uint64_t>(a.materials.size());
  for (const AssetMaterial& m : a.materials) {
    w.String(m.name);
    w.Pod(m.baseColor);
    w.Pod(m.metallic);
    w.Pod(m.roughness);
    w.Pod(m.specular);
    w.Pod(m.baseColorTexture);
    w.Pod(m.emission);
    w.Pod(m.emissionTexture);
  }
  w.Pod<uint64_t>(a.textures.size());
  for (const Texture& t : a.textures) {
    w.String(t.name);
    w.Pod(t.width);
    w.Pod(t.height);
    w.Vector(t.rgb);
  }
  w.Pod<uint64_t>(a.meshes.size());
  for (const AssetMesh& m : a.meshes) {
    w.String(m.name);
    w.Pod(m.material);
    w.Vector(m.positions);
    w.Vector(m.normals);
    w.Vector(m.texcoords);
    w.Vector(m.triangles);
  }
  return std::move(w.out);
}

ImportedAsset DeserializeAsset(const std::string& bytes, const std::string& path) {
  Reader r(bytes, path);
  for (char c : kMagic)
    if (r.Pod<char>() != c) r.Broken();
  ImportedAsset a;
  a.skippedPrimitives = r.Pod<uint64_t>();
  // Every element takes at least one byte, so counts beyond the message's size are damage, not allocations.
  auto count = [&]() {
    const uint64_t n = r.Pod<uint64_t>();
    if (n > bytes.size()) r.Broken();
    return static_cast<size_t>(n);
  };
  const size_t materials = count();
  for (size_t i = 0; i < materials; ++i) {
    AssetMaterial m;
    m.name = r.String();
    m.baseColor = r.Pod<Vec3>();
    m.metallic = r.Pod<float>();
    m.roughness = r.Pod<float>();
    m.specular = r.Pod<float>();
    m.baseColorTexture = r.Pod<int32_t>();
    m.emission = r.Pod<Vec3>();
    m.emissionTexture = r.Pod<int32_t>();
    a.materials.push_back(std::move(m));
  }
  const size_t textures = count();
  for (size_t i = 0; i < textures; ++i) {
    Texture t;
    t.name = r.String();
    t.width = r.Pod<int>();
    t.height = r.Pod<int>();
    t.rgb = r.Vector<float>();
    a.textures.push_back(std::move(t));
  }
  const size_t meshes = count();
  for (size_t i = 0; i < meshes; ++i) {
    AssetMesh m;
    m.name = r.String();
    m.material = r.Pod<uint32_t>();
    m.positions = r.Vector<Vec3>();
    m.normals = r.Vector<Vec3>();
    m.texcoords = r.Vector<Vec2>();
    m.triangles = r.Vector<glm::uvec3>();
    a.meshes.push_back(std::move(m));
  }
  if (!r.AtEnd()) r.Broken();
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
  auto textureOk = [&](int32_t k) { return k >= -1 && k < static_cast<int32_t>(a.textures.size()); };
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
        (!m.texcoords.empty() && m.texcoords.size() != m.positions.size()))
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
