// Third-party assets (Debian's assimp-testmodels) through sim/assets/asset_import.h, checked against what the files
// say, read here independently of the importer: the glTF JSON (accessor counts and min/max, the default
// scene's node tree with its matrices or TRS, material factors, the vertex data in the buffers), OBJ
// 'v'/'f'/'usemtl' lines and the MTL's Kd/Ks/Ns/map_Kd, a PLY's header and body, and the texture images
// through OpenImageIO. Also: the forked import (ImportAsset) equals the in-process one to the byte, and
// SerializeAsset/DeserializeAsset round-trip. A missing model is a failure that names the package, never a
// skip.
#include "sim/assets/asset_import.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/sim/asset_fixtures.h"
#include "sim/scene/sequence.h"  // InputError

namespace restir {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

using test::HaveModel;
using test::kModels;
using test::ReadBytes;

// RFC 4648 base64, as glTF data: URIs carry their buffers and images.
std::string DecodeBase64(const std::string& text) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::string out;
  uint32_t bits = 0;
  int count = 0;
  for (char c : text) {
    const int v = value(c);
    if (v < 0) continue;  // padding, line breaks
    bits = (bits << 6) | uint32_t(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out.push_back(char((bits >> count) & 0xFF));
    }
  }
  return out;
}

// An axis-aligned box in double precision.
struct Box {
  glm::dvec3 lo{std::numeric_limits<double>::infinity()};
  glm::dvec3 hi{-std::numeric_limits<double>::infinity()};
  void Add(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  bool Empty() const { return !(lo.x <= hi.x); }
  // The tolerance "1e-4 relative" is taken against the box's largest extent or coordinate.
  double Scale() const {
    return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, std::fabs(lo.x), std::fabs(lo.y), std::fabs(lo.z),
                     std::fabs(hi.x), std::fabs(hi.y), std::fabs(hi.z)});
  }
};

std::ostream& operator<<(std::ostream& os, const Box& b) {
  return os << "[" << b.lo.x << ", " << b.lo.y << ", " << b.lo.z << "] .. [" << b.hi.x << ", " << b.hi.y
            << ", " << b.hi.z << "]";
}

Box ImportedBounds(const ImportedAsset& a) {
  Box b;
  for (const AssetMesh& m : a.meshes)
    for (const Vec3& p : m.positions) b.Add(glm::dvec3(p));
  return b;
}

uint64_t ImportedTriangles(const ImportedAsset& a) {
  uint64_t n = 0;
  for (const AssetMesh& m : a.meshes) n += m.triangles.size();
  return n;
}

// `inner` lies inside `outer`, both ends within 1e-4 of outer's scale.
void ExpectInside(const Box& inner, const Box& outer, const std::string& what) {
  const double tol = 1e-4 * outer.Scale();
  for (int c = 0; c < 3; ++c) {
    EXPECT_GE(inner.lo[c], outer.lo[c] - tol)
        << what << " axis " << c << ": " << inner << " not inside " << outer;
    EXPECT_LE(inner.hi[c], outer.hi[c] + tol)
        << what << " axis " << c << ": " << inner << " not inside " << outer;
  }
}

void ExpectSameBox(const Box& got, const Box& want, const std::string& what) {
  const double tol = 1e-4 * want.Scale();
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got.lo[c], want.lo[c], tol) << what << " axis " << c << ": got " << got << " want " << want;
    EXPECT_NEAR(got.hi[c], want.hi[c], tol) << what << " axis " << c << ": got " << got << " want " << want;
  }
}

// -----------------------------------------------------------------------------------------------------------
// Images, read with OpenImageIO directly; colour channels decoded from sRGB by the IEC 61966-2-1 formula.

struct Image {
  int width = 0;
  int height = 0;
  std::vector<double> rgb;  // linear, row 0 at the top
};

// `hint` is a file name whose extension tells OpenImageIO the format (for bytes that came from memory).
Image ReadImage(const std::string& bytes, const std::string& hint) {
  Image img;
  OIIO::Filesystem::IOMemReader mem(const_cast<char*>(bytes.data()), bytes.size());
  auto in = OIIO::ImageInput::open(hint, nullptr, &mem);
  EXPECT_TRUE(in) << hint << ": OpenImageIO cannot open it: " << OIIO::geterror();
  if (!in) return img;
  const OIIO::ImageSpec spec = in->spec();
  std::vector<uint8_t> pixels(size_t(spec.width) * spec.height * spec.nchannels);
  EXPECT_TRUE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, pixels.data())) << hint;
  EXPECT_EQ(spec.format.basetype, OIIO::TypeDesc::UINT8) << hint << ": the expected values assume 8-bit sRGB";
  img.width = spec.width;
  img.height = spec.height;
  auto decode = [](uint8_t v) {
    const double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
  };
  for (size_t p = 0; p < size_t(spec.width) * spec.height; ++p) {
    const uint8_t* px = &pixels[p * spec.nchannels];
    for (int c = 0; c < 3; ++c) img.rgb.push_back(decode(px[spec.nchannels >= 3 ? c : 0]));
  }
  return img;
}

// The imported texture is the image: same size, every texel its sRGB-decoded value.
void ExpectTextureIsImage(const Texture& t, const Image& img, const std::string& what) {
  EXPECT_EQ(t.width, img.width) << what;
  EXPECT_EQ(t.height, img.height) << what;
  ASSERT_EQ(t.rgb.size(), img.rgb.size()) << what;
  size_t bad = 0, first = 0;
  for (size_t i = 0; i < t.rgb.size(); ++i) {
    if (std::fabs(double(t.rgb[i]) - img.rgb[i]) > 1e-5) {
      if (bad++ == 0) first = i;
    }
  }
  EXPECT_EQ(bad, 0u) << what << ": first differing value " << first << ": " << t.rgb[first] << " vs "
                     << img.rgb[first];
}

// -----------------------------------------------------------------------------------------------------------
// glTF 2.0, read from the JSON and buffers (glTF 2.0 specification, sections 3.6-3.9 and "GLB File Format").

struct GltfMaterialFacts {
  std::string name;
  glm::dvec3 baseColor{1.0};  // baseColorFactor (default 1)
  double metallic = 1.0;      // metallicFactor (default 1)
  double roughness = 1.0;     // roughnessFactor (default 1)
  glm::dvec3 emission{0.0};   // emissiveFactor x KHR_materials_emissive_strength (defaults 0 and 1)
  bool hasBaseColorTexture = false;
  std::string imageBytes;  // the base colour texture's image file
  std::string imageHint;   // a name with its format's extension
};

struct GltfFacts {
  uint64_t triangles = 0;  // mode-4 primitives' index (or vertex) counts / 3, once per instancing node
  uint64_t otherPrimitives = 0;
  Box corners;              // the POSITION accessors' min/max boxes, 8 corners each through the world matrix
  Box vertices;             // every POSITION vertex through its instance's world matrix
  bool axisAligned = true;  // every instancing world matrix maps axes to axes
  std::vector<GltfMaterialFacts> materials;
  std::vector<uint64_t> trianglesPerMaterial;  // by glTF material; the last entry: primitives without one
};

class GltfFile {
 public:
  explicit GltfFile(const std::string& path) : dir_(fs::path(path).parent_path()) {
    const std::string bytes = ReadBytes(path);
    if (fs::path(path).extension() == ".glb") {
      auto u32 = [&](size_t at) {
        uint32_t v = 0;
        std::memcpy(&v, bytes.data() + at, 4);
        return v;
      };
      EXPECT_GE(bytes.size(), 20u);
      EXPECT_EQ(bytes.substr(0, 4), "glTF");
      const uint32_t jsonLength = u32(12);
      EXPECT_EQ(u32(16), 0x4E4F534Au);  // "JSON"
      doc_ = Json::parse(bytes.substr(20, jsonLength));
      const size_t bin = 20 + jsonLength;  // chunk 1: length, "BIN\0", data
      if (bin + 8 <= bytes.size()) {
        EXPECT_EQ(u32(bin + 4), 0x004E4942u);
        binChunk_ = bytes.substr(bin + 8, u32(bin));
      }
    } else {
      doc_ = Json::parse(bytes);
    }
  }

  const Json& Doc() const { return doc_; }

  // The bytes of a URI: a data: URI's payload, or a file beside the glTF.
  std::string Uri(const std::string& uri) const {
    if (uri.rfind("data:", 0) == 0) return DecodeBase64(uri.substr(uri.find(',') + 1));
    return ReadBytes((dir_ / uri).string());
  }

  const std::string& Buffer(size_t i) {
    auto it = buffers_.find(i);
    if (it != buffers_.end()) return it->second;
    const Json& b = doc_.at("buffers").at(i);
    std::string bytes = b.contains("uri") ? Uri(b.at("uri").get<std::string>()) : binChunk_;
    return buffers_.emplace(i, std::move(bytes)).first->second;
  }

  std::string BufferView(size_t v) {
    const Json& view = doc_.at("bufferViews").at(v);
    const std::string& buffer = Buffer(view.at("buffer").get<size_t>());
    return buffer.substr(view.value("byteOffset", size_t(0)), view.at("byteLength").get<size_t>());
  }

  // A float VEC3 accessor's elements.
  std::vector<glm::dvec3> Vec3Accessor(size_t a) {
    const Json& acc = doc_.at("accessors").at(a);
    EXPECT_EQ(acc.at("componentType").get<int>(), 5126) << "accessor " << a << " is not float";
    EXPECT_EQ(acc.at("type").get<std::string>(), "VEC3");
    EXPECT_FALSE(acc.contains("sparse")) << "sparse accessors are beyond this test's reader";
    const Json& view = doc_.at("bufferViews").at(acc.at("bufferView").get<size_t>());
    const std::string& buffer = Buffer(view.at("buffer").get<size_t>());
    const size_t stride = view.value("byteStride", size_t(12));
    const size_t start = view.value("byteOffset", size_t(0)) + acc.value("byteOffset", size_t(0));
    const size_t count = acc.at("count").get<size_t>();
    std::vector<glm::dvec3> out;
    EXPECT_LE(start + (count ? (count - 1) * stride + 12 : 0), buffer.size()) << "accessor " << a;
    for (size_t i = 0; i < count && start + i * stride + 12 <= buffer.size(); ++i) {
      float xyz[3];
      std::memcpy(xyz, buffer.data() + start + i * stride, 12);
      out.emplace_back(xyz[0], xyz[1], xyz[2]);
    }
    return out;
  }

 private:
  fs::path dir_;
  Json doc_;
  std::string binChunk_;
  std::map<size_t, std::string> buffers_;
};

// A node's local matrix: "matrix" (column-major), or T * R * S from translation, rotation (x, y, z, w),
// scale.
glm::dmat4 LocalMatrix(const Json& node) {
  glm::dmat4 m(1.0);
  if (node.contains("matrix")) {
    const std::vector<double> v = node.at("matrix").get<std::vector<double>>();
    EXPECT_EQ(v.size(), 16u);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m[c][r] = v[size_t(4 * c + r)];
    return m;
  }
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (node.contains("translation")) {
    const std::vector<double> v = node.at("translation").get<std::vector<double>>();
    t[3] = glm::dvec4(v[0], v[1], v[2], 1.0);
  }
  if (node.contains("rotation")) {
    const std::vector<double> q = node.at("rotation").get<std::vector<double>>();
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    // Row-major entries of the unit quaternion's rotation, stored column-major (r[column][row]).
    r[0][0] = 1 - 2 * (y * y + z * z), r[1][0] = 2 * (x * y - z * w), r[2][0] = 2 * (x * z + y * w);
    r[0][1] = 2 * (x * y + z * w), r[1][1] = 1 - 2 * (x * x + z * z), r[2][1] = 2 * (y * z - x * w);
    r[0][2] = 2 * (x * z - y * w), r[1][2] = 2 * (y * z + x * w), r[2][2] = 1 - 2 * (x * x + y * y);
  }
  if (node.contains("scale")) {
    const std::vector<double> v = node.at("scale").get<std::vector<double>>();
    s[0][0] = v[0], s[1][1] = v[1], s[2][2] = v[2];
  }
  return t * r * s;
}

// Each column of the linear part has one entry that is not (relatively) zero.
bool MapsAxesToAxes(const glm::dmat4& m) {
  for (int c = 0; c < 3; ++c) {
    const double big = std::max({std::fabs(m[c][0]), std::fabs(m[c][1]), std::fabs(m[c][2])});
    int nonzero = 0;
    for (int r = 0; r < 3; ++r) nonzero += std::fabs(m[c][r]) > 1e-7 * big;
    if (nonzero != 1) return false;
  }
  return true;
}

GltfFacts ReadGltfFacts(const std::string& path) {
  GltfFile file(path);
  const Json& doc = file.Doc();
  GltfFacts facts;

  // Materials: the metallic-roughness factors and the base colour texture's image.
  for (const Json& m : doc.value("materials", Json::array())) {
    GltfMaterialFacts f;
    f.name = m.value("name", "");
    const Json pbr = m.value("pbrMetallicRoughness", Json::object());
    if (pbr.contains("baseColorFactor")) {
      const std::vector<double> c = pbr.at("baseColorFactor").get<std::vector<double>>();
      f.baseColor = glm::dvec3(c[0], c[1], c[2]);
    }
    f.metallic = pbr.value("metallicFactor", 1.0);
    f.roughness = pbr.value("roughnessFactor", 1.0);
    if (m.contains("emissiveFactor")) {
      const std::vector<double> e = m.at("emissiveFactor").get<std::vector<double>>();
      f.emission = glm::dvec3(e[0], e[1], e[2]);
    }
    if (m.contains("extensions") && m["extensions"].contains("KHR_materials_emissive_strength"))
      f.emission *= m["extensions"]["KHR_materials_emissive_strength"].value("emissiveStrength", 1.0);
    if (pbr.contains("baseColorTexture")) {
      f.hasBaseColorTexture = true;
      const Json& tex = doc.at("textures").at(pbr["baseColorTexture"].at("index").get<size_t>());
      const Json& image = doc.at("images").at(tex.at("source").get<size_t>());
      std::string mime = image.value("mimeType", "");
      if (image.contains("uri")) {
        const std::string uri = image.at("uri").get<std::string>();
        f.imageBytes = file.Uri(uri);
        if (uri.rfind("data:", 0) == 0)
          mime = uri.substr(5, uri.find(';') - 5);
        else
          f.imageHint = uri;
      } else {
        f.imageBytes = file.BufferView(image.at("bufferView").get<size_t>());
      }
      if (f.imageHint.empty()) f.imageHint = mime == "image/jpeg" ? "image.jpg" : "image.png";
    }
    facts.materials.push_back(std::move(f));
  }
  facts.trianglesPerMaterial.assign(facts.materials.size() + 1, 0);

  // The default scene's node tree, world = parent world x local.
  auto walk = [&](auto&& self, size_t n, const glm::dmat4& parent, int depth) -> void {
    ASSERT_LT(depth, 64) << "node hierarchy too deep or cyclic";
    const Json& node = doc.at("nodes").at(n);
    const glm::dmat4 world = parent * LocalMatrix(node);
    if (node.contains("mesh")) {
      facts.axisAligned = facts.axisAligned && MapsAxesToAxes(world);
      for (const Json& prim : doc.at("meshes").at(node["mesh"].get<size_t>()).at("primitives")) {
        if (prim.value("mode", 4) != 4) {
          ++facts.otherPrimitives;
          continue;
        }
        const size_t position = prim.at("attributes").at("POSITION").get<size_t>();
        const Json& pa = doc.at("accessors").at(position);
        const uint64_t count =
            prim.contains("indices")
                ? doc.at("accessors").at(prim["indices"].get<size_t>()).at("count").get<uint64_t>()
                : pa.at("count").get<uint64_t>();
        facts.triangles += count / 3;
        const size_t material =
            prim.contains("material") ? prim["material"].get<size_t>() : facts.materials.size();
        facts.trianglesPerMaterial.at(material) += count / 3;
        const std::vector<double> lo = pa.at("min").get<std::vector<double>>();
        const std::vector<double> hi = pa.at("max").get<std::vector<double>>();
        for (int corner = 0; corner < 8; ++corner) {
          const glm::dvec4 p((corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1],
                             (corner & 4) ? hi[2] : lo[2], 1.0);
          facts.corners.Add(glm::dvec3(world * p));
        }
        for (const glm::dvec3& v : file.Vec3Accessor(position))
          facts.vertices.Add(glm::dvec3(world * glm::dvec4(v, 1.0)));
      }
    }
    for (const Json& child : node.value("children", Json::array()))
      self(self, child.get<size_t>(), world, depth + 1);
  };
  const size_t scene = doc.value("scene", size_t(0));
  for (const Json& root : doc.at("scenes").at(scene).at("nodes"))
    walk(walk, root.get<size_t>(), glm::dmat4(1.0), 0);
  return facts;
}

// Everything the importer's result must agree with in a glTF file.
void ExpectMatchesGltf(const ImportedAsset& a, const GltfFacts& facts) {
  EXPECT_EQ(ImportedTriangles(a), facts.triangles);
  EXPECT_EQ(a.skippedPrimitives, 0u);
  const Box got = ImportedBounds(a);
  ExpectInside(got, facts.corners, "imported bounds vs the transformed accessor boxes");
  if (facts.axisAligned)
    ExpectSameBox(got, facts.corners, "imported bounds vs the transformed accessor boxes");
  ExpectSameBox(got, facts.vertices, "imported bounds vs the transformed vertices");

  // Materials. Assimp 5.2 orders a glTF's materials as its reader first meets them, not as the file lists
  // them, and names repeat (the engine has 34 materials under 8 names): so every material a mesh uses must be
  // one of the file's with that name, factor for factor, and the triangles per material name must agree.
  const std::string kNone = "(no material)";
  std::set<std::string> fileNames;
  for (const GltfMaterialFacts& f : facts.materials) fileNames.insert(f.name);
  std::map<std::string, uint64_t> want, have;
  for (size_t i = 0; i < facts.materials.size(); ++i)
    want[facts.materials[i].name] += facts.trianglesPerMaterial[i];
  want[kNone] += facts.trianglesPerMaterial.back();
  std::set<uint32_t> used;
  for (const AssetMesh& m : a.meshes) {
    const std::string& name = a.materials.at(m.material).name;
    have[fileNames.count(name) ? name : kNone] += m.triangles.size();
    used.insert(m.material);
  }
  for (auto& [name, count] : want) EXPECT_EQ(have[name], count) << "triangles with material '" << name << "'";
  for (auto& [name, count] : have) EXPECT_EQ(want[name], count) << "triangles with material '" << name << "'";

  auto near = [](double x, double y) { return std::fabs(x - y) <= 1e-6; };
  auto same = [&](const AssetMaterial& m, const GltfMaterialFacts& f) {
    bool ok = m.name == f.name && near(m.metallic, f.metallic) && near(m.roughness, f.roughness) &&
              (m.baseColorTexture >= 0) == f.hasBaseColorTexture;
    for (int c = 0; c < 3; ++c)
      ok = ok && near(m.baseColor[c], f.baseColor[c]) && near(m.emission[c], f.emission[c]);
    return ok;
  };
  auto describe = [](const AssetMaterial& m) {
    std::ostringstream s;
    s << "'" << m.name << "' baseColor " << m.baseColor.x << " " << m.baseColor.y << " " << m.baseColor.z
      << " metallic " << m.metallic << " roughness " << m.roughness << " emission " << m.emission.x << " "
      << m.emission.y << " " << m.emission.z << " texture " << m.baseColorTexture;
    return s.str();
  };
  for (uint32_t k : used) {
    const AssetMaterial& m = a.materials[k];
    if (!fileNames.count(m.name)) continue;  // the importer's default, for primitives without a material
    SCOPED_TRACE("imported material " + std::to_string(k) + " " + describe(m));
    EXPECT_FLOAT_EQ(m.specular, 0.04f);  // glTF's dielectric F0
    const auto f = std::find_if(facts.materials.begin(), facts.materials.end(),
                                [&](const GltfMaterialFacts& x) { return same(m, x); });
    EXPECT_NE(f, facts.materials.end()) << "no material of the file has these name and factors";
    if (f != facts.materials.end() && f->hasBaseColorTexture) {
      ASSERT_LT(size_t(m.baseColorTexture), a.textures.size());
      ExpectTextureIsImage(a.textures[size_t(m.baseColorTexture)], ReadImage(f->imageBytes, f->imageHint),
                           f->imageHint);
    }
  }
  // And the other way: each material some primitive of the scene uses was imported as it is.
  for (size_t i = 0; i < facts.materials.size(); ++i) {
    if (facts.trianglesPerMaterial[i] == 0) continue;
    EXPECT_TRUE(std::any_of(used.begin(), used.end(),
                            [&](uint32_t k) { return same(a.materials[k], facts.materials[i]); }))
        << "glTF material " << i << " '" << facts.materials[i].name << "' is not among the imported ones";
  }
}

// -----------------------------------------------------------------------------------------------------------
// Wavefront OBJ and MTL text.

std::vector<std::string> Tokens(const std::string& line) {
  std::istringstream s(line);
  std::vector<std::string> t;
  for (std::string w; s >> w;) t.push_back(w);
  return t;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream s(text);
  for (std::string line; std::getline(s, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

struct MtlFacts {
  glm::dvec3 kd{0.0}, ks{0.0};
  double ns = 0.0;
  std::string mapKd;  // the texture's path relative to the MTL, '\' made '/'
};

struct ObjFacts {
  uint64_t triangles = 0;                               // n - 2 per face of n corners
  Box allVertices;                                      // every 'v' line
  Box usedVertices;                                     // the 'v' lines some face refers to
  std::map<std::string, uint64_t> trianglesByMaterial;  // by the 'usemtl' in force ("" before any)
  std::map<std::string, MtlFacts> materials;            // from the 'mtllib' files
};

ObjFacts ReadObjFacts(const std::string& path) {
  ObjFacts facts;
  std::vector<glm::dvec3> v;
  std::vector<bool> used;
  std::string material;
  for (const std::string& line : Lines(ReadBytes(path))) {
    const std::vector<std::string> t = Tokens(line);
    if (t.empty()) continue;
    if (t[0] == "v") {
      v.emplace_back(std::stod(t.at(1)), std::stod(t.at(2)), std::stod(t.at(3)));
      facts.allVertices.Add(v.back());
      used.push_back(false);
    } else if (t[0] == "f") {
      EXPECT_GE(t.size(), 4u) << line;
      facts.triangles += t.size() - 3;
      facts.trianglesByMaterial[material] += t.size() - 3;
      for (size_t k = 1; k < t.size(); ++k) {
        long i = std::stol(t[k].substr(0, t[k].find('/')));
        i = i < 0 ? long(v.size()) + i : i - 1;  // negative: relative to the vertices so far
        EXPECT_TRUE(i >= 0 && size_t(i) < v.size()) << line;
        if (i >= 0 && size_t(i) < v.size()) used[size_t(i)] = true;
      }
    } else if (t[0] == "usemtl") {
      material = t.size() > 1 ? t[1] : "";
    } else if (t[0] == "mtllib" && t.size() > 1) {
      const fs::path mtl = fs::path(path).parent_path() / t[1];
      MtlFacts* m = nullptr;
      for (const std::string& ml : Lines(ReadBytes(mtl.string()))) {
        const std::vector<std::string> u = Tokens(ml);
        if (u.empty()) continue;
        if (u[0] == "newmtl") m = &facts.materials[u.at(1)];
        if (!m) continue;
        if (u[0] == "Kd") m->kd = glm::dvec3(std::stod(u.at(1)), std::stod(u.at(2)), std::stod(u.at(3)));
        if (u[0] == "Ks") m->ks = glm::dvec3(std::stod(u.at(1)), std::stod(u.at(2)), std::stod(u.at(3)));
        if (u[0] == "Ns") m->ns = std::stod(u.at(1));
        if (u[0] == "map_Kd") {
          m->mapKd = u.back();
          std::replace(m->mapKd.begin(), m->mapKd.end(), '\\', '/');
        }
      }
    }
  }
  for (size_t i = 0; i < v.size(); ++i)
    if (used[i]) facts.usedVertices.Add(v[i]);
  return facts;
}

void ExpectMatchesObj(const ImportedAsset& a, const ObjFacts& facts, const std::string& path) {
  EXPECT_EQ(ImportedTriangles(a), facts.triangles);
  const Box got = ImportedBounds(a);
  ExpectInside(got, facts.allVertices, "imported bounds vs every 'v' line");
  ExpectSameBox(got, facts.usedVertices, "imported bounds vs the vertices the faces use");

  // Triangles per material, by name; those before any 'usemtl' go to a material the MTL does not name.
  std::map<std::string, uint64_t> byName;
  uint64_t unnamed = 0;
  for (const AssetMesh& m : a.meshes) {
    const std::string& name = a.materials.at(m.material).name;
    if (facts.materials.count(name))
      byName[name] += m.triangles.size();
    else
      unnamed += m.triangles.size();
  }
  uint64_t wantUnnamed = 0;
  for (const auto& [name, count] : facts.trianglesByMaterial) {
    if (facts.materials.count(name))
      EXPECT_EQ(byName[name], count) << "triangles with material " << name;
    else
      wantUnnamed += count;
  }
  EXPECT_EQ(unnamed, wantUnnamed) << "triangles with no MTL material";

  // Each MTL material, mapped: baseColor = Kd / (1 - max Ks), specular = max Ks, roughness = (2 / (Ns +
  // 2))^(1/4).
  for (const auto& [name, want] : facts.materials) {
    SCOPED_TRACE("MTL material '" + name + "'");
    const auto it = std::find_if(a.materials.begin(), a.materials.end(),
                                 [&](const AssetMaterial& m) { return m.name == name; });
    ASSERT_NE(it, a.materials.end()) << "not imported";
    const double specular = std::max({want.ks.x, want.ks.y, want.ks.z});
    EXPECT_NEAR(it->specular, specular, 1e-6);
    EXPECT_EQ(it->metallic, 0.0f);
    EXPECT_NEAR(it->roughness, std::sqrt(std::sqrt(2.0 / (want.ns + 2.0))), 1e-6);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(it->baseColor[c], want.kd[c] / (1.0 - specular), 1e-6) << "Kd " << c;
    EXPECT_EQ(it->baseColorTexture >= 0, !want.mapKd.empty());
    if (!want.mapKd.empty() && it->baseColorTexture >= 0) {
      const std::string image = (fs::path(path).parent_path() / want.mapKd).lexically_normal().string();
      ASSERT_TRUE(HaveModel(image));
      ExpectTextureIsImage(a.textures.at(size_t(it->baseColorTexture)), ReadImage(ReadBytes(image), image),
                           image);
    }
  }
}

// -----------------------------------------------------------------------------------------------------------
// ASCII PLY: header and body.

struct PlyFacts {
  uint64_t faces = 0;  // 'element face N'
  Box allVertices, usedVertices;
  bool hasNormals = false, hasTexcoords = false;
};

PlyFacts ReadAsciiPlyFacts(const std::string& path) {
  PlyFacts facts;
  const std::vector<std::string> lines = Lines(ReadBytes(path));
  size_t at = 0, vertices = 0;
  std::vector<std::string> vertexProperties;
  std::string element;
  for (; at < lines.size(); ++at) {
    const std::vector<std::string> t = Tokens(lines[at]);
    if (t.empty()) continue;
    if (t[0] == "format") {
      EXPECT_EQ(t.at(1), "ascii") << path << ": this reader takes ASCII PLY only";
    }
    if (t[0] == "element") {
      element = t.at(1);
      if (element == "vertex") vertices = std::stoul(t.at(2));
      if (element == "face") facts.faces = std::stoul(t.at(2));
    }
    if (t[0] == "property" && element == "vertex") vertexProperties.push_back(t.back());
    if (t[0] == "end_header") break;
  }
  auto column = [&](const std::string& name) {
    return size_t(std::find(vertexProperties.begin(), vertexProperties.end(), name) -
                  vertexProperties.begin());
  };
  const size_t x = column("x"), y = column("y"), z = column("z");
  facts.hasNormals = column("nx") < vertexProperties.size();
  facts.hasTexcoords = column("s") < vertexProperties.size() || column("u") < vertexProperties.size();
  std::vector<glm::dvec3> v;
  for (size_t i = 0; i < vertices; ++i) {
    const std::vector<std::string> t = Tokens(lines.at(++at));
    v.emplace_back(std::stod(t.at(x)), std::stod(t.at(y)), std::stod(t.at(z)));
    facts.allVertices.Add(v.back());
  }
  for (uint64_t f = 0; f < facts.faces; ++f) {
    const std::vector<std::string> t = Tokens(lines.at(++at));
    EXPECT_EQ(t.at(0), "3") << path << " face " << f << ": the test expects a triangles-only file";
    for (size_t k = 1; k < t.size(); ++k) facts.usedVertices.Add(v.at(std::stoul(t[k])));
  }
  return facts;
}

// -----------------------------------------------------------------------------------------------------------
// Whole-asset comparison, field by field (texture names aside: they say where the image came from).

void ExpectSameGeometryAndTextures(const ImportedAsset& a, const ImportedAsset& b, const std::string& what) {
  ASSERT_EQ(a.meshes.size(), b.meshes.size()) << what;
  for (size_t i = 0; i < a.meshes.size(); ++i) {
    EXPECT_EQ(a.meshes[i].name, b.meshes[i].name) << what << " mesh " << i;
    EXPECT_EQ(a.meshes[i].material, b.meshes[i].material) << what << " mesh " << i;
    EXPECT_TRUE(a.meshes[i].positions == b.meshes[i].positions) << what << " mesh " << i << " positions";
    EXPECT_TRUE(a.meshes[i].normals == b.meshes[i].normals) << what << " mesh " << i << " normals";
    EXPECT_TRUE(a.meshes[i].texcoords == b.meshes[i].texcoords) << what << " mesh " << i << " texcoords";
    EXPECT_TRUE(a.meshes[i].triangles == b.meshes[i].triangles) << what << " mesh " << i << " triangles";
  }
  ASSERT_EQ(a.materials.size(), b.materials.size()) << what;
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const AssetMaterial &x = a.materials[i], &y = b.materials[i];
    EXPECT_TRUE(x.name == y.name && x.baseColor == y.baseColor && x.metallic == y.metallic &&
                x.roughness == y.roughness && x.specular == y.specular &&
                x.baseColorTexture == y.baseColorTexture && x.emission == y.emission &&
                x.emissionTexture == y.emissionTexture)
        << what << " material " << i;
  }
  ASSERT_EQ(a.textures.size(), b.textures.size()) << what;
  for (size_t i = 0; i < a.textures.size(); ++i) {
    EXPECT_EQ(a.textures[i].width, b.textures[i].width) << what << " texture " << i;
    EXPECT_EQ(a.textures[i].height, b.textures[i].height) << what << " texture " << i;
    EXPECT_TRUE(a.textures[i].rgb == b.textures[i].rgb) << what << " texture " << i << " texels";
  }
  EXPECT_EQ(a.skippedPrimitives, b.skippedPrimitives) << what;
}

const char* const kBoxTextured[] = {"glTF2/BoxTextured-glTF/BoxTextured.gltf",
                                    "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
                                    "glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"};
const char* const kEngine = "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";

// Every model this file imports.
const char* const kAllModels[] = {kBoxTextured[0],  kBoxTextured[1],    kBoxTextured[2], kEngine,
                                  "OBJ/spider.obj", "OBJ/WusonOBJ.obj", "PLY/Wuson.ply"};

TEST(AssetImport, TestModelsArePresent) {
  for (const char* m : kAllModels) EXPECT_TRUE(HaveModel(kModels + m));
}

TEST(AssetImport, BoxTexturedMatchesItsGltfJsonInAllThreeEncodings) {
  for (const char* m : kBoxTextured) {
    const std::string path = kModels + m;
    SCOPED_TRACE(path);
    ASSERT_TRUE(HaveModel(path));
    const GltfFacts facts = ReadGltfFacts(path);
    EXPECT_EQ(facts.triangles, 12u);  // a box: what the accessor says, stated here so a misread JSON shows
    EXPECT_TRUE(facts.axisAligned);
    ASSERT_EQ(facts.materials.size(), 1u);
    EXPECT_TRUE(facts.materials[0].hasBaseColorTexture);
    const ImportedAsset a = ImportAsset(path);
    ExpectMatchesGltf(a, facts);
    std::cout << "[ figures  ] " << m << ": JSON " << facts.triangles << " triangles, corner box "
              << facts.corners << "; imported " << ImportedTriangles(a) << ", box " << ImportedBounds(a)
              << "\n";
    EXPECT_EQ(a.textures.size(), 1u);
  }
}

TEST(AssetImport, BoxTexturedEncodingsGiveTheSameGeometryAndDecodedTexture) {
  for (const char* m : kBoxTextured) ASSERT_TRUE(HaveModel(kModels + m));
  const ImportedAsset separate = ImportAsset(kModels + kBoxTextured[0]);
  for (const char* m : {kBoxTextured[1], kBoxTextured[2]})
    ExpectSameGeometryAndTextures(separate, ImportAsset(kModels + m), m);
  ASSERT_EQ(separate.textures.size(), 1u);
  // The size in CesiumLogoFlat.png's IHDR chunk (PNG: 8-byte signature, chunk length and type, then
  // big-endian width and height).
  const std::string png = ReadBytes(kModels + "glTF2/BoxTextured-glTF/CesiumLogoFlat.png");
  ASSERT_GE(png.size(), 24u);
  ASSERT_EQ(png.substr(12, 4), "IHDR");
  auto be32 = [&](size_t at) {
    return int(uint32_t(uint8_t(png[at])) << 24 | uint32_t(uint8_t(png[at + 1])) << 16 |
               uint32_t(uint8_t(png[at + 2])) << 8 | uint32_t(uint8_t(png[at + 3])));
  };
  EXPECT_EQ(separate.textures[0].width, be32(16));
  EXPECT_EQ(separate.textures[0].height, be32(20));
  std::cout << "[ figures  ] CesiumLogoFlat.png: " << be32(16) << " x " << be32(20) << "\n";
}

// KHR_materials_emissive_strength belongs to the material the file gives it to, whatever order Assimp keeps
// the materials in (Assimp 5.2 orders them as its glTF reader first meets them: here B, through the first
// node, before A, which the file lists first).
TEST(AssetImport, EmissiveStrengthStaysWithItsMaterialWhenAssimpReordersThem) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-asset-emissive-strength";
  fs::create_directories(dir);
  const std::string path = (dir / "order.gltf").string();
  std::ofstream(path) << test::MakeGltf(
      {{"A", Vec3(1.0f), Vec3(1.0f), 5.0f}, {"B", Vec3(1.0f), Vec3(1.0f), -1.0f}},
      {{"usesB", 1, {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}},
       {"usesA", 0, {Vec3(0, 0, -1), Vec3(1, 0, -1), Vec3(0, 1, -1)}}});
  const ImportedAsset a = ImportAsset(path);
  fs::remove_all(dir);
  ASSERT_EQ(a.meshes.size(), 2u);
  for (const AssetMesh& m : a.meshes) {
    const AssetMaterial& mat = a.materials.at(m.material);
    const float want = mat.name == "A" ? 5.0f : 1.0f;
    EXPECT_EQ(mat.emission, Vec3(want)) << "mesh " << m.name << " material " << mat.name << " emits "
                                        << mat.emission.x << ", the file says " << want;
  }
}

// Nested nodes with matrices (rotations by 60 and 45 degrees, mirrors), meshes instanced by several nodes.
TEST(AssetImport, CylinderEngineMatchesItsNodeHierarchy) {
  const std::string path = kModels + kEngine;
  ASSERT_TRUE(HaveModel(path));
  const GltfFacts facts = ReadGltfFacts(path);
  EXPECT_FALSE(facts.axisAligned);  // so only containment in the corner boxes; the vertex box is exact
  EXPECT_EQ(facts.otherPrimitives, 0u);
  const ImportedAsset a = ImportAsset(path);
  ExpectMatchesGltf(a, facts);
  std::cout << "[ figures  ] " << kEngine << ": JSON " << facts.triangles << " triangles, vertex box "
            << facts.vertices << ", accessor-corner box " << facts.corners << "; imported "
            << ImportedTriangles(a) << " triangles in " << a.meshes.size() << " meshes, box "
            << ImportedBounds(a) << "\n";
}

TEST(AssetImport, SpiderObjMatchesItsFacesAndMtl) {
  const std::string path = kModels + "OBJ/spider.obj";
  ASSERT_TRUE(HaveModel(path));
  ASSERT_TRUE(HaveModel(kModels + "OBJ/spider.mtl"));
  const ObjFacts facts = ReadObjFacts(path);
  EXPECT_EQ(facts.materials.size(), 5u);  // a misread MTL shows here
  const ImportedAsset a = ImportAsset(path);
  ExpectMatchesObj(a, facts, path);
  std::cout << "[ figures  ] OBJ/spider.obj: " << facts.triangles << " triangles from 'f' lines, box "
            << facts.usedVertices << "; imported " << ImportedTriangles(a) << " in " << a.meshes.size()
            << " meshes, box " << ImportedBounds(a) << "\n";
  EXPECT_EQ(a.textures.size(), 5u);  // one per distinct map_Kd, including the unused material's
}

// The spider's MTL has Ks 0 and Ns 0, which leave the mapping's division and exponent untried: an MTL written
// here has both (and a polygon of five corners, three triangles, besides a triangle).
TEST(AssetImport, MtlSpecularAndShininessMapAsDocumented) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir-asset-mtl-mapping";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "m.mtl") << "newmtl shiny\nKd 0.3 0.4 0.5\nKs 0.2 0.1 0.05\nNs 98\n"
                                  "newmtl dull\nKd 0.6 0.5 0.4\nKs 0.01 0.02 0.03\nNs 7.5\n";
  std::ofstream(dir / "m.obj")
      << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\nv 0 0 3\n"
         "usemtl shiny\nf 1 2 3 4 5\nusemtl dull\nf 1 2 6\n";
  const std::string path = (dir / "m.obj").string();
  const ObjFacts facts = ReadObjFacts(path);
  EXPECT_EQ(facts.triangles, 4u);
  ASSERT_EQ(facts.materials.size(), 2u);
  ExpectMatchesObj(ImportAsset(path), facts, path);
  fs::remove_all(dir);
}

TEST(AssetImport, WusonObjMatchesItsFaces) {
  const std::string path = kModels + "OBJ/WusonOBJ.obj";
  ASSERT_TRUE(HaveModel(path));
  const ObjFacts facts = ReadObjFacts(path);
  EXPECT_TRUE(facts.materials.empty());
  const ImportedAsset a = ImportAsset(path);
  ExpectMatchesObj(a, facts, path);
  std::cout << "[ figures  ] OBJ/WusonOBJ.obj: " << facts.triangles << " triangles from 'f' lines, box "
            << facts.usedVertices << "; imported " << ImportedTriangles(a) << ", box " << ImportedBounds(a)
            << "\n";
  for (const AssetMesh& m : a.meshes)
    EXPECT_EQ(m.normals.size(), m.positions.size()) << "the faces give normals";
}

TEST(AssetImport, WusonPlyMatchesItsHeaderAndBody) {
  const std::string path = kModels + "PLY/Wuson.ply";
  ASSERT_TRUE(HaveModel(path));
  const PlyFacts facts = ReadAsciiPlyFacts(path);
  const ImportedAsset a = ImportAsset(path);
  EXPECT_EQ(ImportedTriangles(a), facts.faces);
  ExpectInside(ImportedBounds(a), facts.allVertices, "imported bounds vs the vertex element");
  ExpectSameBox(ImportedBounds(a), facts.usedVertices, "imported bounds vs the vertices the faces use");
  EXPECT_TRUE(facts.hasNormals && facts.hasTexcoords);
  for (const AssetMesh& m : a.meshes) {
    EXPECT_EQ(m.normals.size(), m.positions.size());
    EXPECT_EQ(m.texcoords.size(), m.positions.size());
  }
  EXPECT_TRUE(a.textures.empty());
  std::cout << "[ figures  ] PLY/Wuson.ply: header " << facts.faces << " faces, vertex box "
            << facts.usedVertices << "; imported " << ImportedTriangles(a) << " triangles, box "
            << ImportedBounds(a) << "\n";
}

// The child process changes nothing: its result, serialised, is the in-process import's to the byte.
TEST(AssetImport, ForkedImportEqualsInProcessImport) {
  for (const char* m : kAllModels) {
    const std::string path = kModels + m;
    SCOPED_TRACE(path);
    ASSERT_TRUE(HaveModel(path));
    const std::string forked = SerializeAsset(ImportAsset(path));
    const std::string inProcess = SerializeAsset(ImportAssetInProcess(path));
    EXPECT_EQ(forked.size(), inProcess.size());
    EXPECT_TRUE(forked == inProcess);
  }
}

TEST(AssetImport, SerializeDeserializeRoundTripsExactly) {
  for (const char* m : kAllModels) {
    const std::string path = kModels + m;
    SCOPED_TRACE(path);
    ASSERT_TRUE(HaveModel(path));
    const ImportedAsset a = ImportAssetInProcess(path);
    const std::string bytes = SerializeAsset(a);
    const ImportedAsset b = DeserializeAsset(bytes, path);
    ExpectSameGeometryAndTextures(a, b, m);
    for (size_t i = 0; i < a.textures.size() && i < b.textures.size(); ++i)
      EXPECT_EQ(a.textures[i].name, b.textures[i].name);
    EXPECT_TRUE(SerializeAsset(b) == bytes);
    EXPECT_NO_THROW(ValidateAsset(b, path, AssetLimits{}));
  }
}

// A damaged message is an InputError naming the path, never a crash or another exception: every prefix of a
// real asset's bytes, and single-byte changes in its counts.
TEST(AssetImport, DeserializeRefusesTruncatedOrDamagedBytes) {
  const std::string path = kModels + kBoxTextured[0];
  ASSERT_TRUE(HaveModel(path));
  const std::string bytes = SerializeAsset(ImportAssetInProcess(path));
  for (size_t cut = 0; cut < bytes.size(); cut += 1 + cut / 64) {
    try {
      DeserializeAsset(bytes.substr(0, cut), "x.glb");
      ADD_FAILURE() << "a " << cut << "-byte prefix of " << bytes.size() << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("x.glb: error: ", 0), 0u) << e.what();
    }
  }
  for (size_t at = 0; at < std::min<size_t>(bytes.size(), 256); ++at) {
    std::string damaged = bytes;
    damaged[at] = char(damaged[at] ^ 0xFF);
    try {
      const ImportedAsset a = DeserializeAsset(damaged, "x.glb");
      ValidateAsset(a, "x.glb", AssetLimits{});
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("x.glb: error: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace restir
