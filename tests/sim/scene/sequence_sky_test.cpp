// The sky in sequence files (docs/sequence-format.md "Sky"): the environment (a map file or a colour) and the sun
// parse into Sequence::environment / Sequence::sun, their keys interpolate and switch like the other animated things,
// an illuminance becomes the radiance E / (π sin²α), a map file's texels land where OpenEXR's lat-long layout says,
// the map enters the content hash, and every bad input is one InputError naming the JSON path.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include "sim/scene/sequence.h"
#include "sim/scene/sky_frame.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace sequence_sky_test {

namespace fs = std::filesystem;

// A scene without lights, lit by `sky` (the top-level members it adds, e.g. "\"sun\": {...}"), over 10 frames.
std::string WithSky(const std::string& sky, const std::string& lights = "[]") {
  return R"({
  "name": "t",
  "resolution": [8, 4],
  "frames": 10,
  "materials": [{"name": "m", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]}],
  "objects": [{"name": "o", "material": "m", "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}}],
  "lights": )" + lights + R"(,
  )" + sky + R"(,
  "camera": {"keyframes": [{"frame": 0, "position": [0, 0, 5], "lookAt": [0, 0, 0], "fov": 45}]}
})";
}

const char* const kSun = R"("sun": {"direction": [0, 2, 0], "radiance": [1, 2, 3]})";
const char* const kColour = R"("environment": {"color": [0.25, 0.5, 1]})";

// The InputError message for text, or "" when it parses; one line (DESIGN §10).
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

// A scratch directory unique to the test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("restir_sky_") + info->test_suite_name() + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string Path() const { return path_.string(); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// Writes a float RGB image (row 0 at the top) with OpenImageIO; the format follows the extension.
void WriteImage(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  const OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::FLOAT);
  ASSERT_TRUE(out->open(path, spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, rgb.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

// The 4x2 test map: texel (column c, row r) is (1 + c + 4r, 10 + c, 20 + r), distinct everywhere.
std::vector<float> TestMap() {
  std::vector<float> rgb;
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 4; ++c) rgb.insert(rgb.end(), {1.0f + c + 4.0f * r, 10.0f + c, 20.0f + r});
  return rgb;
}
Vec3 TestTexel(int c, int r) { return Vec3(1.0f + c + 4.0f * r, 10.0f + c, 20.0f + r); }

void ExpectNear(const Vec3& a, const Vec3& b, float eps = 1e-6f) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

// --- the environment
// -----------------------------------------------------------------------------------------

TEST(SequenceSky, ColourEnvironmentIsAOneTexelMapWithOneKey) {
  const Sequence seq = ParseSequence(WithSky(R"("environment": {"color": [0.25, 0.5, 1], "intensity": 2,
      "rotation": 30})"), "seq.json", ".");
  const Environment& e = seq.environment;
  ASSERT_TRUE(e.present);
  EXPECT_FALSE(seq.sun.present);
  EXPECT_TRUE(e.file.empty());
  ASSERT_EQ(e.map.width, 1);
  ASSERT_EQ(e.map.height, 1);
  ASSERT_EQ(e.map.texels.size(), 1u);
  EXPECT_EQ(e.map.texels[0], Vec3(0.25f, 0.5f, 1.0f));
  ASSERT_EQ(e.keys.size(), 1u);
  EXPECT_EQ(e.keys[0].intensity, 2.0f);
  EXPECT_EQ(e.keys[0].rotationDegrees, 30.0f);
  EXPECT_TRUE(e.onRanges.empty());
  ASSERT_NE(e.sampler, nullptr);
  EXPECT_FALSE(e.sampler->Empty());
  // A constant sky: the same radiance everywhere.
  EXPECT_EQ(e.sampler->Radiance(Vec3(0, 1, 0)), Vec3(0.25f, 0.5f, 1.0f));
  EXPECT_EQ(e.sampler->Radiance(Vec3(0.6f, -0.8f, 0)), Vec3(0.25f, 0.5f, 1.0f));
  for (int f : {0, 5, 9}) {
    const FrameState s = Evaluate(seq, f, 8, 4);
    EXPECT_EQ(s.environmentIntensity, 2.0f);
    EXPECT_EQ(s.environmentRotationDegrees, 30.0f);
    EXPECT_EQ(s.sunIntensity, 0.0f);
  }
}

TEST(SequenceSky, DefaultsAreIntensityOneRotationZero) {
  const Sequence seq = ParseSequence(WithSky(kColour), "seq.json", ".");
  ASSERT_EQ(seq.environment.keys.size(), 1u);
  EXPECT_EQ(seq.environment.keys[0].intensity, 1.0f);
  EXPECT_EQ(seq.environment.keys[0].rotationDegrees, 0.0f);
  EXPECT_EQ(Evaluate(seq, 3, 8, 4).environmentIntensity, 1.0f);
}

TEST(SequenceSky, EnvironmentKeysInterpolateLinearSmoothAndClamp) {
  // Written out of order: keys are sorted by frame. Key at 2 eases (smoothstep) into 6, which moves linearly to 8.
  const Sequence seq = ParseSequence(WithSky(R"("environment": {"color": [1, 1, 1], "keyframes": [
      {"frame": 6, "intensity": 3, "rotation": 90},
      {"frame": 2, "intensity": 1, "interpolation": "smooth"},
      {"frame": 8, "intensity": 0, "rotation": 90}]})"), "seq.json", ".");
  const std::vector<EnvironmentKey>& keys = seq.environment.keys;
  ASSERT_EQ(keys.size(), 3u);
  EXPECT_EQ(keys[0].frame, 2);
  EXPECT_EQ(keys[0].rotationDegrees, 0.0f);  // not given: 0 for that key
  auto smooth = [](double t) { return t * t * (3.0 - 2.0 * t); };
  struct Expect {
    int frame;
    double intensity, rotation;
  };
  const Expect expected[] = {
      {0, 1.0, 0.0},                                          // before the first key: clamped
      {2, 1.0, 0.0},
      {3, 1.0 + 2.0 * smooth(0.25), 90.0 * smooth(0.25)},     // smoothstep from key 2
      {4, 2.0, 45.0},                                         // smoothstep(1/2) = 1/2
      {5, 1.0 + 2.0 * smooth(0.75), 90.0 * smooth(0.75)},
      {6, 3.0, 90.0},
      {7, 1.5, 90.0},                                         // linear from key 6
      {8, 0.0, 90.0},
      {9, 0.0, 90.0},                                         // after the last key: clamped
  };
  for (const Expect& e : expected) {
    const FrameState s = Evaluate(seq, e.frame, 8, 4);
    EXPECT_NEAR(s.environmentIntensity, e.intensity, 1e-6) << "frame " << e.frame;
    EXPECT_NEAR(s.environmentRotationDegrees, e.rotation, 1e-4) << "frame " << e.frame;
  }
}

TEST(SequenceSky, OnRangesSwitchTheEnvironmentAndTheSun) {
  const Sequence seq = ParseSequence(
      WithSky(R"("environment": {"color": [1, 1, 1], "intensity": 2, "on": [[1, 3], [5, 6]]},
      "sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1], "intensity": 4, "on": [[0, 2]]})"),
      "seq.json", ".");
  ASSERT_EQ(seq.environment.onRanges.size(), 2u);
  ASSERT_EQ(seq.sun.onRanges.size(), 1u);
  for (int f = 0; f < 10; ++f) {
    const FrameState s = Evaluate(seq, f, 8, 4);
    const bool environmentOn = (f >= 1 && f < 3) || f == 5;
    EXPECT_EQ(s.environmentIntensity, environmentOn ? 2.0f : 0.0f) << "frame " << f;
    EXPECT_EQ(s.sunIntensity, f < 2 ? 4.0f : 0.0f) << "frame " << f;
    // Switched off, the frame's sky has nothing of it.
    const Sky sky = MakeSky(seq, s);
    EXPECT_EQ(sky.environment != nullptr, environmentOn) << "frame " << f;
    EXPECT_EQ(sky.hasSun, f < 2) << "frame " << f;
  }
}

// --- the sun
// ------------------------------------------------------------------------------------------------

TEST(SequenceSky, SunParsesRadianceAndNormalisesItsDirection) {
  const Sequence seq = ParseSequence(WithSky(R"("sun": {"direction": [3, 4, 0], "angularDiameter": 2,
      "radiance": [1.6e9, 1.5e9, 1.4e9], "intensity": 0.5})"), "seq.json", ".");
  const Sun& sun = seq.sun;
  ASSERT_TRUE(sun.present);
  EXPECT_FALSE(seq.environment.present);
  EXPECT_EQ(sun.radiance, Vec3(1.6e9f, 1.5e9f, 1.4e9f));  // past the 1e7 bound on other numbers
  EXPECT_EQ(sun.angularDiameterDegrees, 2.0f);
  ASSERT_EQ(sun.keys.size(), 1u);
  ExpectNear(sun.keys[0].direction, Vec3(0.6f, 0.8f, 0.0f));
  const FrameState s = Evaluate(seq, 7, 8, 4);
  EXPECT_EQ(s.sunIntensity, 0.5f);
  ExpectNear(s.sunDirection, Vec3(0.6f, 0.8f, 0.0f));
  EXPECT_EQ(Evaluate(ParseSequence(WithSky(kSun), "seq.json", "."), 0, 8, 4).sunIntensity, 1.0f);
  EXPECT_EQ(ParseSequence(WithSky(kSun), "seq.json", ".").sun.angularDiameterDegrees, 0.53f);  // the default
}

TEST(SequenceSky, IlluminanceBecomesRadianceWithPiLSin2AlphaEqualToIt) {
  for (const double diameter : {0.53, 5.0, 30.0}) {
    const Vec3 e(1e5f, 5e4f, 2e4f);
    const Sequence seq = ParseSequence(
        WithSky(R"("sun": {"direction": [0, 1, 0], "illuminance": [1e5, 5e4, 2e4], "angularDiameter": )" +
                std::to_string(diameter) + "}"),
        "seq.json", ".");
    // E = π L sin²α for a disc of half-angle α and uniform radiance L, in double here.
    const double sinAlpha = std::sin(0.5 * diameter * M_PI / 180.0);
    for (int c = 0; c < 3; ++c) {
      const double l = double(e[c]) / (M_PI * sinAlpha * sinAlpha);
      EXPECT_NEAR(seq.sun.radiance[c], l, 1e-6 * l) << "diameter " << diameter << " channel " << c;
      EXPECT_NEAR(M_PI * seq.sun.radiance[c] * sinAlpha * sinAlpha, e[c], 1e-6 * e[c]);
    }
  }
}

TEST(SequenceSky, SunKeysInterpolateDirectionAndIntensity) {
  const Sequence seq = ParseSequence(WithSky(R"("sun": {"radiance": [1, 1, 1], "keyframes": [
      {"frame": 2, "direction": [1, 0, 0], "intensity": 1},
      {"frame": 6, "direction": [0, 2, 0], "intensity": 3, "interpolation": "smooth"},
      {"frame": 8, "direction": [0, -1, 0]}]})"), "seq.json", ".");
  ASSERT_EQ(seq.sun.keys.size(), 3u);
  EXPECT_EQ(seq.sun.keys[2].intensity, 1.0f);  // not given: 1 for that key
  // Before the first key and after the last: clamped.
  ExpectNear(Evaluate(seq, 0, 8, 4).sunDirection, Vec3(1, 0, 0));
  EXPECT_EQ(Evaluate(seq, 0, 8, 4).sunIntensity, 1.0f);
  ExpectNear(Evaluate(seq, 9, 8, 4).sunDirection, Vec3(0, -1, 0));
  // Linear from frame 2 to 6: normalize(lerp) of the unit keys.
  for (int f = 3; f <= 5; ++f) {
    const float t = (f - 2) / 4.0f;
    const Vec3 lerp = Vec3(1 - t, t, 0);
    const FrameState s = Evaluate(seq, f, 8, 4);
    ExpectNear(s.sunDirection, lerp / std::sqrt(lerp.x * lerp.x + lerp.y * lerp.y));
    EXPECT_NEAR(s.sunIntensity, 1.0f + 2.0f * t, 1e-6f);
  }
  // Smooth from 6 (up) to 8 (down): half-way the lerp is zero, and the earlier key's direction is kept.
  const FrameState half = Evaluate(seq, 7, 8, 4);
  EXPECT_EQ(half.sunDirection, Vec3(0, 1, 0));
  EXPECT_NEAR(half.sunIntensity, 2.0f, 1e-6f);
  EXPECT_NEAR(glm::length(Evaluate(seq, 4, 8, 4).sunDirection), 1.0f, 1e-6f);
}

TEST(SequenceSky, LightsMayBeEmptyOnlyWithASkyOrAssetEmitters) {
  EXPECT_EQ(ErrorOf(WithSky(kSun)), "");
  EXPECT_EQ(ErrorOf(WithSky(kColour)), "");
  // Without either: the old rule.
  const std::string noSky = WithSky(R"("seed": 3)");
  const std::string message = ErrorOf(noSky);
  EXPECT_NE(message.find("error at /lights: expected a non-empty array"), std::string::npos) << message;
  // Lights and a sky together.
  const Sequence both = ParseSequence(
      WithSky(kSun, R"([{"name": "l", "type": "quad", "center": [0, 2, 0], "u": [0.5, 0, 0], "v": [0, 0, 0.5],
                        "color": [1, 1, 1], "intensity": 1}])"),
      "seq.json", ".");
  EXPECT_EQ(both.lights.size(), 1u);
  EXPECT_TRUE(both.sun.present);
}

TEST(SequenceSky, SummaryListsEnvironmentAndSun) {
  const Sequence seq = ParseSequence(WithSky(R"("environment": {"color": [0.25, 0.5, 1], "keyframes": [
      {"frame": 0, "intensity": 1}, {"frame": 9, "intensity": 2, "rotation": 90}], "on": [[0, 5]]},
      "sun": {"direction": [0, 1, 0], "radiance": [1, 2, 3], "angularDiameter": 0.5})"), "seq.json", ".");
  const std::string s = SummarizeSequence(seq);
  EXPECT_NE(s.find("environment colour [0.25, 0.5, 1]; 2 keys: intensity 1..2, rotation 0..90 deg; on [0, 5)"),
            std::string::npos)
      << s;
  EXPECT_NE(s.find("sun         radiance [1, 2, 3], diameter 0.5 deg; 1 key: direction [0, 1, 0], intensity 1; "
                   "always on"),
            std::string::npos)
      << s;
  EXPECT_EQ(SummarizeSequence(ParseSequence(WithSky(kSun, R"([{"name": "l", "type": "quad", "center": [0, 2, 0],
      "u": [0.5, 0, 0], "v": [0, 0, 0.5], "color": [1, 1, 1], "intensity": 1}])"), "seq.json", "."))
                .find("environment"),
            std::string::npos);
}

// --- map files
// ----------------------------------------------------------------------------------------------

TEST(SequenceSky, ExrMapFollowsTheLatLongLayout) {
  TempDir dir;
  WriteImage(dir.File("sky.exr"), 4, 2, TestMap());
  // Relative to the sequence's directory, like assets.
  const Sequence seq = ParseSequence(WithSky(R"("environment": {"file": "sky.exr"})"), "seq.json", dir.Path());
  const Environment& e = seq.environment;
  ASSERT_TRUE(e.present);
  EXPECT_EQ(e.file, "sky.exr");
  ASSERT_EQ(e.map.width, 4);
  ASSERT_EQ(e.map.height, 2);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(e.map.texels[size_t(r * 4 + c)], TestTexel(c, r)) << c << "," << r;
  ASSERT_NE(e.sampler, nullptr);
  // By hand from the layout: longitude atan2(x, z) runs from +π at column 0 to -π, so the four columns' centres
  // look towards +X-Z, +X+Z, -X+Z and -X-Z; row 0 is the upper hemisphere (+Y).
  const float h = std::sqrt(0.5f) * 0.8f;  // 0.6 up or down, the rest split between x and z
  const Vec3 columnCentre[4] = {Vec3(h, 0, -h), Vec3(h, 0, h), Vec3(-h, 0, h), Vec3(-h, 0, -h)};
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 4; ++c) {
      Vec3 w = columnCentre[c];
      w.y = r == 0 ? 0.6f : -0.6f;
      EXPECT_EQ(e.sampler->Radiance(w), TestTexel(c, r)) << "column " << c << " row " << r;
    }
  // The poles and the axes, each inside one texel.
  EXPECT_EQ(e.sampler->Radiance(Vec3(0.01f, 1.0f, -0.01f)), TestTexel(0, 0));
  EXPECT_EQ(e.sampler->Radiance(Vec3(-0.01f, -1.0f, 0.01f)), TestTexel(2, 1));
  // Rotation 90° (counter-clockwise seen from above, +Z onto +X): the world's +X-Z shows the map's +X+Z.
  FrameState state = Evaluate(seq, 0, 8, 4);
  state.environmentRotationDegrees = 90.0f;
  const Sky sky = MakeSky(seq, state);
  EXPECT_EQ(sky.Radiance(Vec3(h, 0.6f, -h)), TestTexel(1, 0));
  EXPECT_EQ(sky.Radiance(Vec3(-h, -0.6f, h)), TestTexel(3, 1));
}

TEST(SequenceSky, PngMapIsDecodedFromSrgb) {
  TempDir dir;
  const std::string path = dir.File("sky.png");
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out) << OIIO::geterror();
  ASSERT_TRUE(out->open(path, OIIO::ImageSpec(2, 1, 3, OIIO::TypeDesc::UINT8)));
  const uint8_t rgb[6] = {128, 255, 10, 0, 64, 200};
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, rgb));
  ASSERT_TRUE(out->close());
  const Sequence seq = ParseSequence(WithSky(R"("environment": {"file": "sky.png"})"), "seq.json", dir.Path());
  auto decode = [](int byte) {  // IEC 61966-2-1, in double
    const double c = byte / 255.0;
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
  };
  ASSERT_EQ(seq.environment.map.texels.size(), 2u);
  for (int t = 0; t < 2; ++t)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(seq.environment.map.texels[size_t(t)][c], decode(rgb[3 * t + c]), 1e-6) << t << " " << c;
}

TEST(SequenceSky, ContentHashFollowsTheMapFile) {
  TempDir dir;
  const std::string text = WithSky(R"("environment": {"file": "sky.exr"})");
  std::vector<float> map = TestMap();
  WriteImage(dir.File("sky.exr"), 4, 2, map);
  const std::string first = ParseSequence(text, "seq.json", dir.Path()).contentHash;
  EXPECT_EQ(ParseSequence(text, "seq.json", dir.Path()).contentHash, first);
  map[5] = 0.5f;  // one channel of one texel
  WriteImage(dir.File("sky.exr"), 4, 2, map);
  const std::string edited = ParseSequence(text, "seq.json", dir.Path()).contentHash;
  EXPECT_NE(edited, first);
  // The same texels in another layout are another map.
  WriteImage(dir.File("sky.exr"), 2, 4, map);
  EXPECT_NE(ParseSequence(text, "seq.json", dir.Path()).contentHash, edited);
  // And the same bytes read from another directory (an absolute path) hash the same as the map's own content.
  WriteImage(dir.File("sky.exr"), 4, 2, TestMap());
  const std::string absolute =
      WithSky(R"("environment": {"file": ")" + dir.File("sky.exr") + R"("})");
  const Sequence a = ParseSequence(absolute, "seq.json", "/");
  const Sequence b = ParseSequence(absolute, "seq.json", dir.Path());
  EXPECT_EQ(a.contentHash, b.contentHash);
}

// --- bad input
// ----------------------------------------------------------------------------------------------

// The message names the JSON path (and, before it, the file, line and column).
void ExpectErrorAt(const std::string& message, const std::string& path, const std::string& what = "") {
  EXPECT_EQ(message.rfind("seq.json:", 0), 0u) << message;
  EXPECT_NE(message.find("error at " + path + ":"), std::string::npos) << "want " << path << ", got: " << message;
  if (!what.empty()) {
    EXPECT_NE(message.find(what), std::string::npos) << "want '" << what << "', got: " << message;
  }
}

TEST(SequenceSkyBadInput, EnvironmentNeedsExactlyFileOrColor) {
  TempDir dir;
  WriteImage(dir.File("sky.exr"), 4, 2, TestMap());
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "sky.exr", "color": [1, 1, 1]})"), dir.Path()),
                "/environment/color", "either 'file' or 'color'");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"intensity": 1})")), "/environment", "'file' or 'color'");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [0, 0, 0]})")), "/environment/color", "black");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, -1, 1]})")), "/environment/color", ">= 0");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": ""})")), "/environment/file", "empty");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": [1, 2])")), "/environment", "expected an object");
}

TEST(SequenceSkyBadInput, IntensitiesMustBeNonNegativeAndWithinTheRadianceBound) {
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "intensity": -1})")),
                "/environment/intensity", ">= 0");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "keyframes": [{"frame": 0},
      {"frame": 3, "intensity": -0.5}]})")),
                "/environment/keyframes/1/intensity", ">= 0");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1], "intensity": -2})")),
                "/sun/intensity", ">= 0");
  // Colour 1e7 x intensity 1e6 = 1e13 > 1e12, though each is within its own bound.
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1e7, 1, 1], "intensity": 1e6})")),
                "/environment/intensity", "beyond the limit of 1e12");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1e12, 1, 1], "intensity": 2})")),
                "/sun/intensity", "beyond the limit of 1e12");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1e12, 1, 1], "keyframes": [
      {"frame": 0, "direction": [0, 1, 0]}, {"frame": 1, "direction": [1, 1, 0], "intensity": 2}]})")),
                "/sun/keyframes/1/intensity", "beyond the limit of 1e12");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "intensity": 1e13})")),
                "/environment/intensity", "beyond the limit of 1e+12");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "rotation": 1e8})")),
                "/environment/rotation", "beyond the limit of 1e+07");
}

TEST(SequenceSkyBadInput, KeyframesExcludeTopLevelValues) {
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "rotation": 5,
      "keyframes": [{"frame": 0}]})")),
                "/environment/rotation", "in each key");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1], "direction": [0, 1, 0],
      "keyframes": [{"frame": 0, "direction": [0, 1, 0]}]})")),
                "/sun/direction", "in each key");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1], "keyframes": [{"frame": 0}]})")),
                "/sun/keyframes/0", "missing required key 'direction'");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1], "keyframes": []})")), "/sun/keyframes",
                "non-empty");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "keyframes": [{"frame": 10}]})")),
                "/environment/keyframes/0/frame", "");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "keyframes": [{"frame": 2},
      {"frame": 2}]})")),
                "/environment/keyframes/1/frame", "duplicate keyframe");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "keyframes": [{"frame": 2,
      "interpolation": "smoth"}]})")),
                "/environment/keyframes/0/interpolation", "did you mean 'smooth'");
}

TEST(SequenceSkyBadInput, SunDirectionDiameterAndRadiance) {
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 0, 0], "radiance": [1, 1, 1]})")), "/sun/direction",
                "must not be zero");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1], "keyframes": [
      {"frame": 0, "direction": [0, 1, 0]}, {"frame": 4, "direction": [0, 0, 0]}]})")),
                "/sun/keyframes/1/direction", "must not be zero");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1]})")), "/sun", "missing required key 'direction'");
  for (const char* d : {"0", "40", "-1", "1e-6"})
    ExpectErrorAt(ErrorOf(WithSky(std::string(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1],
        "angularDiameter": )") + d + "}")),
                  "/sun/angularDiameter", "(0, 30]");
  EXPECT_EQ(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1], "angularDiameter": 30})")), "");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1],
      "illuminance": [1, 1, 1]})")),
                "/sun/illuminance", "either 'radiance' or 'illuminance'");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0]})")), "/sun", "'radiance' or 'illuminance'");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [0, 0, 0]})")), "/sun/radiance",
                "black");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, -1, 1]})")), "/sun/radiance",
                ">= 0");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1]})")), "/sun/radiance",
                "array of 3");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [2e12, 1, 1]})")),
                "/sun/radiance/0", "beyond the limit");
  // 1e7 lux from a disc of 0.01°: L = 1e7 / (π sin²(0.005°)) = 4.2e14.
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "illuminance": [1e7, 1, 1],
      "angularDiameter": 0.01})")),
                "/sun/illuminance", "beyond the limit of 1e12");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "illuminance": [0, 0, 0]})")),
                "/sun/illuminance", "black");
}

TEST(SequenceSkyBadInput, OnRangesAreCheckedLikeLights) {
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1], "on": []})")),
                "/sun/on", "a sun that is always on");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "on": [[3, 3]]})")), "/environment/on/0",
                "empty range");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "on": [[0, 11]]})")),
                "/environment/on/0/1", "");
}

TEST(SequenceSkyBadInput, UnknownKeysSuggestTheNearest) {
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"color": [1, 1, 1], "intensty": 2})")),
                "/environment/intensty", "did you mean 'intensity'");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"direction": [0, 1, 0], "radiance": [1, 1, 1], "angularDiametre": 1})")),
                "/sun/angularDiametre", "did you mean 'angularDiameter'");
  ExpectErrorAt(ErrorOf(WithSky(R"("sun": {"radiance": [1, 1, 1], "keyframes": [{"frame": 0,
      "directoin": [0, 1, 0]}]})")),
                "/sun/keyframes/0/directoin", "did you mean 'direction'");
  ExpectErrorAt(ErrorOf(WithSky(R"("enviroment": {"color": [1, 1, 1]})")), "/enviroment",
                "did you mean 'environment'");
  // Located at the key: line 8 of WithSky's text, column 3 (after the two-space indent).
  const std::string message = ErrorOf(WithSky(R"("sky": {"color": [1, 1, 1]})"));
  EXPECT_EQ(message.rfind("seq.json:8:3: error at /sky: unknown key 'sky'", 0), 0u) << message;
}

TEST(SequenceSkyBadInput, MapFileProblemsNameTheFileKey) {
  TempDir dir;
  // Missing.
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "nope.exr"})"), dir.Path()), "/environment/file",
                "no such file");
  // A directory.
  fs::create_directories(dir.File("maps.exr"));
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "maps.exr"})"), dir.Path()), "/environment/file",
                "a directory");
  // Not an image at all, and an EXR cut short.
  std::ofstream(dir.File("text.exr"), std::ios::binary) << "not an image";
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "text.exr"})"), dir.Path()), "/environment/file",
                "cannot decode environment map");
  std::vector<float> big(64 * 32 * 3);
  for (size_t i = 0; i < big.size(); ++i) big[i] = float(i % 97) + 0.25f;
  WriteImage(dir.File("whole.exr"), 64, 32, big);
  std::string bytes;
  {
    std::ifstream in(dir.File("whole.exr"), std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(bytes.size(), 1000u);
  std::ofstream(dir.File("cut.exr"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "cut.exr"})"), dir.Path()), "/environment/file",
                "cannot decode environment map");
}

TEST(SequenceSkyBadInput, BadTexelsAreNamed) {
  TempDir dir;
  std::vector<float> map = TestMap();
  map[3 * (1 * 4 + 2) + 1] = std::numeric_limits<float>::quiet_NaN();  // column 2, row 1, green
  WriteImage(dir.File("nan.exr"), 4, 2, map);
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "nan.exr"})"), dir.Path()), "/environment/file",
                "a non-finite value in channel G of the texel at column 2, row 1");
  map = TestMap();
  map[3 * (0 * 4 + 3) + 2] = -0.5f;  // column 3, row 0, blue
  WriteImage(dir.File("negative.exr"), 4, 2, map);
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "negative.exr"})"), dir.Path()), "/environment/file",
                "a negative value -0.5 in channel B of the texel at column 3, row 0");
  map = TestMap();
  map[0] = std::numeric_limits<float>::infinity();
  WriteImage(dir.File("inf.exr"), 4, 2, map);
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "inf.exr"})"), dir.Path()), "/environment/file",
                "non-finite value in channel R of the texel at column 0, row 0");
  map = TestMap();
  map[3 * (1 * 4 + 1)] = 2e12f;
  WriteImage(dir.File("huge.exr"), 4, 2, map);
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "huge.exr"})"), dir.Path()), "/environment/file",
                "the value 2e+12 in channel R of the texel at column 1, row 1 (radiance must be finite");
  WriteImage(dir.File("black.exr"), 4, 2, std::vector<float>(24, 0.0f));
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "black.exr"})"), dir.Path()), "/environment/file",
                "black everywhere");
  // Bright texels are fine alone, not times an intensity past the bound.
  map = TestMap();
  map[0] = 1e11f;
  WriteImage(dir.File("bright.exr"), 4, 2, map);
  EXPECT_EQ(ErrorOf(WithSky(R"("environment": {"file": "bright.exr"})"), dir.Path()), "");
  ExpectErrorAt(ErrorOf(WithSky(R"("environment": {"file": "bright.exr", "intensity": 20})"), dir.Path()),
                "/environment/intensity", "beyond the limit of 1e12");
}

TEST(SequenceSky, LoadSequenceResolvesTheMapAgainstTheFilesDirectory) {
  // Through LoadSequence, relative map paths resolve against the sequence file's directory.
  TempDir dir;
  WriteImage(dir.File("sky.exr"), 4, 2, TestMap());
  const std::string seqPath = dir.File("seq.json");
  std::ofstream(seqPath) << WithSky(R"("environment": {"file": "sky.exr"})");
  EXPECT_EQ(LoadSequence(seqPath).environment.map.width, 4);
  std::ofstream(seqPath) << WithSky(R"("environment": {"file": "other.exr"})");
  try {
    LoadSequence(seqPath);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(seqPath + ":8:", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("error at /environment/file"), std::string::npos) << e.what();
  }
}

}  // namespace sequence_sky_test
}  // namespace restir
