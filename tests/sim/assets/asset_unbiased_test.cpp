// Closed forms through the asset importer (sim/assets/asset_import.h, sim/scene/sequence_assets.h): what a scene built
// from glTF / OBJ+MTL files renders must be what the same scene written as sequence primitives renders, and
// what Lambert's formula (core/polygon_irradiance.h) says, so that a bug in the importer's node transforms,
// emission strength, texture means, texture orientation or sRGB decoding shows up as a failed test. Every
// asset is written by the test itself into a scratch directory (glTF as text with its buffer inline as a
// base64 data: URI, PNGs with OpenImageIO), with expected values computed here in double precision, never
// with sim/'s own helpers (tests/sim/assets/asset_scene_writer.h).
//
// UnbiasedPresetsMatchReferenceOnImportedScene: a glTF of 2,025 small emissive triangles in four materials
//    (one with an emissive palette texture, so colours vary per triangle) over a floor, with a glossy layered
//    box (metallic 1, roughness 0.3) and a base-colour-textured board from the same asset. Every unbiased
//    preset's frame mean (K = 192 seeds × frames 0-3) against the reference (4096 spp), per pixel on
//    luminance: z = (mean − ref) / sqrt(se_mean² + se_ref²), Welch's statistic with between 15 (the
//    reference's replicates) and 206 dof, so E z² ∈ [1, 15/13] and its tail is at most t15's. Claims: the
//    mean over 16×16 blocks of the blocks' mean z² within [1 − band, 15/13 + band], band =
//    q·sqrt(3.389/blocks), q the normal quantile of 1e-4 two-sided (blocks as units, as closed_form_test does
//    for spatial reuse; false-failure rate ≤ 1e-4); max |z| below the t15 quantile of 1e-3/pixels (≤ 1e-3);
//    the luma ratio Σ mean / Σ ref − 1 (the metric luma_ratio) within a t-test at 1e-3 (191 dof; standard
//    error from the seeds' spread and the reference's replicates), at most 0.25%, and its standard error
//    below a third of that (so the bound can fail); the same t-test per object (floor, gold box, board: at
//    1e-3 each), so that a bias confined to the glossy or the textured object is not diluted by the floor.
//    Per preset at most 5.1e-3. Why 0.25% and not closed_form_test's 0.1%: with 2,025 lights the presets'
//    frame means vary by ~0.9% of the image per seed (ReSTIR; 0.5% for ris), so 0.1% would need ~750 seeds,
//    minutes of CPU; K = 192 gives standard errors of 0.036% (ris) to 0.074%.
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
// Proof 3: the unbiased presets on an imported scene of many emissive triangles.

// splitmix64: the same numbers on every platform (std::uniform_real_distribution is not specified bit for
// bit).
struct SplitMix {
  uint64_t s;
  double Next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return double((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  }
};

// The asset: 45 × 45 emissive triangles (4-5 cm) at 1.5-1.8 m, facing down within 40°, in four materials (one
// with an 8×8 emissive palette texture, each triangle's UVs near one texel's centre); a glossy gold box
// (metallic 1, roughness 0.3) and a board with a base-colour checker texture (dielectric, roughness 0.7).
void WriteManyLightsAsset(const fs::path& dir) {
  Gltf g;
  SplitMix rng{20240611};
  {
    std::vector<uint8_t> palette;
    for (int k = 0; k < 64 * 3; ++k) palette.push_back(static_cast<uint8_t>(60 + 195 * rng.Next()));
    WritePng(dir / "palette.png", 8, 8, palette);
    std::vector<uint8_t> checker;
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const bool dark = (x + y) % 2;
        const uint8_t c[3] = {uint8_t(dark ? 40 : 230), uint8_t(dark ? 90 : 210), uint8_t(dark ? 160 : 120)};
        checker.insert(checker.end(), c, c + 3);
      }
    WritePng(dir / "checker.png", 8, 8, checker);
  }
  const int palette = g.Texture("palette.png"), checker = g.Texture("checker.png");
  const D3 factors[4] = {{1.0, 0.6, 0.3}, {0.3, 0.6, 1.0}, {0.9, 0.9, 0.9}, {1.0, 1.0, 1.0}};
  const double strengths[4] = {60.0, 50.0, 40.0, 70.0};
  std::vector<D3> positions[4];
  std::vector<glm::dvec2> st[4];
  constexpr int kSide = 45;
  for (int j = 0; j < kSide; ++j)
    for (int i = 0; i < kSide; ++i) {
      const int m = (i + 2 * j) % 4;
      const D3 centre(-1.6 + 3.2 * (i + 0.2 + 0.6 * rng.Next()) / kSide, 1.5 + 0.3 * rng.Next(),
                      -1.8 + 3.0 * (j + 0.2 + 0.6 * rng.Next()) / kSide);
      // A frame whose third axis is the emitting direction: down, tilted by up to 40° towards a random
      // azimuth.
      const double tilt = glm::radians(40.0) * rng.Next(), azimuth = 2 * M_PI * rng.Next(),
                   spin = 2 * M_PI * rng.Next();
      const D3 n(std::sin(tilt) * std::cos(azimuth), -std::cos(tilt), std::sin(tilt) * std::sin(azimuth));
      const D3 a = glm::normalize(glm::cross(n, D3(0, 0, 1))), b = glm::cross(n, a);  // a × b = n
      const double size = 0.04 + 0.01 * rng.Next();
      for (int k = 0; k < 3; ++k) {
        const double angle = spin + 2 * M_PI * k / 3;
        positions[m].push_back(centre + size * (std::cos(angle) * a + std::sin(angle) * b));
      }
      const glm::dvec2 texel((std::floor(8 * rng.Next()) + 0.5) / 8, (std::floor(8 * rng.Next()) + 0.5) / 8);
      st[m].insert(st[m].end(), {texel + glm::dvec2(-0.01, 0.01), texel + glm::dvec2(0.01, 0.01),
                                 texel + glm::dvec2(0, -0.01)});
    }
  Json primitives = Json::array();
  for (int m = 0; m < 4; ++m) {
    Json mat = {
        {"name", "lamp" + std::to_string(m)},
        {"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}, {"metallicFactor", 0.0}}},
        {"emissiveFactor", J(factors[m])},
        {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", strengths[m]}}}}}};
    if (m == 3) mat["emissiveTexture"] = {{"index", palette}};
    std::vector<uint32_t> indices(positions[m].size());
    for (size_t k = 0; k < indices.size(); ++k) indices[k] = static_cast<uint32_t>(k);
    primitives.push_back(Gltf::Primitive(g.Positions(positions[m]), g.Indices(indices), g.Material(mat),
                                         m == 3 ? g.Texcoords(st[m]) : -1));
  }
  std::vector<int> roots = {g.Node({{"name", "lamps"}, {"mesh", g.Mesh(primitives)}})};

  // The gold box, 0.5 × 0.35 × 0.4, turned 30° about y by its node; flat (no normals).
  {
    std::vector<D3> p;
    for (int k = 0; k < 8; ++k)
      p.push_back(D3((k & 1) ? 0.25 : -0.25, (k & 2) ? 0.35 : 0.0, (k & 4) ? 0.2 : -0.2));
    const uint32_t faces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                  {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    std::vector<uint32_t> indices;
    for (const auto& f : faces) indices.insert(indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
    const int gold = g.Material(
        {{"name", "gold"},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {1.0, 0.78, 0.34, 1.0}}, {"metallicFactor", 1.0}, {"roughnessFactor", 0.3}}}});
    const int mesh = g.Mesh(Json::array({Gltf::Primitive(g.Positions(p), g.Indices(indices), gold)}));
    const glm::dvec4 q = Quaternion({0, 1, 0}, 30.0);
    roots.push_back(g.Node({{"name", "gold"},
                            {"mesh", mesh},
                            {"translation", {-0.5, 0.0, -0.4}},
                            {"rotation", {q.x, q.y, q.z, q.w}}}));
  }
  // The board: a 0.7 m square tilted 50° from the floor, checker base colour tiled twice.
  {
    const std::vector<D3> p = {
        {-0.35, 0, 0},
        {0.35, 0, 0},
        {0.35, 0.7 * std::sin(glm::radians(50.0)), -0.7 * std::cos(glm::radians(50.0))},
        {-0.35, 0.7 * std::sin(glm::radians(50.0)), -0.7 * std::cos(glm::radians(50.0))}};
    const std::vector<glm::dvec2> uv = {{0, 2}, {2, 2}, {2, 0}, {0, 0}};
    const int board = g.Material({{"name", "board"},
                                  {"pbrMetallicRoughness",
                                   {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}},
                                    {"baseColorTexture", {{"index", checker}}},
                                    {"metallicFactor", 0.0},
                                    {"roughnessFactor", 0.7}}}});
    const int mesh = g.Mesh(Json::array(
        {Gltf::Primitive(g.Positions(p), g.Indices({0, 1, 2, 0, 2, 3}), board, g.Texcoords(uv))}));
    roots.push_back(g.Node({{"name", "board"}, {"mesh", mesh}, {"translation", {0.55, 0.05, -0.2}}}));
  }
  WriteText(dir / "scene.gltf", g.Text(roots));
}

// "<object> (<material>)", the material's name without the asset's prefix.
std::string ObjectLabel(const Sequence& seq, size_t o) {
  const std::string& m = seq.materials[seq.objects[o].material].name;
  return seq.objects[o].name + " (" + m.substr(m.find(':') == std::string::npos ? 0 : m.find(':') + 1) + ")";
}

TEST(AssetClosedForm, UnbiasedPresetsMatchReferenceOnImportedScene) {
  const auto start = std::chrono::steady_clock::now();
  const Scratch scratch("many_lights");
  const fs::path& dir = *scratch;
  WriteManyLightsAsset(dir);
  constexpr int kSize = 64, kSeeds = 192, kFrames = 4, kBlock = 16;
  const Json scene = {
      {"name", "many_lights"},
      {"resolution", {kSize, kSize}},
      {"frames", kFrames},
      {"materials", Json::array({{{"name", "floor"}, {"type", "diffuse"}, {"albedo", {0.6, 0.55, 0.5}}}})},
      {"objects",
       {{{"name", "floor"},
         {"material", "floor"},
         {"shape", {{"type", "quad"}, {"center", {0, 0, 0}}, {"u", {5, 0, 0}}, {"v", {0, 0, -5}}}}},
        {{"name", "asset"},
         {"asset", {{"file", "scene.gltf"}}},
         {"keyframes", Json::array({Key{{0.05, 0, 0.1}, {0, 10, 0}, D3(1.0)}.ToJson()})}}}},
      {"lights", Json::array()},
      {"camera", CameraJson({0, 0.9, 2.0}, {0, 0.1, -0.4}, 55.0)}};
  const Sequence seq = Load(dir, "many_lights", scene);
  size_t emitters = 0;
  for (const Light& l : seq.lights) emitters += l.vertices.size() / 3;
  ASSERT_EQ(emitters, 2025u);
  ASSERT_EQ(seq.textures.size(), 1u);  // the board's (the palette is an emission texture, averaged at import)
  bool glossy = false;
  for (const Material& m : seq.materials)
    glossy = glossy || (m.type == MaterialType::kLayered && m.metallic == 1.0f && m.roughness == 0.3f);
  ASSERT_TRUE(glossy);

  GBuffer g;
  const ReferenceImage ref = Reference(seq, 4096, &g);
  std::vector<int> objectPixels(seq.objects.size(), 0);
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i)) ++objectPixels[size_t(g.objectId[i])];
  std::printf("reference %.1f s, mean relative standard error %.3f%%; pixels per object:", ref.ms / 1000.0,
              100.0 * MeanRelativeStandardError(ref));
  for (size_t o = 0; o < seq.objects.size(); ++o)
    std::printf(" %s %d", ObjectLabel(seq, o).c_str(), objectPixels[o]);
  std::printf("\n");
  for (int n : objectPixels) EXPECT_GT(n, 150);  // the floor, the gold box and the board are all in view

  // Welch's z: E z² in [1, 15/13], Var z² at most t15's, tails at most t15's (its dof lie between the
  // reference's 15 and 15 + K - 1). The luma ratio's bound: 0.25% (K = 192 seeds resolve ~0.07% here; see the
  // file comment).
  const Claims welch{1.0,   test::StudentTSquaredMean(15), test::StudentTSquaredVariance(15), 15, kSeeds - 1,
                     2.5e-3};
  const double tObject = test::StudentTQuantileTwoSided(1e-3, kSeeds - 1);
  for (const char* name : {"ris", "restir-unbiased", "restir-balance", "restir-spmis"}) {
    const Preset* preset = FindPreset(name);
    ASSERT_NE(preset, nullptr) << name;
    PipelineSettings settings = preset->settings;
    settings.spatial.radius =
        4.0f;  // reuse stays within a 16 × 16 block's neighbourhood (the RMS test's units)
    settings.spatial.stochastic.cellSearchRadius = 4.0f / kSize;  // 4 px (in image heights)
    FrameLoop driver(seq, kSize, kSize);
    std::vector<Pipeline> pipelines(kSeeds, Pipeline(settings));
    std::vector<std::vector<double>> luma(kSeeds,
                                          std::vector<double>(g.Size(), 0.0));  // per seed, frame mean
    driver.Play(0, kFrames, [&](int frame) {
      ASSERT_EQ(driver.Gbuffer().posX, g.posX);
      for (int s = 0; s < kSeeds; ++s) {
        const FrameResult fr = driver.Render(pipelines[s], 9100u + static_cast<uint32_t>(s));
        for (size_t i = 0; i < g.Size(); ++i) luma[s][i] += Luminance(fr.image.pixels[i]) / kFrames;
      }
    });
    if (::testing::Test::HasFatalFailure()) return;  // the ASSERT above ends only its frame's body
    Verdict v;
    const int bw = kSize / kBlock;
    std::vector<double> blockZ2(bw * bw, 0.0);
    std::vector<int> blockCount(bw * bw, 0);
    // Per object (and, last, the whole image): per seed Σ luma, Σ ref, Σ se_ref².
    const size_t objects = seq.objects.size();
    std::vector<std::vector<double>> seedSums(objects + 1, std::vector<double>(kSeeds, 0.0));
    std::vector<double> refSum(objects + 1, 0.0), refVar(objects + 1, 0.0);
    for (size_t i = 0; i < g.Size(); ++i) {
      if (!g.IsSurface(i)) continue;
      const double r = Luminance(ref.mean.pixels[i]), se = ref.lumaStandardError[i];
      test::RunningStats stats;
      for (int s = 0; s < kSeeds; ++s) {
        stats.Add(luma[s][i]);
        for (size_t o : {size_t(g.objectId[i]), objects}) seedSums[o][s] += luma[s][i];
      }
      for (size_t o : {size_t(g.objectId[i]), objects}) refSum[o] += r, refVar[o] += se * se;
      const double denom = std::sqrt(stats.StdError() * stats.StdError() + se * se);
      if (denom == 0.0) {  // every seed and replicate agreed: only an unlit pixel may
        EXPECT_EQ(stats.mean, 0.0) << "pixel " << i;
        EXPECT_EQ(r, 0.0) << "pixel " << i;
        continue;
      }
      const double z = (stats.mean - r) / denom;
      v.meanZ2 += z * z;
      if (std::fabs(z) > v.maxAbsZ) {
        v.maxAbsZ = std::fabs(z);
        char buf[200];
        std::snprintf(buf, sizeof buf, "pixel (%zu, %zu) object %d: %s %.6g +- %.2g, reference %.6g +- %.2g",
                      i % g.width, i / g.width, g.objectId[i], name, stats.mean, stats.StdError(), r, se);
        v.worst = buf;
      }
      ++v.pixels;
      const size_t b = (i / g.width) / kBlock * bw + (i % g.width) / kBlock;
      blockZ2[b] += z * z, blockCount[b] += 1;
    }
    v.meanZ2 /= std::max(1, v.pixels);
    double blockMean = 0.0;
    int blocks = 0;
    for (size_t b = 0; b < blockZ2.size(); ++b)
      if (blockCount[b] > 0) blockMean += blockZ2[b] / blockCount[b], ++blocks;
    blockMean /= std::max(1, blocks);
    // The luma ratio Σ mean / Σ ref − 1 and its standard error (delta method: the seeds' spread of the sum
    // and the reference's replicates, independent).
    auto ratio = [&](size_t o, double& value, double& stdError) {
      test::RunningStats sums;
      for (double x : seedSums[o]) sums.Add(x);
      value = sums.mean / refSum[o] - 1.0;
      stdError = std::sqrt(sums.StdError() * sums.StdError() + refVar[o]) / refSum[o];
    };
    ratio(objects, v.relativeError, v.relativeStdError);
    std::printf("%s: pixel RMS z %.3f; luma ratio - 1 per object:", name, std::sqrt(v.meanZ2));
    for (size_t o = 0; o < objects; ++o) {
      double value, stdError;
      ratio(o, value, stdError);
      std::printf(" %s %+.3f%% (se %.3f%%)", ObjectLabel(seq, o).c_str(), 100.0 * value, 100.0 * stdError);
      EXPECT_LE(std::fabs(value), tObject * stdError)
          << name << ", " << ObjectLabel(seq, o) << ": luma ratio, t-test";
    }
    std::printf("\n");
    ExpectAgreement(v, blockMean, blocks, welch, std::string(name) + ", whole image");
  }
  std::printf("%.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace
}  // namespace restir
