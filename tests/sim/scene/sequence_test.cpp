// Sequence files: parsing and validation (every error is one line with file:line:column and JSON path),
// the OBJ reader, the shipped sequences, and animation evaluation.
#include "sim/scene/sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace sequence_test {

// Small valid sequence; tests edit it with Replace. Column numbers in the tests refer to this layout.
const char* const kBase = R"({
  "name": "t",
  "resolution": [8, 4],
  "frames": 4,
  "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]}],
  "objects": [{"name": "o", "material": "m", "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}}],
  "lights": [{"name": "l", "type": "quad", "center": [0, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1}],
  "camera": {"keyframes": [{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 45}]}
})";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in text";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The InputError message for text, or "" when it parses. Also checks the one-line promise of DESIGN §10.
std::string ErrorOf(const std::string& text, const std::string& baseDir = ".") {
  try {
    ParseSequence(text, "seq.json", baseDir);
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
  }
  return "";
}

std::string SourcePath(const std::string& relative) {
  return std::string(RESTIR_SOURCE_DIR) + "/" + relative;
}

// A scratch directory unique to the test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            (std::string("restir_seq_") + info->test_suite_name() + "_" + info->name());
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string file = (path_ / name).string();
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }
  std::string Path() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

void ExpectNear(const Vec3& a, const Vec3& b, float eps = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

// --- parsing and errors
// -------------------------------------------------------------------------------------

TEST(SequenceParse, MinimalTextParses) {
  const Sequence seq = ParseSequence(kBase, "seq.json", ".");
  EXPECT_EQ(seq.name, "t");
  EXPECT_EQ(seq.width, 8);
  EXPECT_EQ(seq.height, 4);
  EXPECT_EQ(seq.frameCount, 4);
  EXPECT_EQ(seq.frameRate, 30.0f);  // default
  ASSERT_EQ(seq.lights.size(), 1u);
  EXPECT_EQ(seq.lights[0].vertices.size(), 6u);
  ASSERT_EQ(seq.objects.size(), 1u);
  EXPECT_EQ(seq.objects[0].keys.size(), 1u);  // identity key when none is given
  EXPECT_FALSE(seq.objects[0].animated);
  EXPECT_EQ(seq.objects[0].mesh.normals.size(),
            seq.objects[0].mesh.positions.size());  // spheres shade smooth
  EXPECT_EQ(seq.defaults.presets, std::vector<std::string>{"ris"});
  EXPECT_EQ(seq.contentHash.size(), 16u);
}

TEST(SequenceParse, SyntaxErrorReportsLineAndColumn) {
  EXPECT_EQ(
      ErrorOf("{\n  \"name\": \"t\",\n  \"frames\": ,\n}").rfind("seq.json:3:13: error: invalid JSON: ", 0),
      0u)
      << ErrorOf("{\n  \"name\": \"t\",\n  \"frames\": ,\n}");
  // An invalid literal is reported where it starts, not where the lexer gave up.
  EXPECT_EQ(ErrorOf("{\"a\": tru}").rfind("seq.json:1:7: error: invalid JSON", 0), 0u)
      << ErrorOf("{\"a\": tru}");
  EXPECT_EQ(ErrorOf("").rfind("seq.json:1:1: error: invalid JSON", 0), 0u) << ErrorOf("");
}

TEST(SequenceParse, SyntaxErrorColumnCountsCharactersNotBytes) {
  // "é" is two UTF-8 bytes but one column, so the stray x is the 15th character.
  EXPECT_EQ(ErrorOf("{\"name\": \"\xC3\xA9\", x}").rfind("seq.json:1:15: error", 0), 0u)
      << ErrorOf("{\"name\": \"\xC3\xA9\", x}");
}

TEST(SequenceParse, NumberOverflowIsAnErrorWithPosition) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": 1e999"))
                .rfind("seq.json:6:105: error: invalid JSON", 0),
            0u);
}

// Finite float arithmetic (issue 14): numbers, object reach and light radiance have bounds whose products stay
// finite; each bound is tested on both sides, so a limit that moved would show here.
TEST(SequenceParse, NumbersBeyondFloatSafeBoundsAreErrorsAtTheirPath) {
  auto error = [](const std::string& from, const std::string& to) { return ErrorOf(Replace(kBase, from, to)); };
  EXPECT_EQ(error("\"position\": [0, 0, 5]", "\"position\": [0, 0, 1e7]"), "");
  EXPECT_NE(error("\"position\": [0, 0, 5]", "\"position\": [0, 0, 1.0001e7]").find("/camera/keyframes/0/position/2"),
            std::string::npos);
  EXPECT_NE(error("\"lookAt\": [0, 0, 0]", "\"lookAt\": [-3e38, 0, 0]").find("/camera/keyframes/0/lookAt/0"),
            std::string::npos);
  EXPECT_NE(error("\"radius\": 1", "\"radius\": 2e7").find("/objects/0/shape/radius"), std::string::npos);
  // A sun-like intensity is fine: only colour x intensity is bounded (1e12).
  EXPECT_EQ(error("\"intensity\": 1", "\"intensity\": 1.5e9"), "");
  EXPECT_EQ(error("\"intensity\": 1", "\"intensity\": 1e12"), "");
  EXPECT_NE(error("\"intensity\": 1", "\"intensity\": 1.1e12").find("/lights/0/intensity"), std::string::npos);
  EXPECT_NE(error("\"color\": [1, 1, 1], \"intensity\": 1", "\"color\": [2, 1, 1], \"intensity\": 1e12")
                .find("error at /lights/0: light 'l' has radiance"),
            std::string::npos);
  // Object reach: translation plus scale times the mesh's extent, per keyframe.
  const std::string far = ", \"keyframes\": [{\"frame\": 0, \"translate\": [0, 0, 0], \"scale\": [S, S, S]}]}]";
  auto withScale = [&](const std::string& scale) {
    std::string k = far;
    for (size_t at; (at = k.find('S')) != std::string::npos;) k.replace(at, 1, scale);
    return error("\"radius\": 1}}]", "\"radius\": 1e6}" + k);
  };
  EXPECT_EQ(withScale("99"), "");
  EXPECT_NE(withScale("101").find("/objects/0/keyframes/0"), std::string::npos) << withScale("101");
}

TEST(SequenceParse, WrongTypeReportsPathAndLine) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": \"1\"")),
            "seq.json:6:105: error at /objects/0/shape/radius: expected a number, got string");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"frames\": 4", "\"frames\": [4]")),
            "seq.json:4:13: error at /frames: expected an integer, got array");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"frames\": 4", "\"frames\": 4.5")),
            "seq.json:4:13: error at /frames: expected an integer, got 4.5");
  EXPECT_EQ(ErrorOf(Replace(kBase, "[0.5, 0.5, 0.5]", "[0.5, 0.5]")),
            "seq.json:5:60: error at /materials/0/albedo: expected an array of 3 numbers, got an array of 2");
  EXPECT_EQ(ErrorOf("[1, 2]"), "seq.json:1:1: error at (top level): expected an object, got array");
}

TEST(SequenceParse, UnknownKeySuggestsNearest) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\"", "\"radus\"")),
            "seq.json:6:95: error at /objects/0/shape/radus: unknown key 'radus' (did you mean 'radius'?)");
  EXPECT_NE(
      ErrorOf(Replace(kBase, "\"frames\"", "\"frame\"")).find("unknown key 'frame' (did you mean 'frames'?)"),
      std::string::npos);
}

TEST(SequenceParse, UnknownKeyWithoutCloseMatchListsKnownKeys) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": 1, \"xyzzyq\": 2")),
            "seq.json:6:108: error at /objects/0/shape/xyzzyq: unknown key 'xyzzyq' (expected one of: type, "
            "center, "
            "radius, segments)");
}

TEST(SequenceParse, UnknownEnumValueSuggestsNearest) {
  EXPECT_EQ(
      ErrorOf(Replace(kBase, "\"sphere\"", "\"spere\"")),
      "seq.json:6:64: error at /objects/0/shape/type: unknown shape type 'spere' (did you mean 'sphere'?)");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"material\": \"m\"", "\"material\": \"n\"")),
            "seq.json:6:41: error at /objects/0/material: unknown material 'n' (did you mean 'm'?)");
}

TEST(SequenceParse, MissingRequiredKeyNamesContainingObject) {
  EXPECT_EQ(ErrorOf(Replace(kBase, ", \"radius\": 1", "")),
            "seq.json:6:55: error at /objects/0/shape: missing required key 'radius'");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"frames\": 4,", ""))
                .find("error at (top level): missing required key 'frames'"),
            std::string("seq.json:1:1: ").size());
}

TEST(SequenceParse, NegativeRadiusIsRejected) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": -1")),
            "seq.json:6:105: error at /objects/0/shape/radius: radius must be > 0, got -1");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": 0")),
            "seq.json:6:105: error at /objects/0/shape/radius: radius must be > 0, got 0");
}

TEST(SequenceParse, ZeroResolutionIsRejected) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "[8, 4]", "[0, 4]")),
            "seq.json:3:18: error at /resolution/0: width must be in [1, 16384], got 0");
  EXPECT_NE(
      ErrorOf(Replace(kBase, "[8, 4]", "[8, 20000]")).find("/resolution/1: height must be in [1, 16384]"),
      std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kBase, "\"frames\": 4", "\"frames\": 0")).find("frames must be in [1, 100000]"),
            std::string::npos);
}

TEST(SequenceParse, ZeroAreaLightIsRejected) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"u\": [0.5, 0, 0]", "\"u\": [0, 0, 0]")),
            "seq.json:7:14: error at /lights/0: zero-area light 'l'");
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"v\": [0, 0, 0.5]", "\"v\": [1, 0, 0]")),
            "seq.json:7:14: error at /lights/0: zero-area light 'l'");
  const std::string tri =
      R"({"name": "l", "type": "triangle", "vertices": [[0, 0, 0], [1, 1, 1], [2, 2, 2]], "intensity": 1, "color": [1, 1, 1]})";
  EXPECT_NE(
      ErrorOf(
          Replace(
              kBase,
              R"({"name": "l", "type": "quad", "center": [0, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1})",
              tri))
          .find("zero-area light 'l'"),
      std::string::npos);
}

TEST(SequenceParse, NegativeOrBlackEmissionIsRejected) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"intensity\": 1", "\"intensity\": -2")),
            "seq.json:7:134: error at /lights/0/intensity: intensity must be > 0, got -2");
  EXPECT_NE(
      ErrorOf(Replace(kBase, "\"color\": [1, 1, 1]", "\"color\": [0, 0, 0]")).find("color must not be black"),
      std::string::npos);
  EXPECT_NE(
      ErrorOf(Replace(kBase, "[0.5, 0.5, 0.5]", "[-0.5, 0.5, 0.5]")).find("albedo components must be >= 0"),
      std::string::npos);
}

TEST(SequenceParse, DuplicateNamesAreRejected) {
  const std::string twoMaterials =
      Replace(kBase, R"("albedo": [0.5, 0.5, 0.5]})",
              R"("albedo": [0.5, 0.5, 0.5]}, {"name": "m", "type": "diffuse", "albedo": [1, 1, 1]})");
  EXPECT_NE(
      ErrorOf(twoMaterials)
          .find("error at /materials/1/name: duplicate material name 'm' (first used at /materials/0/name)"),
      std::string::npos);
  const std::string twoObjects = Replace(
      kBase, R"("radius": 1}}],)",
      R"("radius": 1}}, {"name": "o", "material": "m", "shape": {"type": "box", "min": [0, 0, 0], "max": [1, 1, 1]}}],)");
  EXPECT_NE(ErrorOf(twoObjects).find("duplicate object name 'o'"), std::string::npos);
  const std::string gridClash = Replace(
      kBase, R"("intensity": 1}],)",
      R"("intensity": 1}, {"name": "g", "type": "grid", "origin": [0, 2, 0], "u": [1, 0, 0], "v": [0, 0, 1], "count": [2, 1], "pitch": [2, 2], "color": [1, 1, 1], "intensity": 1}, {"name": "g[1,0]", "type": "quad", "center": [5, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1}],)");
  EXPECT_NE(ErrorOf(gridClash).find(
                "error at /lights/2/name: duplicate light name 'g[1,0]' (first used at /lights/1/name)"),
            std::string::npos)
      << ErrorOf(gridClash);
}

TEST(SequenceParse, DuplicateJsonKeyIsRejected) {
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"frames\": 4,", "\"frames\": 4, \"frames\": 3,")),
            "seq.json:4:16: error at /frames: duplicate key 'frames'");
}

TEST(SequenceParse, CameraPositionEqualToLookAtIsRejected) {
  EXPECT_EQ(
      ErrorOf(Replace(kBase, "\"lookAt\": [0, 0, 0]", "\"lookAt\": [0, 0, 5]")),
      "seq.json:8:74: error at /camera/keyframes/0/lookAt: camera lookAt equals its position [0, 0, 5]");
  // Fine at both keys, but position and lookAt swap places, so they meet halfway.
  const std::string swap = Replace(
      kBase, R"("fov": 45}]})", R"("fov": 45}, {"frame": 2, "position": [0, 0, 0], "lookAt": [0, 0, 5]}]})");
  EXPECT_NE(ErrorOf(swap).find(
                "error at /camera/keyframes/0: the interpolated camera position meets its lookAt at frame 1"),
            std::string::npos)
      << ErrorOf(swap);
}

TEST(SequenceParse, CameraNeedsAKeyframeAndValidFov) {
  EXPECT_NE(ErrorOf(Replace(kBase, R"([{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 45}])",
                            "[]"))
                .find("error at /camera/keyframes: expected a non-empty array"),
            std::string::npos);
  EXPECT_EQ(ErrorOf(Replace(kBase, "\"fov\": 45", "\"fov\": 180")),
            "seq.json:8:92: error at /camera/keyframes/0/fov: fov must be in (0, 180) degrees, got 180");
}

TEST(SequenceParse, KeyframesAreSortedAndDuplicatesRejected) {
  const std::string keys = Replace(
      kBase, R"("radius": 1}})",
      R"("radius": 1}, "keyframes": [{"frame": 3, "translate": [3, 0, 0]}, {"frame": 1, "translate": [1, 0, 0]}]})");
  const Sequence seq = ParseSequence(keys, "seq.json", ".");
  ASSERT_EQ(seq.objects[0].keys.size(), 2u);
  EXPECT_EQ(seq.objects[0].keys[0].frame, 1);
  EXPECT_EQ(seq.objects[0].keys[1].frame, 3);
  EXPECT_TRUE(seq.objects[0].animated);

  const std::string dup = Replace(keys, "{\"frame\": 1,", "{\"frame\": 3,");
  EXPECT_NE(ErrorOf(dup).find("error at /objects/0/keyframes/1/frame: duplicate keyframe at frame 3 (also at "
                              "/objects/0/keyframes/0)"),
            std::string::npos)
      << ErrorOf(dup);
  EXPECT_NE(ErrorOf(Replace(keys, "{\"frame\": 3,", "{\"frame\": 4,")).find("frame must be in [0, 3], got 4"),
            std::string::npos);
}

TEST(SequenceParse, IdenticalKeysAreNotAnimated) {
  const std::string keys = Replace(
      kBase, R"("radius": 1}})",
      R"("radius": 1}, "keyframes": [{"frame": 0, "translate": [1, 0, 0]}, {"frame": 3, "translate": [1, 0, 0], "interpolation": "smooth"}]})");
  EXPECT_FALSE(ParseSequence(keys, "seq.json", ".").objects[0].animated);
}

TEST(SequenceParse, InvalidOnRangesAreRejected) {
  auto withOn = [](const std::string& on) {
    return Replace(kBase, "\"intensity\": 1}", "\"intensity\": 1, \"on\": " + on + "}");
  };
  EXPECT_NE(ErrorOf(withOn("[[2, 2]]")).find("error at /lights/0/on/0: empty range"), std::string::npos);
  EXPECT_NE(
      ErrorOf(withOn("[[0, 5]]")).find("/lights/0/on/0/1: last frame (exclusive) must be in [0, 4], got 5"),
      std::string::npos);
  EXPECT_NE(ErrorOf(withOn("[]")).find("needs at least one [first, last) range"), std::string::npos);
  EXPECT_EQ(ErrorOf(withOn("[[0, 4]]")), "");
}

TEST(SequenceParse, RoughnessOnlyForGgxAndInRange) {
  EXPECT_NE(ErrorOf(Replace(kBase, "[0.5, 0.5, 0.5]}", "[0.5, 0.5, 0.5], \"roughness\": 0.5}"))
                .find("roughness applies only to 'ggx' materials"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(kBase, "\"diffuse\", \"albedo\": [0.5, 0.5, 0.5]}",
                            "\"ggx\", \"albedo\": [0.5, 0.5, 0.5], \"roughness\": 0}"))
                .find("roughness must be in (0, 1], got 0"),
            std::string::npos);
}

TEST(SequenceParse, FloatOverflowIsRejected) {
  EXPECT_EQ(
      ErrorOf(Replace(kBase, "\"radius\": 1", "\"radius\": 1e39")),
      "seq.json:6:105: error at /objects/0/shape/radius: number 1e+39 is out of single-precision range");
}

TEST(SequenceParse, GridGeneratesNamedLightsWithCycledColours) {
  const std::string grid = Replace(
      kBase,
      R"({"name": "l", "type": "quad", "center": [0, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1})",
      R"({"name": "g", "type": "grid", "origin": [0, 2, 0], "u": [1, 0, 0], "v": [0, 0, 1], "count": [3, 2],
          "pitch": [[2, 0, 0], 3], "colors": [[1, 0, 0], [0, 1, 0]], "intensities": [1, 2, 4]})");
  const Sequence seq = ParseSequence(grid, "seq.json", ".");
  ASSERT_EQ(seq.lights.size(), 6u);
  EXPECT_EQ(seq.lights[0].name, "g[0,0]");
  EXPECT_EQ(seq.lights[1].name, "g[1,0]");
  EXPECT_EQ(seq.lights[3].name, "g[0,1]");
  // Light index k = j * nx + i takes colour k mod 2 and intensity k mod 3.
  ExpectNear(seq.lights[0].radiance, Vec3(1, 0, 0));
  ExpectNear(seq.lights[1].radiance, Vec3(0, 2, 0));
  ExpectNear(seq.lights[5].radiance, Vec3(0, 4, 0));
  // Light [i,j] has its corner at origin + i*pitchU + j*pitchV and edges u, v.
  ExpectNear(seq.lights[4].vertices[0], Vec3(2, 2, 3));
  ExpectNear(seq.lights[4].vertices[2], Vec3(3, 2, 4));
  // Counter-clockwise seen from cross(u, v) = -y.
  const Vec3* v = seq.lights[4].vertices.data();
  EXPECT_LT(glm::cross(v[1] - v[0], v[2] - v[0]).y, 0.0f);
}

TEST(SequenceParse, QuadLightEmitsTowardsCrossUV) {
  const Sequence seq = ParseSequence(kBase, "seq.json", ".");  // u = +x, v = +z: cross = -y
  const std::vector<Vec3>& v = seq.lights[0].vertices;
  for (size_t t = 0; t < v.size(); t += 3) EXPECT_LT(glm::cross(v[t + 1] - v[t], v[t + 2] - v[t]).y, 0.0f);
  ExpectNear(v[0], Vec3(-0.5f, 2.0f, -0.5f));
}

// A light's `material` makes it a surface too (docs/sequence-format.md "Lights"); every light of a grid takes it;
// an unknown name is an error at its path, with the nearest name suggested.
TEST(SequenceParse, LightMaterialNamesTheSurfaceItReflectsBy) {
  EXPECT_EQ(ParseSequence(kBase, "seq.json", ".").lights[0].material, -1);
  const std::string quad = Replace(kBase, "\"intensity\": 1}", "\"intensity\": 1, \"material\": \"m\"}");
  EXPECT_EQ(ParseSequence(quad, "seq.json", ".").lights[0].material, 0);
  const std::string grid = Replace(
      kBase,
      R"({"name": "l", "type": "quad", "center": [0, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1})",
      R"({"name": "g", "type": "grid", "origin": [0, 2, 0], "u": [1, 0, 0], "v": [0, 0, 1], "count": [2, 2],
          "pitch": [2, 2], "color": [1, 1, 1], "intensity": 1, "material": "m"})");
  const Sequence g = ParseSequence(grid, "seq.json", ".");
  ASSERT_EQ(g.lights.size(), 4u);
  for (const Light& l : g.lights) EXPECT_EQ(l.material, 0) << l.name;
  const std::string wrong = Replace(kBase, "\"intensity\": 1}", "\"intensity\": 1, \"material\": \"n\"}");
  const std::string error = ErrorOf(wrong);
  EXPECT_NE(error.find("error at /lights/0/material: unknown material 'n' (did you mean 'm'?)"), std::string::npos)
      << error;
  EXPECT_NE(ErrorOf(Replace(kBase, "\"intensity\": 1}", "\"intensity\": 1, \"material\": 3}"))
                .find("error at /lights/0/material: expected a string"),
            std::string::npos);
}

TEST(SequenceParse, WindowBarsFollowDocumentedConvention) {
  const std::string bars = Replace(
      kBase, R"({"type": "sphere", "center": [0, 0, 0], "radius": 1})",
      R"({"type": "window_bars", "origin": [1, 2, 3], "count": 3, "spacing": 0.5, "thickness": 0.1, "height": 2, "depth": 0.2})");
  const Sequence seq = ParseSequence(bars, "seq.json", ".");
  const Mesh& mesh = seq.objects[0].mesh;
  EXPECT_EQ(mesh.triangles.size(), 36u);
  Vec3 lo(1e9f), hi(-1e9f);
  for (const Vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  ExpectNear(lo, Vec3(1, 2, 3));
  ExpectNear(hi, Vec3(2.1f, 4, 3.2f));  // last bar starts at origin.x + 2 * spacing
  EXPECT_NE(
      ErrorOf(Replace(bars, "\"spacing\": 0.5", "\"spacing\": 0.05")).find("spacing must exceed thickness"),
      std::string::npos);
}

TEST(SequenceParse, BoxTrianglesFaceOutwards) {
  const std::string box = Replace(kBase, R"({"type": "sphere", "center": [0, 0, 0], "radius": 1})",
                                  R"({"type": "box", "min": [-1, -2, -3], "max": [1, 2, 3]})");
  const Sequence seq = ParseSequence(box, "seq.json", ".");
  const Mesh& mesh = seq.objects[0].mesh;
  ASSERT_EQ(mesh.triangles.size(), 12u);
  for (const glm::uvec3& t : mesh.triangles) {
    const Vec3 a = mesh.positions[t.x], b = mesh.positions[t.y], c = mesh.positions[t.z];
    EXPECT_GT(glm::dot(glm::cross(b - a, c - a), (a + b + c) / 3.0f), 0.0f);
  }
  EXPECT_NE(
      ErrorOf(Replace(box, "\"max\": [1, 2, 3]", "\"max\": [1, -2, 3]")).find("box max must exceed min"),
      std::string::npos);
}

TEST(SequenceParse, SphereIsClosedAndOutwardFacing) {
  const Sequence seq =
      ParseSequence(Replace(kBase, "\"radius\": 1", "\"radius\": 2, \"segments\": 8"), "seq.json", ".");
  const Mesh& mesh = seq.objects[0].mesh;
  EXPECT_EQ(mesh.triangles.size(), 2u * 8u * 3u);  // 8 segments, 4 rings: two fans and two quad bands
  for (const Vec3& p : mesh.positions) EXPECT_NEAR(glm::length(p), 2.0f, 1e-5f);
  for (const glm::uvec3& t : mesh.triangles) {
    const Vec3 a = mesh.positions[t.x], b = mesh.positions[t.y], c = mesh.positions[t.z];
    EXPECT_GT(glm::dot(glm::cross(b - a, c - a), a + b + c), 0.0f);
  }
}

TEST(SequenceParse, MissingMeshFileNamesTheFile) {
  const std::string mesh = Replace(kBase, R"({"type": "sphere", "center": [0, 0, 0], "radius": 1})",
                                   R"({"type": "mesh", "file": "nope/missing.obj"})");
  EXPECT_EQ(ErrorOf(mesh, "base"),
            "seq.json:6:80: error at /objects/0/shape/file: cannot read file 'base/nope/missing.obj' (no such file)");
}

// Meshes go through Assimp, which gives no line numbers: the message names the mesh file, says what failed, and
// where the sequence asked for it.
TEST(SequenceParse, MalformedMeshNamesTheFileAndWhereItWasAskedFor) {
  TempDir dir;
  const std::string mesh = Replace(kBase, R"({"type": "sphere", "center": [0, 0, 0], "radius": 1})",
                                   R"({"type": "mesh", "file": "bad.obj"})");
  const std::string objPath = (std::filesystem::path(dir.Path()) / "bad.obj").string();
  const std::string origin = " (asset of seq.json:6:80 /objects/0/shape/file)";
  for (const char* bad : {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "v 0 0 0\nv 1 zero 0\nf 1 2 1\n",
                          "# nothing\nv 0 0 0\n", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "",
                          "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "v 0 0 0\nv 1 0 0\nv 1e9 1 0\nf 1 2 3\n"}) {
    dir.Write("bad.obj", bad);
    const std::string e = ErrorOf(mesh, dir.Path());
    EXPECT_EQ(e.rfind(objPath + ": error: ", 0), 0u) << bad << "\n" << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
    EXPECT_NE(e.find(origin), std::string::npos) << e;
  }
}

TEST(SequenceParse, ObjMeshHandlesFaceFormsAndNegativeIndices) {
  TempDir dir;
  dir.Write("m.obj",
            "# quad and triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
            "f 1/1 2/1 3/1 4/1\n"        // v/vt quad: fan-triangulated
            "f -4//1 -3//1 -2//-1\n"     // negative indices with normals
            "f 1/1/1 3/1/1 4/1/1\r\n");  // v/vt/vn, CRLF line end
  const std::string mesh = Replace(kBase, R"({"type": "sphere", "center": [0, 0, 0], "radius": 1})",
                                   R"({"type": "mesh", "file": "m.obj"})");
  const Sequence seq = ParseSequence(mesh, "seq.json", dir.Path());
  const Mesh& m = seq.objects[0].mesh;
  ASSERT_EQ(m.triangles.size(), 4u);
  // Every triangle is one of the file's faces, with its corners in the file's (counter-clockwise) order.
  for (const glm::uvec3& t : m.triangles) {
    const Vec3 n = glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
    EXPECT_GT(n.z, 0.0f);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.positions[t[k]].z, 0.0f);
  }

  // The hash covers the mesh: editing the OBJ changes it.
  const std::string before = seq.contentHash;
  dir.Write("m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
  EXPECT_NE(ParseSequence(mesh, "seq.json", dir.Path()).contentHash, before);
}

TEST(SequenceParse, DeepNestingIsRejectedWithoutExhaustingMemory) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_EQ(ErrorOf(deep), "seq.json:1:65: error: JSON nests deeper than 64 levels");
}

TEST(SequenceParse, LoadReportsUnreadableFile) {
  try {
    LoadSequence("/nonexistent/dir/x.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/dir/x.json: error: cannot read sequence file (no such file)");
  }
}

// --- shipped files
// ------------------------------------------------------------------------------------------

TEST(SequenceFiles, ShippedSequencesLoad) {
  for (const char* name : {"window_bars_pan", "static_room", "moving_occluder", "smoke"}) {
    SCOPED_TRACE(name);
    Sequence seq;
    ASSERT_NO_THROW(seq = LoadSequence(SourcePath(std::string("sequences/") + name + ".json")));
    EXPECT_EQ(seq.name, name);
    EXPECT_FALSE(seq.lights.empty());
    EXPECT_FALSE(SummarizeSequence(seq).empty());
  }
}

// The ReSTIR GI sequences (issue 41) load with the GI presets (tests/sim/estimator/presets_test.cpp holds what those
// model), and shutter_reveal_sun's description holds as
// geometry: before the reveal its shutter fills the view (every corner ray of frames 0-11 hits it) and at no frame
// does it stand in the way of a sun ray that enters the window (so the room's light never changes). Checked by slab
// tests against the shutter's world box, not by the renderer.
TEST(SequenceFiles, GiSequencesLoadAndTheShutterRevealsWithoutShadingTheRoom) {
  for (const char* name : {"window_bars_sun", "shutter_reveal_sun"}) {
    SCOPED_TRACE(name);
    const Sequence seq = LoadSequence(SourcePath(std::string("sequences/") + name + ".json"));
    EXPECT_TRUE(seq.lights.empty());
    EXPECT_TRUE(seq.sun.present);
    EXPECT_EQ(seq.defaults.presets, (std::vector<std::string>{"restir-gi", "restir-gi-unbiased", "restir-gi-spmis"}));
  }
  const Sequence seq = LoadSequence(SourcePath("sequences/shutter_reveal_sun.json"));
  size_t shutter = seq.objects.size();
  for (size_t k = 0; k < seq.objects.size(); ++k)
    if (seq.objects[k].name == "shutter") shutter = k;
  ASSERT_LT(shutter, seq.objects.size());
  EXPECT_TRUE(seq.objects[shutter].animated);
  const auto hits = [](const Vec3& lo, const Vec3& hi, const Vec3& origin, const Vec3& dir) {
    float t0 = 0.0f, t1 = 1e30f;
    for (int a = 0; a < 3; ++a) {
      if (dir[a] == 0.0f) {
        if (origin[a] < lo[a] || origin[a] > hi[a]) return false;
        continue;
      }
      float ta = (lo[a] - origin[a]) / dir[a], tb = (hi[a] - origin[a]) / dir[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    }
    return t0 <= t1;
  };
  for (int frame = 0; frame < seq.frameCount; ++frame) {
    const FrameState state = Evaluate(seq, frame, seq.width, seq.height);
    Vec3 lo(1e30f), hi(-1e30f);
    for (const Vec3& v : seq.objects[shutter].mesh.positions) {
      const Vec3 w = Vec3(state.objectToWorld[shutter] * glm::vec4(v, 1.0f));
      lo = glm::min(lo, w), hi = glm::max(hi, w);
    }
    // The window's opening (between the facade's sill, lintel and sides) on its street face, every 5 cm.
    for (float x = -3.6f; x <= 3.6f; x += 0.05f)
      for (float y = 0.3f; y <= 2.8f; y += 0.05f)
        ASSERT_FALSE(hits(lo, hi, Vec3(x, y, 0.2f), state.sunDirection)) << "frame " << frame << " x " << x << " y " << y;
    if (frame < 12) {
      const Camera& c = state.camera;
      for (const auto& [px, py] : {std::pair{0.0f, 0.0f}, {float(c.width), 0.0f}, {0.0f, float(c.height)},
                                   {float(c.width), float(c.height)}})
        EXPECT_TRUE(hits(lo, hi, c.position, c.RayDirection(px, py))) << "frame " << frame;
    }
  }
}

TEST(SequenceFiles, ShippedSequencesHaveDocumentedShape) {
  const Sequence smoke = LoadSequence(SourcePath("sequences/smoke.json"));
  EXPECT_EQ(smoke.width, 64);
  EXPECT_EQ(smoke.height, 36);
  EXPECT_EQ(smoke.frameCount, 6);
  EXPECT_EQ(smoke.lights.size(), 2u);
  EXPECT_EQ(smoke.defaults.referenceError, 0.02);
  EXPECT_EQ(smoke.defaults.referenceSppCap, 64);
  const Sequence occluder = LoadSequence(SourcePath("sequences/moving_occluder.json"));
  EXPECT_EQ(occluder.frameCount, 48);
  bool anyAnimated = false;
  for (const Object& o : occluder.objects) anyAnimated = anyAnimated || o.animated;
  EXPECT_TRUE(anyAnimated);
  const Sequence room = LoadSequence(SourcePath("sequences/static_room.json"));
  EXPECT_GE(room.lights.size(), 64u);
  EXPECT_EQ(room.frameCount, 64);
  bool hasTetra = false;
  for (const Object& o : room.objects) {
    if (o.mesh.triangles.size() == 4 && o.mesh.normals.size() == 12)
      hasTetra = true;  // split per face normal
  }
  EXPECT_TRUE(hasTetra);
}

TEST(SequenceFiles, WindowBarsPanHasManyLightsTwelveBarsAndEnoughFrames) {
  const Sequence seq = LoadSequence(SourcePath("sequences/window_bars_pan.json"));
  EXPECT_GE(seq.lights.size(), 64u);
  EXPECT_GE(seq.frameCount, 60);
  EXPECT_EQ(seq.width, 640);
  EXPECT_EQ(seq.height, 360);
  bool found = false;
  for (const Object& o : seq.objects) {
    if (o.name == "window_bars") {
      found = true;
      EXPECT_EQ(o.mesh.triangles.size(), 12u * 12u);  // 12 boxes of 12 triangles
    }
  }
  EXPECT_TRUE(found);
  bool hasGgx = false;
  for (const Material& m : seq.materials) hasGgx = hasGgx || m.type == MaterialType::kGgx;
  EXPECT_TRUE(hasGgx);
}

// The flagship only works if the camera really looks into the room through the window every frame: most
// primary rays must cross the wall plane inside the opening, and the pan must move the camera each frame.
TEST(SequenceFiles, WindowBarsPanCameraSeesInteriorThroughWindow) {
  const Sequence seq = LoadSequence(SourcePath("sequences/window_bars_pan.json"));
  const float wallZ = 0.2f;  // outside face of the facade
  Vec3 previous(0.0f);
  for (int f = 0; f < seq.frameCount; ++f) {
    const Camera cam = Evaluate(seq, f, seq.width, seq.height).camera;
    EXPECT_GT(cam.position.z, wallZ);
    int inside = 0, total = 0;
    for (int y = 0; y < seq.height; y += 6) {
      for (int x = 0; x < seq.width; x += 6) {
        const Vec3 d = cam.RayDirection(x + 0.5f, y + 0.5f);
        ++total;
        if (d.z >= 0.0f) continue;
        const Vec3 hit = cam.position + d * ((wallZ - cam.position.z) / d.z);
        if (hit.x > -3.6f && hit.x < 3.6f && hit.y > 0.3f && hit.y < 2.8f) ++inside;
      }
    }
    EXPECT_GT(static_cast<float>(inside) / static_cast<float>(total), 0.7f) << "frame " << f;
    if (f > 0) {
      EXPECT_GT(cam.position.x - previous.x, 0.01f) << "frame " << f;  // pans every frame
    }
    previous = cam.position;
  }
}

// --- evaluation
// ---------------------------------------------------------------------------------------------

Sequence TwoKeyCamera(const char* interpolation) {
  return ParseSequence(
      Replace(
          kBase, R"([{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 45}])",
          std::string(
              R"([{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 40, "interpolation": ")") +
              interpolation + R"("}, {"frame": 3, "position": [4, 0, 5], "lookAt": [4, 0, 0], "fov": 60}])"),
      "seq.json", ".");
}

TEST(SequenceEvaluate, CameraAtKeyEqualsKey) {
  const Sequence seq = TwoKeyCamera("linear");
  const Camera a = Evaluate(seq, 0, 8, 4).camera;
  EXPECT_EQ(a.position, Vec3(0, 0, 5));
  EXPECT_EQ(a.vfovDegrees, 40.0f);
  const Camera b = Evaluate(seq, 3, 8, 4).camera;
  EXPECT_EQ(b.position, Vec3(4, 0, 5));
  EXPECT_EQ(b.vfovDegrees, 60.0f);
  ExpectNear(b.forward, Vec3(0, 0, -1));
}

TEST(SequenceEvaluate, LinearInterpolationIsProportional) {
  // Frame 1 of 0..3 is one third of the way; the midpoint of the path is the midpoint of the keys.
  const Sequence seq = TwoKeyCamera("linear");
  ExpectNear(Evaluate(seq, 1, 8, 4).camera.position, Vec3(4.0f / 3.0f, 0, 5));
  EXPECT_NEAR(Evaluate(seq, 2, 8, 4).camera.vfovDegrees, 40.0f + 20.0f * 2.0f / 3.0f, 1e-4f);
  const Sequence wide = ParseSequence(
      Replace(
          Replace(kBase, "\"frames\": 4", "\"frames\": 5"),
          R"([{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 45}])",
          R"([{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0]}, {"frame": 4, "position": [4, 2, 5], "lookAt": [4, 2, 0]}])"),
      "seq.json", ".");
  ExpectNear(Evaluate(wide, 2, 8, 4).camera.position, Vec3(2, 1, 5));
}

TEST(SequenceEvaluate, SmoothInterpolationFollowsSmoothstep) {
  const std::string text = Replace(
      Replace(kBase, "\"frames\": 4", "\"frames\": 5"), R"("radius": 1}})",
      R"("radius": 1}, "keyframes": [{"frame": 0, "interpolation": "smooth"}, {"frame": 4, "translate": [8, 0, 0], "rotate": [0, 0, 80], "scale": 3}]})");
  const Sequence seq = ParseSequence(text, "seq.json", ".");
  // t = 0.5: smoothstep(0.5) = 0.5, the midpoint.
  ExpectNear(Vec3(Evaluate(seq, 2, 8, 4).objectToWorld[0][3]), Vec3(4, 0, 0));
  // t = 0.25: smoothstep = 0.25^2 * (3 - 0.5) = 0.15625.
  const Mat4 quarter = Evaluate(seq, 1, 8, 4).objectToWorld[0];
  ExpectNear(Vec3(quarter[3]), Vec3(8.0f * 0.15625f, 0, 0));
  // Scale 1 → 3 and rotation 0 → 80 degrees about z at the same eased parameter.
  const float scale = 1.0f + 2.0f * 0.15625f;
  const float angle = glm::radians(80.0f * 0.15625f);
  ExpectNear(Vec3(quarter[0]), scale * Vec3(std::cos(angle), std::sin(angle), 0));
}

TEST(SequenceEvaluate, ClampsOutsideKeyedRange) {
  const std::string text = Replace(
      Replace(kBase, "\"frames\": 4", "\"frames\": 10"), R"("radius": 1}})",
      R"("radius": 1}, "keyframes": [{"frame": 3, "translate": [1, 0, 0]}, {"frame": 5, "translate": [3, 0, 0]}]})");
  const Sequence seq = ParseSequence(text, "seq.json", ".");
  EXPECT_EQ(Vec3(Evaluate(seq, 0, 8, 4).objectToWorld[0][3]), Vec3(1, 0, 0));
  EXPECT_EQ(Vec3(Evaluate(seq, 9, 8, 4).objectToWorld[0][3]), Vec3(3, 0, 0));
  ExpectNear(Vec3(Evaluate(seq, 4, 8, 4).objectToWorld[0][3]), Vec3(2, 0, 0));
}

TEST(SequenceEvaluate, ObjectTransformIsTranslateRotateZYXScale) {
  const std::string text = Replace(
      kBase, R"("radius": 1}})",
      R"("radius": 1}, "keyframes": [{"frame": 0, "translate": [1, 2, 3], "rotate": [90, 90, 0], "scale": [2, 3, 4]}]})");
  const Mat4 m = Evaluate(ParseSequence(text, "seq.json", "."), 0, 8, 4).objectToWorld[0];
  // (0, 1, 0) → scale (0, 3, 0) → X by 90 (0, 0, 3) → Y by 90 (3, 0, 0) → translate (4, 2, 3).
  EXPECT_EQ(Vec3(m * Vec4(0, 1, 0, 1)), Vec3(4, 2, 3));  // exact: quarter turns have exact sines
  // (1, 0, 0) → (2, 0, 0) → X keeps it → Y by 90 maps +x to -z: (0, 0, -2) → (1, 2, 1).
  EXPECT_EQ(Vec3(m * Vec4(1, 0, 0, 1)), Vec3(1, 2, 1));
  // Z rotation comes last: +x by 90 about z is +y.
  const std::string z = Replace(kBase, R"("radius": 1}})",
                                R"("radius": 1}, "keyframes": [{"frame": 0, "rotate": [0, 0, 90]}]})");
  EXPECT_EQ(Vec3(Evaluate(ParseSequence(z, "seq.json", "."), 0, 8, 4).objectToWorld[0] * Vec4(1, 0, 0, 1)),
            Vec3(0, 1, 0));
}

TEST(SequenceEvaluate, CameraBasisIsOrthonormalRightHanded) {
  const Camera cam = Evaluate(TwoKeyCamera("linear"), 1, 8, 4).camera;
  ExpectNear(cam.forward, Vec3(0, 0, -1));
  ExpectNear(cam.right, Vec3(1, 0, 0));
  ExpectNear(cam.up, Vec3(0, 1, 0));
  EXPECT_EQ(cam.width, 8);
  EXPECT_EQ(cam.height, 4);
  // Looking straight down: forward parallel to +Y's axis still gives a valid basis with right = +x.
  const Sequence down =
      ParseSequence(Replace(kBase, "\"lookAt\": [0, 0, 0]", "\"lookAt\": [0, -3, 5]"), "seq.json", ".");
  const Camera d = Evaluate(down, 0, 16, 9).camera;
  ExpectNear(d.forward, Vec3(0, -1, 0));
  ExpectNear(d.right, Vec3(1, 0, 0));
  EXPECT_NEAR(glm::dot(d.up, d.forward), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(d.up), 1.0f, 1e-6f);
  EXPECT_EQ(d.width, 16);  // the arguments, not the file's resolution
}

TEST(SequenceEvaluate, LightsFollowOnRanges) {
  const Sequence seq =
      ParseSequence(Replace(Replace(kBase, "\"frames\": 4", "\"frames\": 8"), "\"intensity\": 1}",
                            "\"intensity\": 1, \"on\": [[1, 3], [5, 6]]}"),
                    "seq.json", ".");
  const int expected[8] = {0, 1, 1, 0, 0, 1, 0, 0};
  for (int f = 0; f < 8; ++f) EXPECT_EQ(Evaluate(seq, f, 8, 4).lightOn[0], expected[f]) << "frame " << f;
  EXPECT_EQ(Evaluate(ParseSequence(kBase, "seq.json", "."), 3, 8, 4).lightOn[0], 1);  // no ranges: always on
}

TEST(SequenceSummary, ListsCountsAndPathLength) {
  const Sequence seq = TwoKeyCamera("linear");
  const std::string s = SummarizeSequence(seq);
  EXPECT_NE(s.find("8x4, 4 frames"), std::string::npos) << s;
  EXPECT_NE(s.find("path length 4.000 m"), std::string::npos) << s;
  EXPECT_NE(s.find("1 in 1 groups, 2 emitter triangles"), std::string::npos)
      << s;                                                               // a quad light is two triangles
  EXPECT_NE(s.find("o                      m"), std::string::npos) << s;  // object and its material
}

}  // namespace sequence_test
}  // namespace restir
