// Closed forms through the asset importer (sim/assets/asset_import.h, sim/scene/sequence_assets.h): what a scene built
// from glTF / OBJ+MTL files renders must be what the same scene written as sequence primitives renders, and
// what Lambert's formula (core/polygon_irradiance.h) says, so that a bug in the importer's node transforms,
// emission strength, texture means, texture orientation or sRGB decoding shows up as a failed test. Every
// asset is written by the test itself into a scratch directory (glTF as text with its buffer inline as a
// base64 data: URI, PNGs with OpenImageIO), with expected values computed here in double precision, never
// with sim/'s own helpers (tests/sim/assets/asset_scene_writer.h).
//
// EmissiveQuadMatchesSequenceLightAndLambert: a glTF whose only mesh is an emissive quad (emissiveFactor ×
//    KHR_materials_emissive_strength, optionally × an emissive texture), placed by the sequence's keyframe
//    (and in some cases a glTF node hierarchy), above a diffuse floor. Per configuration:
//    - the imported light triangles equal the world vertices computed here (within 8 float ulps of the
//      largest coordinate), each counter-clockwise seen from the front glTF 2.0 gives it (section 3.7.4: the
//      file's order, reversed under a node whose global transform mirrors), that front computed here from the
//      transforms and never from the imported winding, with the radiance computed here (1e-6 relative);
//    - (a) the reference equals the reference of the same scene with a sequence quad light ("type": "quad",
//      centre, u and v computed here): one floor object and one light either way, so the same frame state and
//      the same random numbers. Where the two paths give the same float triangles the images must be
//      identical bit for bit (claimed for every configuration where they do, and required of the one whose
//      transforms are exact in binary floating point); elsewhere the paths round the corners differently
//      (Assimp bakes the node matrices, AddAsset applies the keyframe's, the reader adds c ± u ± v) or the
//      radiance (the texture mean), and the images agree to rounding: every pixel takes the same sample
//      count, and differs by at most 1e-6 of the brightest pixel, and by at most 1e-5 relative where it is
//      above 1% of it (near the emitter's plane a rounding of the plane's tilt is a larger share of a small
//      value);
//    - (b) per pixel and channel, the reference against Lambert's closed form on the scene's light triangles
//      (each clipped to the floor's horizon, lighting only the side of the front computed here) × albedo/π,
//      with the radiance computed here. z = (ref − closed
//      form) / ref standard error is Student t with 15 dof (16 replicates). Three claims per channel, as
//      tests/sim/reference/closed_form_test.cpp makes them: mean z² within 15/13 ± q·sqrt(3.389/pixels), q the normal
//      quantile of 1e-4 two-sided (false-failure rate 1e-4); max |z| below the t15 quantile of 1e-3/pixels
//      (Bonferroni, at most 1e-3); the mean relative error over lit pixels at most 0.1% and within a z-test
//      at 1e-3 of 0 (its standard error, with pixels independent, is known: the reference's), the reference's
//      own relative standard error below a third of 0.1% (so the claim can fail). Per channel at most 2.1e-3,
//      per configuration at most 6.3e-3 (the channels share samples; the union bound holds regardless).
//      Pixels within two float spacings of an emitter's plane are left out (CompareWithLambert says why; at
//      most 8).
//    The grid: binary-exact transforms through a node hierarchy (bit-identity), tilted 40°, tilted 75° 1000 m
//    from the origin, tiny 1 cm tilted 30°, tiny 1 cm 1000 m from the origin, huge 100 m at 100 m, a node
//    hierarchy (parent translation, child rotation and non-uniform scale) under a rotated, non-uniformly
//    scaled keyframe, nodes mirrored in x and (non-uniformly, 1000 m from the origin) in z, a node scaled −1 on
//    two axes (a half turn: no mirror), a uniform 4×4 sRGB emissive texture, and a four-quadrant emissive
//    texture whose two triangles read two diagonal quadrants (each triangle's mean is one colour exactly; a
//    flipped u or v would read another). The mirroring cases have (b) only: see (a).
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
// Proof 1: an emissive quad from glTF.

constexpr double kFloorAlbedo = 0.5;

enum class EmissionTexture { kNone, kUniform, kQuadrants };

struct EmitterCase {
  std::string name;
  Key key;                 // the sequence object's keyframe
  bool hierarchy = false;  // a parent node (translation) with a child node (rotation, scale) holding the mesh
  D3 parentTranslation{0.0};
  D3 childAxis{0, 1, 0};
  double childDegrees = 0.0;
  D3 childScale{1.0};
  D3 emissiveFactor{1.0};
  double strength = 7.5;  // KHR_materials_emissive_strength
  EmissionTexture texture = EmissionTexture::kNone;
  D3 origin{0.0};               // where the floor and the view are (the "far from the origin" offset)
  D3 view{0.3, 0, 0};           // the floor point the camera looks at, from origin
  double cameraDistance = 2.6;  // camera at view + (0, d, d/2)
  bool exact = false;           // every transform exact in binary floating point: bit-identity is claimed
};

std::vector<EmitterCase> EmitterGrid() {
  std::vector<EmitterCase> out;
  {
    // Dyadic numbers, quarter turns and a half-turn quaternion: every float operation on the way is exact.
    EmitterCase c;
    c.name = "exact transforms through a node hierarchy";
    c.key = {{0.25, 0.5, -0.125}, {0, 90, 0}, {0.125, 0.125, 0.25}};
    c.hierarchy = true;
    c.parentTranslation = {0.5, 0.0, -0.25};
    c.childAxis = {0, 1, 0};
    c.childDegrees = 180.0;
    c.childScale = {1.0, 1.0, 0.5};
    c.emissiveFactor = {1.0, 0.75, 0.5};
    c.exact = true;
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "tilted 40 deg";
    c.key = {{0, 0.5, 0}, {0, 0, 40}, D3(0.15)};
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "tilted 75 deg, 1000 m from the origin";
    c.origin = Far(1000.0);
    c.key = {c.origin + D3(0, 0.5, 0), {10, 30, 75}, D3(0.15)};
    c.emissiveFactor = {0.9, 1.0, 0.6};
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "tiny 1 cm, tilted 30 deg";
    c.key = {{0.3, 0.15, 0}, {30, 0, 0}, D3(0.005)};
    c.strength = 2000.0;
    c.cameraDistance = 0.6;
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "tiny 1 cm, 1000 m from the origin";
    c.origin = Far(1000.0);
    c.key = {c.origin + D3(0.3, 0.15, 0), {0, 20, -25}, D3(0.005)};
    c.strength = 2000.0;
    c.cameraDistance = 0.6;
    out.push_back(c);
  }
  {
    // 100 m square, centre 100 m from the view, facing it: it emits along Rz(-53.13°)·(0, -1, 0), that is
    // -(0.8, 0.6, 0).
    EmitterCase c;
    c.name = "huge 100 m, 100 m away";
    c.key = {{80, 60, 0}, {0, 0, -glm::degrees(std::asin(0.8))}, D3(50.0)};
    c.strength = 0.75;
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "node hierarchy, rotated and non-uniformly scaled";
    c.key = {{0.1, 0.3, 0.05}, {0, 25, 0}, {0.2, 0.2, 0.12}};
    c.hierarchy = true;
    c.parentTranslation = {0.3, 0.2, -0.2};
    c.childAxis = {1, 0, 1};
    c.childDegrees = 35.0;
    c.childScale = {1.5, 1.0, 0.75};
    c.emissiveFactor = {1.0, 0.8, 0.9};
    out.push_back(c);
  }
  // Mirroring nodes (glTF 2.0 section 3.7.4: a negative determinant makes the front faces clockwise). In each the
  // front, as the test computes it, faces the floor: an importer that kept the file's winding would light
  // nothing, or the other way round.
  {
    EmitterCase c;
    c.name = "node mirrored in x, turned 20 deg about z";
    c.key = {{0.1, 0.5, 0}, {0, 15, 0}, D3(0.15)};
    c.hierarchy = true;
    c.parentTranslation = {0.2, 0.1, 0.0};
    c.childAxis = {0, 0, 1};
    c.childDegrees = 20.0;
    c.childScale = {-1.0, 1.0, 0.8};
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "node mirrored in z, non-uniform, turned 35 deg about (1, 0, 1), 1000 m from the origin";
    c.origin = Far(1000.0);
    c.key = {c.origin + D3(0, 0.45, 0), {0, -30, 0}, D3(0.15)};
    c.hierarchy = true;
    c.childAxis = {1, 0, 1};
    c.childDegrees = 35.0;
    c.childScale = {1.2, 1.0, -0.6};
    c.emissiveFactor = {0.8, 1.0, 0.7};
    out.push_back(c);
  }
  {
    // Two negative scales make a half turn, not a mirror: the winding stays, and the keyframe's half turn
    // about x brings the front (now up) back down to the floor.
    EmitterCase c;
    c.name = "node scaled -1 on x and y (a half turn), keyframe turned over";
    c.key = {{0, 0.5, 0.1}, {180, 0, 0}, D3(0.15)};
    c.hierarchy = true;
    c.childScale = {-1.0, -1.0, 1.0};
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "uniform emissive texture";
    c.key = {{0, 0.5, 0}, {0, 0, 30}, D3(0.15)};
    c.emissiveFactor = {0.9, 1.0, 0.8};
    c.texture = EmissionTexture::kUniform;
    out.push_back(c);
  }
  {
    EmitterCase c;
    c.name = "four-quadrant emissive texture, 10 m from the origin";
    c.origin = Far(10.0);
    c.key = {c.origin + D3(0, 0.5, 0), {-20, 0, 30}, D3(0.15)};
    c.texture = EmissionTexture::kQuadrants;
    out.push_back(c);
  }
  return out;
}

// The local quad: corners c ± u ± v with c = 0, u = x̂, v = ẑ (the sequence quad light's layout), emitting
// towards cross(u, v) = −ŷ; triangles (0, 1, 2) and (0, 2, 3), counter-clockwise seen from the emitting side.
const D3 kLocalCorners[4] = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};

// Emission texture colours (8-bit sRGB): uniform, and the four quadrants top-left, top-right, bottom-left,
// bottom-right of a 4×4 image.
const uint8_t kUniformTexel[3] = {200, 150, 90};
const uint8_t kQuadrant[4][3] = {{255, 40, 10}, {30, 200, 60}, {90, 90, 250}, {240, 230, 30}};

// Writes the case's glTF (and texture); returns the expected radiance of its two triangles.
std::vector<D3> WriteEmitterAsset(const EmitterCase& c, const fs::path& dir) {
  Gltf g;
  Json material = {
      {"name", "lamp"},
      {"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}, {"metallicFactor", 0.0}}},
      {"emissiveFactor", J(c.emissiveFactor)},
      {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", c.strength}}}}}};
  const D3 base = c.emissiveFactor * c.strength;
  std::vector<D3> radiance(2, base);
  std::vector<D3> positions(kLocalCorners, kLocalCorners + 4);
  std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  std::vector<glm::dvec2> st;
  if (c.texture == EmissionTexture::kUniform) {
    WritePng(dir / "emission.png", 4, 4, [] {
      std::vector<uint8_t> rgb;
      for (int k = 0; k < 16; ++k) rgb.insert(rgb.end(), kUniformTexel, kUniformTexel + 3);
      return rgb;
    }());
    st = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    radiance.assign(2, base * SrgbDecode(kUniformTexel));
  } else if (c.texture == EmissionTexture::kQuadrants) {
    std::vector<uint8_t> rgb;
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x)
        rgb.insert(rgb.end(), kQuadrant[(y / 2) * 2 + x / 2], kQuadrant[(y / 2) * 2 + x / 2] + 3);
    WritePng(dir / "emission.png", 4, 4, rgb);
    // Unshared corners: triangle 0 reads the top-left quadrant only, triangle 1 the bottom-right (glTF's t
    // grows downwards); both stay 0.15 texel-widths inside their quadrant's texel centres, so the bilinear
    // filter never reaches another quadrant, nor wraps. A flipped u or v would read the top-right or
    // bottom-left colour.
    positions = {kLocalCorners[0], kLocalCorners[1], kLocalCorners[2],
                 kLocalCorners[0], kLocalCorners[2], kLocalCorners[3]};
    indices = {0, 1, 2, 3, 4, 5};
    st = {{0.15, 0.35}, {0.35, 0.35}, {0.35, 0.15}, {0.65, 0.85}, {0.85, 0.65}, {0.65, 0.65}};
    radiance = {base * SrgbDecode(kQuadrant[0]), base * SrgbDecode(kQuadrant[3])};
  }
  if (c.texture != EmissionTexture::kNone)
    material["emissiveTexture"] = {{"index", g.Texture("emission.png")}};
  const int m = g.Material(material);
  const int p = g.Positions(positions), i = g.Indices(indices);
  const int mesh = g.Mesh(Json::array({Gltf::Primitive(p, i, m, st.empty() ? -1 : g.Texcoords(st))}));
  std::vector<int> roots;
  if (c.hierarchy) {
    const glm::dvec4 q = Quaternion(c.childAxis, c.childDegrees);
    const int child = g.Node(
        {{"name", "child"}, {"mesh", mesh}, {"rotation", {q.x, q.y, q.z, q.w}}, {"scale", J(c.childScale)}});
    roots.push_back(g.Node(
        {{"name", "parent"}, {"translation", J(c.parentTranslation)}, {"children", Json::array({child})}}));
  } else {
    roots.push_back(g.Node({{"name", "lamp"}, {"mesh", mesh}}));
  }
  WriteText(dir / "lamp.gltf", g.Text(roots));
  return radiance;
}

// The case's local → world map, composed here: node chain (child T·R·S under the parent's translation), then
// the sequence keyframe.
Affine EmitterToWorld(const EmitterCase& c) {
  Affine node;
  if (c.hierarchy) {
    node.a = QuaternionMatrix(Quaternion(c.childAxis, c.childDegrees)) * Diagonal(c.childScale);
    node.t = c.parentTranslation;
  }
  return node.Then(c.key.Matrix());
}

Json EmitterScene(const EmitterCase& c, const std::string& name) {
  const D3 view = c.origin + c.view;
  return {
      {"name", name},
      {"resolution", {64, 64}},
      {"frames", 1},
      {"materials", Json::array({{{"name", "floor"}, {"type", "diffuse"}, {"albedo", J(D3(kFloorAlbedo))}}})},
      {"objects",
       Json::array({{{"name", "floor"},
                     {"material", "floor"},
                     {"shape",
                      {{"type", "quad"}, {"center", J(c.origin)}, {"u", {12, 0, 0}}, {"v", {0, 0, -12}}}}}})},
      {"lights", Json::array()},
      {"camera", CameraJson(view + D3(0, c.cameraDistance, c.cameraDistance / 2), view, 62.0)}};
}

// The emitting side's normal in the world, as glTF 2.0 defines it (section 3.7.4), computed here from the case's
// transforms and never from the imported winding: the local quad's front −ŷ mapped by the inverse transpose of
// the local → world map. (The triangles' own cross product is det(A) times that: it turns over under a mirror.)
D3 ExpectedFront(const EmitterCase& c) {
  return glm::normalize(glm::transpose(glm::inverse(EmitterToWorld(c).a)) * D3(0, -1, 0));
}

bool Mirrors(const EmitterCase& c) {
  return glm::determinant(EmitterToWorld(c).a) < 0.0;
}

// Outgoing radiance at floor point x, channel `ch`: albedo/π Σ_t L_t E_t(x), each light triangle (as the
// scene holds it) clipped to x's horizon, where x is on its emitting side: the side of the triangle's plane (as
// the scene holds it: at 1000 m its rounded corners tilt it) that `front`, the test's own, points to.
double FloorClosedForm(const Light& light, const std::vector<D3>& radiance, const D3& front, int ch,
                       const Vec3& x) {
  const Vec3 n(0, 1, 0);
  double sum = 0.0;
  for (size_t t = 0; t < radiance.size(); ++t) {
    const std::vector<Vec3> tri(light.vertices.begin() + 3 * t, light.vertices.begin() + 3 * t + 3);
    D3 side = glm::cross(D3(tri[1]) - D3(tri[0]), D3(tri[2]) - D3(tri[0]));
    if (glm::dot(side, front) < 0.0) side = -side;
    if (glm::dot(side, D3(x) - D3(tri[0])) <= 0.0) continue;
    const std::vector<Vec3> clipped = ClipPolygonToHemisphere(x, n, tri);
    if (clipped.size() >= 3) sum += PolygonIrradiance(x, n, clipped, radiance[t][ch]);
  }
  return kFloorAlbedo / M_PI * sum;
}

// The reference's channel `ch` against the closed form over the floor's pixels (t15 z; pixels independent), every
// one of them: until issue 40 the pixels within two float spacings of an emitter's plane were left out, because a
// light point sampled in float lies up to half a spacing off the plane and the emitter's cosine taken from it lit
// floor points up to ~30 µm behind a 1 cm emitter at 1000 m; the reference now takes that cosine from the plane
// (core/shading.h ConnectToLightOnPlane).
Verdict CompareWithLambert(const GBuffer& g, const ReferenceImage& ref, const Light& light,
                           const std::vector<D3>& radiance, const D3& front, int ch) {
  Verdict v;
  std::vector<double> exact(g.Size(), 0.0);
  double brightest = 0.0;
  for (size_t i = 0; i < g.Size(); ++i)
    if (g.IsSurface(i))
      brightest = std::max(brightest, exact[i] = FloorClosedForm(light, radiance, front, ch, g.Position(i)));
  double sumRelative = 0.0, sumRelativeVar = 0.0;
  int lit = 0;
  for (size_t i = 0; i < g.Size(); ++i) {
    if (!g.IsSurface(i)) continue;
    const double value = ref.mean.pixels[i][ch], se = ref.standardError.pixels[i][ch];
    if (exact[i] > 1e-3 * brightest) {
      sumRelative += value / exact[i] - 1.0;
      sumRelativeVar += se * se / (exact[i] * exact[i]);
      ++lit;
    }
    if (se == 0.0) {
      // Every replicate agreed: an unlit pixel, or one the difference estimator has exactly (its light arrived
      // at every draw, sim/reference/reference_learning.h), which must then be the closed form to float rounding.
      EXPECT_NEAR(value, exact[i], 1e-5 * exact[i] + 1e-7 * brightest) << "pixel " << i;
      if (exact[i] > 0.0) ++v.exactPixels;
      continue;
    }
    const double z = (value - exact[i]) / se;
    v.meanZ2 += z * z;
    if (std::fabs(z) > v.maxAbsZ) {
      v.maxAbsZ = std::fabs(z);
      char buf[160];
      std::snprintf(buf, sizeof buf, "pixel (%zu, %zu): ref %.7g +- %.2g, closed form %.7g", i % g.width,
                    i / g.width, value, se, exact[i]);
      v.worst = buf;
    }
    ++v.pixels;
  }
  v.meanZ2 /= std::max(1, v.pixels);
  v.relativeError = sumRelative / std::max(1, lit);
  v.relativeStdError = std::sqrt(sumRelativeVar) / std::max(1, lit);
  return v;
}

TEST(AssetClosedForm, EmissiveQuadMatchesSequenceLightAndLambert) {
  const auto start = std::chrono::steady_clock::now();
  const Claims t15{test::StudentTSquaredMean(15),
                   test::StudentTSquaredMean(15),
                   test::StudentTSquaredVariance(15),
                   15,
                   INFINITY,
                   1e-3};
  int index = 0;
  for (const EmitterCase& c : EmitterGrid()) {
    SCOPED_TRACE(c.name);
    std::printf("%s\n", c.name.c_str());
    const Scratch scratch("emitter" + std::to_string(index++));
    const fs::path& dir = *scratch;
    const std::vector<D3> radiance = WriteEmitterAsset(c, dir);
    Json scene = EmitterScene(c, "asset");
    scene["objects"].push_back(
        {{"name", "lamp"}, {"asset", {{"file", "lamp.gltf"}}}, {"keyframes", Json::array({c.key.ToJson()})}});
    const Sequence asset = Load(dir, "asset", scene);

    // The importer's triangles: one light (the mesh), the quad's two triangles in order, at the world
    // vertices computed here, with the radiance computed here.
    ASSERT_EQ(asset.lights.size(), 1u);
    const Light& light = asset.lights[0];
    ASSERT_EQ(light.vertices.size(), 6u);
    const Affine toWorld = EmitterToWorld(c);
    const bool mirrors = Mirrors(c);
    const D3 front = ExpectedFront(c);
    // Each triangle counter-clockwise seen from its front: the file's corners, reversed under a mirroring node
    // (where the file's order is clockwise seen from the front). Where the triangle starts is free.
    const int fileOrder[6] = {0, 1, 2, 0, 2, 3}, reversedOrder[6] = {0, 2, 1, 0, 3, 2};
    const int* order = mirrors ? reversedOrder : fileOrder;
    double magnitude = 0.0, worstVertex = 0.0;
    for (int k = 0; k < 4; ++k) magnitude = std::max(magnitude, CompMax(glm::abs(toWorld(kLocalCorners[k]))));
    for (int t = 0; t < 2; ++t) {
      double error = INFINITY;
      for (int start = 0; start < 3; ++start) {
        double e = 0.0;
        for (int k = 0; k < 3; ++k)
          e = std::max(e, CompMax(glm::abs(D3(light.vertices[3 * t + (start + k) % 3]) -
                                           toWorld(kLocalCorners[order[3 * t + k]]))));
        error = std::min(error, e);
      }
      worstVertex = std::max(worstVertex, error);
      EXPECT_LE(error, FloatTolerance(magnitude)) << "triangle " << t << ": imported (" << light.vertices[3 * t].x
                                                  << ", " << light.vertices[3 * t].y << ", "
                                                  << light.vertices[3 * t].z << "), ...";
      const D3 p0(light.vertices[3 * t]);
      EXPECT_GT(glm::dot(glm::cross(D3(light.vertices[3 * t + 1]) - p0, D3(light.vertices[3 * t + 2]) - p0), front),
                0.0)
          << "triangle " << t << " faces away from the front glTF gives it";
    }
    const double side = glm::length(toWorld(kLocalCorners[1]) - toWorld(kLocalCorners[0]));
    std::printf(
        "  imported vertices within %.3g m of the expected (%.3g of the quad's side; tolerance %.3g m)\n",
        worstVertex, worstVertex / side, FloatTolerance(magnitude));
    for (size_t t = 0; t < 2; ++t) {
      const Vec3 r = light.triangleRadiance.empty() ? light.radiance : light.triangleRadiance[t];
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(r[ch], radiance[t][ch], 1e-6 * radiance[t][ch]) << "triangle " << t << " channel " << ch;
    }

    GBuffer g;
    const ReferenceImage ref = Reference(asset, 1024, &g);

    // (a) The same scene with a sequence quad light (one light, two triangles: the same frame state, so the
    // same random numbers). The four-quadrant case has two radiances, which needs two sequence lights, hence
    // another frame state and other random numbers: it has (b) only. So have the mirroring cases: a sequence
    // quad whose front is the mirrored one lists its triangles in another order, so its samples pick others.
    if (c.texture != EmissionTexture::kQuadrants && !mirrors) {
      const D3 centre = toWorld(D3(0.0)), u = toWorld.a * D3(1, 0, 0), v = toWorld.a * D3(0, 0, 1);
      Json plain = EmitterScene(c, "sequence_light");
      plain["lights"].push_back({{"name", "lamp"},
                                 {"type", "quad"},
                                 {"center", J(centre)},
                                 {"u", J(u)},
                                 {"v", J(v)},
                                 {"color", J(radiance[0])},
                                 {"intensity", 1.0}});
      const Sequence sequenceLight = Load(dir, "sequence_light", plain);
      ASSERT_EQ(sequenceLight.lights.size(), 1u);
      const bool sameVertices =
          std::memcmp(sequenceLight.lights[0].vertices.data(), light.vertices.data(), 6 * sizeof(Vec3)) == 0;
      const bool sameRadiance =
          light.triangleRadiance.empty() && sequenceLight.lights[0].radiance == light.radiance;
      const bool sameTriangles = sameVertices && sameRadiance;
      const ReferenceImage other = Reference(sequenceLight, 1024);
      const size_t bytes = ref.mean.pixels.size() * sizeof(Vec3);
      const bool identical =
          std::memcmp(ref.mean.pixels.data(), other.mean.pixels.data(), bytes) == 0 &&
          std::memcmp(ref.standardError.pixels.data(), other.standardError.pixels.data(), bytes) == 0;
      // Where they differ: the largest difference over the image's brightest value, and the largest relative
      // difference over pixels above 1% of it (near the emitter's plane, at grazing emission, a rounding of
      // the plane's tilt is a larger share of a pixel's small value).
      double brightest = 0.0, worstAbsolute = 0.0, worstRelative = 0.0;
      int otherCounts = 0;
      for (size_t i = 0; i < g.Size(); ++i)
        for (int ch = 0; ch < 3; ++ch) brightest = std::max(brightest, double(ref.mean.pixels[i][ch]));
      for (size_t i = 0; i < g.Size(); ++i) {
        otherCounts += ref.pixelSamples[i] != other.pixelSamples[i];
        for (int ch = 0; ch < 3; ++ch) {
          const double a = ref.mean.pixels[i][ch], b = other.mean.pixels[i][ch];
          worstAbsolute = std::max(worstAbsolute, std::fabs(a - b) / brightest);
          if (std::max(a, b) > 1e-2 * brightest)
            worstRelative = std::max(worstRelative, std::fabs(a - b) / std::max(a, b));
        }
      }
      std::printf(
          "  (a) sequence light: vertices %s, radiance %s; image %s (largest difference %.3g of the "
          "brightest pixel, %.3g relative above 1%% of it; %d pixels with other sample counts)\n",
          sameVertices ? "bit-identical" : "differ by rounding",
          sameRadiance ? "bit-identical" : "differs by rounding", identical ? "bit-identical" : "differs",
          worstAbsolute, worstRelative, otherCounts);
      if (c.exact || sameTriangles) {
        EXPECT_TRUE(identical);  // the same triangles: the same image, bit for bit
      }
      if (c.exact) {
        EXPECT_TRUE(sameTriangles);
      }
      EXPECT_EQ(otherCounts, 0);
      EXPECT_LE(worstAbsolute, 1e-6);
      EXPECT_LE(worstRelative, 1e-5);
    }

    // (b) Lambert, per channel.
    for (int ch = 0; ch < 3; ++ch) {
      const Verdict v = CompareWithLambert(g, ref, light, radiance, front, ch);
      ExpectAgreement(v, v.meanZ2, v.pixels, t15, std::string("(b) Lambert, channel ") + "RGB"[ch]);
    }
  }
  std::printf("%.1f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace
}  // namespace restir
