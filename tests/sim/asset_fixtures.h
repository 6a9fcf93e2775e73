// Small glTF 2.0 files written by the tests: triangles in one base64 data: URI buffer, one node per mesh (in
// the order given), materials with an emissive factor and optionally KHR_materials_emissive_strength.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/math.h"

namespace restir::test {

// Debian's assimp-testmodels, the third-party assets the importer's tests read.
inline const std::string kModels = "/usr/share/assimp/models/";

// Fails (never skips) when a model (a file) or a folder of models of assimp-testmodels is not there.
inline ::testing::AssertionResult HaveModel(const std::string& path) {
  if (std::filesystem::exists(path)) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << path << " is missing: the asset tests need Debian's assimp-testmodels "
         << "package (apt-get install assimp-testmodels; scripts/setup.sh installs it)";
}

inline std::string ReadBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  EXPECT_TRUE(f.good()) << "cannot open " << path;
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

inline void WriteBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

inline std::string EncodeBase64(const std::string& bytes) {
  static const char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v =
        uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out.push_back(kDigits[(v >> s) & 63]);
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | (two ? uint32_t(uint8_t(bytes[i + 1])) << 8 : 0u);
    out.push_back(kDigits[(v >> 18) & 63]);
    out.push_back(kDigits[(v >> 12) & 63]);
    out.push_back(two ? kDigits[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

struct TestGltfMaterial {
  std::string name;
  Vec3 baseColor{1.0f};
  Vec3 emissive{0.0f};     // emissiveFactor
  float strength = -1.0f;  // KHR_materials_emissive_strength's emissiveStrength; < 0: no extension
};

struct TestGltfMesh {
  std::string name;
  int material = 0;           // index into the materials
  std::vector<Vec3> corners;  // 3 per triangle (no index buffer)
};

// The .gltf text: one scene whose root nodes are the meshes, in order.
inline std::string MakeGltf(const std::vector<TestGltfMaterial>& materials,
                            const std::vector<TestGltfMesh>& meshes) {
  using Json = nlohmann::json;
  std::string buffer;
  Json doc = {{"asset", {{"version", "2.0"}}}, {"scene", 0}};
  Json nodes = Json::array(), jmeshes = Json::array(), views = Json::array(), accessors = Json::array();
  for (size_t i = 0; i < meshes.size(); ++i) {
    const TestGltfMesh& m = meshes[i];
    Vec3 lo(1e30f), hi(-1e30f);
    const size_t offset = buffer.size();
    for (const Vec3& p : m.corners) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
      buffer.append(reinterpret_cast<const char*>(&p.x), 12);
    }
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", 12 * m.corners.size()}});
    accessors.push_back({{"bufferView", i},
                         {"componentType", 5126},
                         {"count", m.corners.size()},
                         {"type", "VEC3"},
                         {"min", {lo.x, lo.y, lo.z}},
                         {"max", {hi.x, hi.y, hi.z}}});
    jmeshes.push_back(
        {{"name", m.name}, {"primitives", {{{"attributes", {{"POSITION", i}}}, {"material", m.material}}}}});
    nodes.push_back({{"mesh", i}});
  }
  Json roots = Json::array();
  for (size_t i = 0; i < meshes.size(); ++i) roots.push_back(i);
  Json jmaterials = Json::array();
  bool strength = false;
  for (const TestGltfMaterial& m : materials) {
    Json jm = {
        {"name", m.name},
        {"pbrMetallicRoughness", {{"baseColorFactor", {m.baseColor.x, m.baseColor.y, m.baseColor.z, 1.0}}}},
        {"emissiveFactor", {m.emissive.x, m.emissive.y, m.emissive.z}}};
    if (m.strength >= 0.0f) {
      jm["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", m.strength}}}};
      strength = true;
    }
    jmaterials.push_back(jm);
  }
  doc["scenes"] = {{{"nodes", roots}}};
  doc["nodes"] = nodes;
  doc["meshes"] = jmeshes;
  doc["materials"] = jmaterials;
  if (strength) doc["extensionsUsed"] = {"KHR_materials_emissive_strength"};
  doc["buffers"] = {{{"byteLength", buffer.size()},
                     {"uri", "data:application/octet-stream;base64," + EncodeBase64(buffer)}}};
  doc["bufferViews"] = views;
  doc["accessors"] = accessors;
  return doc.dump(1);
}

}  // namespace restir::test
