// Closed forms through the asset importer (sim/assets/asset_import.h, sim/scene/sequence_assets.h): what a scene built
// from glTF / OBJ+MTL files renders must be what the same scene written as sequence primitives renders, and
// what Lambert's formula (core/polygon_irradiance.h) says, so that a bug in the importer's node transforms,
// emission strength, texture means, texture orientation or sRGB decoding shows up as a failed test. Every
// asset is written by the test itself into a scratch directory (glTF as text with its buffer inline as a
// base64 data: URI, PNGs with OpenImageIO), with expected values computed here in double precision, never
// with sim/'s own helpers (tests/sim/assets/asset_scene_writer.h).
//
// TexturedPlaneIsTextureTimesUntexturedReference: an OBJ plane with an MTL of Ks 0 (pure Lambert, albedo
//    Kd × texel) and map_Kd a 128×128 8-bit sRGB PNG of 8×8 uniform blocks whose colours encode the block's
//    column and row, under a sequence quad light, against the same plane without map_Kd. Per pixel whose UV
//    (from the world hit point through the inverse of the plane's known placement and its UV layout, in
//    double) is more than 1.5 texels from a block boundary: ref_textured = sRGBdecode(block) × ref_untextured
//    within 1e-5 relative per channel. Deterministic: both references draw the same random numbers and sample
//    counts (same frame state; the pilot's relative variance does not depend on the albedo), and the
//    estimator is linear in the albedo; not bit for bit, since each sample's product is rounded with the
//    texel inside it (measured: 3.9e-7 at most). Grid: tilted towards the light; rotated, non-uniformly
//    scaled and 1000 m from the origin.
// Seeds are fixed, so every outcome is deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "asset_scene_writer.h"
#include "core/polygon_irradiance.h"
#include "sim/run/frame_loop.h"
#include "sim/estimator/presets.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"
#include "stats.h"

namespace restir {
namespace {

using namespace test;  // asset_scene_writer.h

// -----------------------------------------------------------------------------------------------------------
// Proof 2: a textured OBJ plane.

constexpr int kTextureSide = 128, kBlocks = 8, kBlockTexels = kTextureSide / kBlocks;

// Block (bx, by), bx counted from the image's left, by from its top: red encodes the column, green the row,
// blue both, so any flip or swap of u and v reads a block of another colour.
void BlockColour(int bx, int by, uint8_t rgb[3]) {
  rgb[0] = static_cast<uint8_t>(20 + 30 * bx);
  rgb[1] = static_cast<uint8_t>(25 + 31 * by);
  rgb[2] = static_cast<uint8_t>(230 - 11 * bx - 17 * by);
}

struct PlaneCase {
  std::string name;
  Key key;
  D3 lightCentre, cameraPosition, lookAt;
};

TEST(AssetClosedForm, TexturedPlaneIsTextureTimesUntexturedReference) {
  const auto start = std::chrono::steady_clock::now();
  const Scratch scratch("plane");
  const fs::path& dir = *scratch;
  {
    std::vector<uint8_t> rgb;
    for (int y = 0; y < kTextureSide; ++y)
      for (int x = 0; x < kTextureSide; ++x) {
        uint8_t c[3];
        BlockColour(x / kBlockTexels, y / kBlockTexels, c);
        rgb.insert(rgb.end(), c, c + 3);
      }
    WritePng(dir / "blocks.png", kTextureSide, kTextureSide, rgb);
  }
  // The plane: local y = 0, x and z in [-1, 1]; u = (x + 1) / 2 to the right, v = (1 − z) / 2 (OBJ's vt, v
  // up). Ks 0: the layered material's specular share is 0, so the BSDF is Lambert with albedo Kd × texel.
  const std::string geometry =
      "v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
      "usemtl plane\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  WriteText(dir / "textured.obj", "mtllib textured.mtl\n" + geometry);
  WriteText(dir / "plain.obj", "mtllib plain.mtl\n" + geometry);
  WriteText(dir / "textured.mtl", "newmtl plane\nKd 0.9 0.9 0.9\nKs 0 0 0\nmap_Kd blocks.png\n");
  WriteText(dir / "plain.mtl", "newmtl plane\nKd 0.9 0.9 0.9\nKs 0 0 0\n");

  const D3 far = Far(1000.0);
  const std::vector<PlaneCase> grid = {{"tilted 30 deg towards the light",
                                        {{0, 0, 0}, {30, 0, 0}, D3(1.0)},
                                        {0, 1.6, 1.0},
                                        {0, 1.25, 1.75},
                                        {0, 0, 0}},
                                       {"rotated, non-uniformly scaled, 1000 m from the origin",
                                        {far, {25, 60, 10}, {1.3, 1.0, 0.8}},
                                        far + D3(0.6, 1.5, 0.4),
                                        far + D3(1.0, 1.25, 0.8),
                                        far}};
  for (const PlaneCase& c : grid) {
    SCOPED_TRACE(c.name);
    Sequence scenes[2];
    for (int textured = 0; textured < 2; ++textured) {
      const std::string name = textured ? "textured" : "plain";
      const Json seq = {{"name", name},
                        {"resolution", {64, 64}},
                        {"frames", 1},
                        {"materials", Json::array()},
                        {"objects", Json::array({{{"name", "plane"},
                                                  {"asset", {{"file", name + ".obj"}}},
                                                  {"keyframes", Json::array({c.key.ToJson()})}}})},
                        {"lights", Json::array({{{"name", "lamp"},
                                                 {"type", "quad"},
                                                 {"center", J(c.lightCentre)},
                                                 {"u", {0.3, 0, 0}},
                                                 {"v", {0, 0, 0.3}},
                                                 {"color", {1.0, 0.9, 0.8}},
                                                 {"intensity", 6.0}}})},
                        {"camera", CameraJson(c.cameraPosition, c.lookAt, 55.0)}};
      scenes[textured] = Load(dir, name, seq);
    }
    ASSERT_EQ(scenes[1].textures.size(), 1u);
    ASSERT_EQ(scenes[0].textures.size(), 0u);
    GBuffer g[2];
    const ReferenceImage plain = Reference(scenes[0], 1024, &g[0]);
    const ReferenceImage textured = Reference(scenes[1], 1024, &g[1]);
    ASSERT_EQ(g[0].posX, g[1].posX);
    // The same frame state, so the same random numbers; the pilot's relative variances do not depend on the
    // albedo, so every pixel takes the same number of samples.
    EXPECT_EQ(plain.pixelSamples, textured.pixelSamples);

    const Affine toWorld = c.key.Matrix();
    const glm::dmat3 inverse = glm::inverse(toWorld.a);
    int checked = 0, exact = 0, surface = 0, bad = 0;
    double worst = 0.0, worstPlane = 0.0;
    std::vector<int> blockSeen(kBlocks * kBlocks, 0);
    for (size_t i = 0; i < g[1].Size(); ++i) {
      if (!g[1].IsSurface(i)) continue;
      ++surface;
      const D3 local = inverse * (D3(g[1].Position(i)) - toWorld.t);
      worstPlane = std::max(worstPlane, std::fabs(local.y));
      const double u = (local.x + 1.0) / 2.0, v = (1.0 - local.z) / 2.0;
      // Texel coordinates from the image's left and top: v = 1 is the top row.
      const double tx = u * kTextureSide, ty = (1.0 - v) * kTextureSide;
      const int bx = static_cast<int>(std::floor(tx / kBlockTexels)),
                by = static_cast<int>(std::floor(ty / kBlockTexels));
      const double mx = tx - bx * kBlockTexels, my = ty - by * kBlockTexels;
      if (bx < 0 || bx >= kBlocks || by < 0 || by >= kBlocks) continue;
      if (std::min(mx, kBlockTexels - mx) <= 1.5 || std::min(my, kBlockTexels - my) <= 1.5) continue;
      uint8_t colour[3];
      BlockColour(bx, by, colour);
      const D3 texel = SrgbDecode(colour);
      bool allExact = true;
      for (int ch = 0; ch < 3; ++ch) {
        const double expected = texel[ch] * plain.mean.pixels[i][ch];
        const double got = textured.mean.pixels[i][ch];
        const double relative = std::fabs(got - expected) / expected;
        worst = std::max(worst, relative);
        allExact = allExact && got == static_cast<float>(texel[ch]) * plain.mean.pixels[i][ch];
        if (!(relative <= 1e-5) && ++bad <= 5)
          ADD_FAILURE() << "pixel (" << i % 64 << ", " << i / 64 << ") block (" << bx << ", " << by
                        << ") channel " << ch << ": textured " << got << ", expected " << expected
                        << " (relative difference " << relative << ")";
      }
      exact += allExact;
      ++checked;
      ++blockSeen[by * kBlocks + bx];
    }
    const int blocks =
        static_cast<int>(std::count_if(blockSeen.begin(), blockSeen.end(), [](int n) { return n > 0; }));
    std::printf(
        "%-56s %d surface pixels, %d checked in %d of 64 blocks: largest relative difference %.3g, %d "
        "pixels bit-exact (texel x untextured in float); hit points within %.2g m of the plane\n",
        c.name.c_str(), surface, checked, blocks, worst, exact, worstPlane);
    EXPECT_EQ(bad, 0) << "pixel channels beyond 1e-5 (the first 5 shown)";
    EXPECT_GT(checked, 1500);
    EXPECT_GE(blocks, 48);
    EXPECT_LT(worstPlane, 1e-3);
  }
  std::printf("%.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace
}  // namespace restir
