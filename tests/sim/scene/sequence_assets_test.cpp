// An imported asset inside a sequence (sim/scene/sequence_assets.h): emissive triangles become lights, and those
// that cannot emit (no area) are skipped, counted, and reported by `validate`, not errors.
#include "sim/scene/sequence_assets.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/sim/asset_fixtures.h"
#include "sim/scene/sequence.h"
#include "tests/sim/sim_binary.h"

namespace restir {
namespace {

namespace fs = std::filesystem;

// One emissive mesh: a collinear triangle (zero area) and a good one; the glTF is written here, its buffer a
// base64 data: URI.
TEST(SequenceAssets, ZeroAreaEmitterIsSkippedCountedAndReported) {
  const fs::path dir = fs::path(::testing::TempDir()) / "restir_sequence_assets_zero_area";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Vec3 good[3] = {Vec3(0, 2, 0), Vec3(1, 2, 0), Vec3(0, 2, 1)};
  std::ofstream(dir / "emitter.gltf") << test::MakeGltf(
      {{"glow", Vec3(0.0f), Vec3(1.0f, 0.5f, 0.25f), 2.0f}},  // emissiveFactor within [0, 1], as glTF requires
      {{"panel", 0, {Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(2, 1, 0), good[0], good[1], good[2]}}});
  // No light of the sequence's own: the asset's emitter is its only light.
  std::ofstream(dir / "seq.json") << R"({
  "name": "zero_area",
  "resolution": [16, 9],
  "frames": 1,
  "materials": [{"name": "grey", "type": "diffuse", "albedo": [0.6, 0.6, 0.6]}],
  "objects": [
    {"name": "floor", "material": "grey", "shape": {"type": "quad", "center": [0, 0, 0], "u": [0, 0, 2], "v": [2, 0, 0]}},
    {"name": "lamp", "asset": {"file": "emitter.gltf"}}
  ],
  "lights": [],
  "camera": {"keyframes": [{"frame": 0, "position": [0, 1, 5], "lookAt": [0, 0.5, 0], "fov": 45}]}
})";
  const Sequence seq = LoadSequence((dir / "seq.json").string());
  EXPECT_EQ(seq.skippedZeroAreaEmitters, 1u);
  EXPECT_EQ(seq.skippedDarkEmitters, 0u);
  ASSERT_EQ(seq.lights.size(), 1u);
  const Light& light = seq.lights[0];
  EXPECT_EQ(light.name, "lamp/0:panel/emission");
  ASSERT_EQ(light.vertices.size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(light.vertices[k], good[k]) << "corner " << k;
  EXPECT_EQ(light.radiance, Vec3(2.0f, 1.0f, 0.5f));
  EXPECT_TRUE(light.triangleRadiance.empty());
  EXPECT_EQ(seq.objects.size(), 1u) << "an emissive mesh is all emitter: no object of its own";

  const test::ShellResult r = test::RunSim("validate " + (dir / "seq.json").string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("1 zero-area emissive triangles"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 emitter triangles"), std::string::npos) << r.output;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace restir
