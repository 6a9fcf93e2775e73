// Shared by the asset proofs (tests/sim/assets/asset_closed_form_test.cpp, asset_texture_test.cpp,
// asset_unbiased_test.cpp): scratch directories, glTF 2.0 text with its buffer inline as a base64 data: URI, PNGs
// through OpenImageIO, sRGB decoding, transforms and the z-statistics claims, all in double precision and the
// tests' own, never sim/'s helpers.
#pragma once

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <vector>

#include "sim/run/frame_loop.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"
#include "tests/sim/asset_fixtures.h"  // EncodeBase64
#include "stats.h"

namespace restir::test {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using D3 = glm::dvec3;

namespace fs = std::filesystem;
using Json = nlohmann::json;
using D3 = glm::dvec3;

// -----------------------------------------------------------------------------------------------------------
// Files.

// A scratch directory for one test's files, unique to the process (builds may run the suite concurrently),
// removed afterwards.
class Scratch {
 public:
  explicit Scratch(const std::string& name)
      : path_(fs::path(::testing::TempDir()) / ("restir_asset_proof_" + std::to_string(::getpid())) /
              name) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Scratch() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
    fs::remove(path_.parent_path(), ignored);  // only once empty
  }
  const fs::path& operator*() const { return path_; }

 private:
  fs::path path_;
};

inline void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

// An 8-bit RGB PNG (sRGB-encoded by convention: the importer decodes 8-bit colour textures as sRGB).
inline void WritePng(const fs::path& path, int width, int height, const std::vector<uint8_t>& rgb) {
  ASSERT_EQ(rgb.size(), size_t(width) * height * 3);
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out) << OIIO::geterror();
  const OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
  ASSERT_TRUE(out->open(path.string(), spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, rgb.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

// IEC 61966-2-1's decoding of an 8-bit value, in double (the test's own, not sim/assets/texture.h's).
inline double SrgbDecode(int byte) {
  const double c = byte / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}
inline D3 SrgbDecode(const uint8_t rgb[3]) {
  return D3(SrgbDecode(rgb[0]), SrgbDecode(rgb[1]), SrgbDecode(rgb[2]));
}

inline Json J(const D3& v) {
  return Json::array({v.x, v.y, v.z});
}

// A glTF 2.0 document with one buffer, written inline as a data: URI.
class Gltf {
 public:
  Gltf() {
    doc_["asset"] = {{"version", "2.0"}, {"generator", "tests/sim/assets/asset_scene_writer.h"}};
    doc_["extensionsUsed"] = Json::array({"KHR_materials_emissive_strength", "KHR_texture_transform"});
  }
  int Positions(const std::vector<D3>& p) {
    std::vector<float> f;
    D3 lo(INFINITY), hi(-INFINITY);
    for (const D3& v : p) {
      for (int k = 0; k < 3; ++k) f.push_back(static_cast<float>(v[k]));
      lo = glm::min(lo, D3(glm::vec3(v))), hi = glm::max(hi, D3(glm::vec3(v)));
    }
    return Accessor(f.data(), f.size() * 4, 5126, "VEC3", p.size(), 34962, J(lo), J(hi));
  }
  // (s, t) as glTF has them: t grows downwards in the image (the importer turns it into v = 1 − t).
  int Texcoords(const std::vector<glm::dvec2>& st) {
    std::vector<float> f;
    for (const glm::dvec2& v : st) f.push_back(float(v.x)), f.push_back(float(v.y));
    return Accessor(f.data(), f.size() * 4, 5126, "VEC2", st.size(), 34962);
  }
  int Indices(const std::vector<uint32_t>& i) {
    return Accessor(i.data(), i.size() * 4, 5125, "SCALAR", i.size(), 34963);
  }
  int Texture(const std::string& uri) {
    if (!doc_.contains("samplers"))
      doc_["samplers"] =
          Json::array({{{"magFilter", 9729}, {"minFilter", 9729}, {"wrapS", 10497}, {"wrapT", 10497}}});
    doc_["images"].push_back({{"uri", uri}});
    doc_["textures"].push_back({{"source", doc_["images"].size() - 1}, {"sampler", 0}});
    return static_cast<int>(doc_["textures"].size() - 1);
  }
  int Material(const Json& m) { return Push("materials", m); }
  int Mesh(const Json& primitives) { return Push("meshes", {{"primitives", primitives}}); }
  int Node(const Json& n) { return Push("nodes", n); }
  static Json Primitive(int positions, int indices, int material, int texcoords = -1) {
    Json p = {
        {"attributes", {{"POSITION", positions}}}, {"indices", indices}, {"material", material}, {"mode", 4}};
    if (texcoords >= 0) p["attributes"]["TEXCOORD_0"] = texcoords;
    return p;
  }
  std::string Text(const std::vector<int>& roots) {
    Json d = doc_;
    d["scene"] = 0;
    d["scenes"] = Json::array({{{"nodes", roots}}});
    d["buffers"] = Json::array({{{"byteLength", buffer_.size()},
                                 {"uri", "data:application/octet-stream;base64," + EncodeBase64(buffer_)}}});
    return d.dump(1);
  }

 private:
  int Push(const char* key, const Json& v) {
    doc_[key].push_back(v);
    return static_cast<int>(doc_[key].size() - 1);
  }
  int Accessor(const void* data, size_t bytes, int componentType, const char* type, size_t count, int target,
               const Json& min = nullptr, const Json& max = nullptr) {
    while (buffer_.size() % 4) buffer_ += '\0';
    const size_t offset = buffer_.size();
    buffer_.append(static_cast<const char*>(data), bytes);
    const int view = Push("bufferViews",
                          {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
    Json a = {{"bufferView", view}, {"componentType", componentType}, {"count", count}, {"type", type}};
    if (!min.is_null()) a["min"] = min, a["max"] = max;
    return Push("accessors", a);
  }
  Json doc_;
  std::string buffer_;
};

// -----------------------------------------------------------------------------------------------------------
// Transforms, in double, the test's own (the sequence's convention: world = T · Rz · Ry · Rx · S).

inline glm::dmat3 Rows(const D3& a, const D3& b, const D3& c) {
  return glm::transpose(glm::dmat3(a, b, c));
}
inline glm::dmat3 Diagonal(const D3& d) {
  return Rows({d.x, 0, 0}, {0, d.y, 0}, {0, 0, d.z});
}
inline double CompMax(const D3& v) {
  return std::max({v.x, v.y, v.z});
}

inline glm::dmat3 RotationXyz(const D3& degrees) {
  const D3 r = glm::radians(degrees);
  const double cx = std::cos(r.x), sx = std::sin(r.x), cy = std::cos(r.y), sy = std::sin(r.y),
               cz = std::cos(r.z), sz = std::sin(r.z);
  const glm::dmat3 rx = Rows({1, 0, 0}, {0, cx, -sx}, {0, sx, cx});
  const glm::dmat3 ry = Rows({cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy});
  const glm::dmat3 rz = Rows({cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1});
  return rz * ry * rx;
}

// Unit quaternion (x, y, z, w) of a rotation by `degrees` about `axis`, components below 1e-15 set to 0 (so
// that a half turn is written exactly), and its matrix.
inline glm::dvec4 Quaternion(const D3& axis, double degrees) {
  const double h = glm::radians(degrees) / 2;
  glm::dvec4 q(glm::normalize(axis) * std::sin(h), std::cos(h));
  for (int k = 0; k < 4; ++k)
    if (std::fabs(q[k]) < 1e-15) q[k] = 0.0;
  return q;
}
inline glm::dmat3 QuaternionMatrix(const glm::dvec4& q) {
  const double x = q.x, y = q.y, z = q.z, w = q.w;
  return Rows({1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
              {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
              {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)});
}

struct Affine {
  glm::dmat3 a{1.0};
  D3 t{0.0};
  D3 operator()(const D3& p) const { return a * p + t; }
  Affine Then(const Affine& outer) const { return {outer.a * a, outer.a * t + outer.t}; }  // outer ∘ this
};

// One keyframe's placement.
struct Key {
  D3 translate{0.0}, rotate{0.0}, scale{1.0};
  Affine Matrix() const { return {RotationXyz(rotate) * Diagonal(scale), translate}; }
  Json ToJson() const {
    return {{"frame", 0}, {"translate", J(translate)}, {"rotate", J(rotate)}, {"scale", J(scale)}};
  }
};

// Floats carry ~24 bits: a world coordinate computed through a few float operations on values up to
// `magnitude` is within a few of its ulps of the exact value.
inline double FloatTolerance(double magnitude) {
  return 8.0 * std::ldexp(1.0, std::ilogb(std::max(magnitude, 1e-3)) - 23);
}

inline Json CameraJson(const D3& position, const D3& lookAt, double fov) {
  return {{"keyframes",
           Json::array({{{"frame", 0}, {"position", J(position)}, {"lookAt", J(lookAt)}, {"fov", fov}}})}};
}

inline Sequence Load(const fs::path& dir, const std::string& name, const Json& seq) {
  const fs::path path = dir / (name + ".json");
  WriteText(path, seq.dump(1));
  return LoadSequence(path.string());
}

inline ReferenceImage Reference(const Sequence& seq, int spp, GBuffer* gbuffer = nullptr) {
  FrameLoop loop(seq, seq.width, seq.height);
  loop.BeginFrame(0);
  if (gbuffer) *gbuffer = loop.Gbuffer();
  return loop.Reference(spp);
}

// -----------------------------------------------------------------------------------------------------------
// Statistics shared by the proofs: z per pixel and the claims on it.

struct Verdict {
  int pixels = 0;       // pixels with a z
  int exactPixels = 0;  // lit pixels the reference has exactly (standard error 0: the difference estimator)
  double meanZ2 = 0.0, maxAbsZ = 0.0;
  std::string worst;  // the pixel of the largest |z|
  double relativeError = 0.0, relativeStdError = 0.0;
};

// E z² ∈ [meanLo, meanHi] and Var z² ≤ variance for each of `units` independent units; the tail of |z| at
// most Student t's with `tailDof`; the relative error's standard error with `errorDof` dof (infinite: known);
// the relative error at most maxRelativeError in magnitude.
struct Claims {
  double meanLo, meanHi, variance, tailDof, errorDof, maxRelativeError;
};

inline void ExpectAgreement(const Verdict& v, double meanZ2, int units, const Claims& c, const std::string& what) {
  const double q = test::NormalQuantileUpper(0.5e-4);
  const double band = q * std::sqrt(c.variance / std::max(1, units));
  const double tail = test::StudentTQuantileTwoSided(1e-3 / std::max(1, v.pixels), c.tailDof);
  const double tMean = std::isinf(c.errorDof) ? test::NormalQuantileUpper(0.5e-3)
                                              : test::StudentTQuantileTwoSided(1e-3, c.errorDof);
  std::printf("  %-52s px %4d (+%d exact)  RMS z %.3f (%.3f..%.3f)  max|z| %5.2f (<%.1f)  rel.err %+.4f%% (se "
              "%.4f%%)\n",
              what.c_str(), v.pixels, v.exactPixels, std::sqrt(meanZ2), std::sqrt(std::max(0.0, c.meanLo - band)),
              std::sqrt(c.meanHi + band), v.maxAbsZ, tail, 100.0 * v.relativeError,
              100.0 * v.relativeStdError);
  EXPECT_GT(v.pixels + v.exactPixels, 500) << what;
  EXPECT_GE(meanZ2, c.meanLo - band) << what << ": RMS z " << std::sqrt(meanZ2);
  EXPECT_LE(meanZ2, c.meanHi + band) << what << ": RMS z " << std::sqrt(meanZ2);
  EXPECT_LE(v.maxAbsZ, tail) << what << ": worst " << v.worst;
  EXPECT_LE(std::fabs(v.relativeError), c.maxRelativeError) << what << ": relative error";
  // Where every lit pixel is exact (standard error 0), the relative error is float rounding alone.
  EXPECT_LE(std::fabs(v.relativeError), std::max(tMean * v.relativeStdError, 1e-6)) << what << ": relative error, t-test";
  EXPECT_LT(v.relativeStdError, c.maxRelativeError / 3.0)
      << what << ": the bound on the relative error has no power";
}

// A point `metres` from the origin in a direction with no zero component (so every axis is far).
inline D3 Far(double metres) {
  return metres * glm::normalize(D3(0.8, 0.36, -0.48));
}

}  // namespace restir::test
