// The furnace (issue 41's first closed form): inside a closed box whose every wall emits a uniform radiance L_e
// and reflects by a Lambertian albedo ρ (emitters that are surfaces too: Light::material), every point of a wall
// receives the irradiance π L_e from the other walls (its own plane subtends no solid angle), so light reflected
// once is ρ L_e, and each further bounce multiplies what arrives by ρ again: with b bounces of indirect light a wall
// point reflects (ρ + ρ² + … + ρ^(b+1)) L_e, whatever its place on the wall, the box's size, tilt or distance from
// the origin. The truth shares no code with what it checks (no polygon, no quadrature: a geometric series).
//
// Checked for the reference (without bounces most pixels' direct light is exact, to rounding; every other pixel by
// ExpectAgreement's two z-tests over the pixels at kClaimRate = 1e-4 each: 7 configurations × 2 claims, a family
// rate at most 1.4e-3) and for the whole frames of the unbiased GI presets, their direct light and ReSTIR GI
// together (ExpectUnbiasedFrames: t-tests over 64 seeds at kClaimRate / 5 = 2e-5 per band, 2 presets × 5 claims,
// a family rate at most 2e-4). What the primary ray sees emitted (L_e, exact) is taken out of both, so the claims'
// relative errors are the estimated light's.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "sim/scene/shading_point.h"
#include "tests/sim/reference/closed_form_support.h"
#include "tests/sim/scene_fixtures.h"

namespace restir {
namespace furnace_test {

using namespace closed_form;  // NOLINT: the renderers and claims every test here uses

struct Furnace {
  Sequence seq;                        // the six walls as lights with the material "wall"; no object
  FrameState state;                    // its one frame
  double albedo = 0.0, radiance = 0.0;  // ρ and L_e of every wall
};

// A cube of edge `edge` centred at `centre`, turned by `tiltDegrees` about the axis (1, 1, 0) (so that no wall is
// square to the world's axes), each of its six walls a quad light facing inwards with the one material "wall". The
// camera sits off the centre and looks towards a corner, so that three walls and their shared edges fill the view.
Furnace FurnaceBox(const D3& centre, double edge, double tiltDegrees, double albedo, double radiance) {
  Furnace f;
  Sequence& seq = f.seq;
  seq.name = "furnace";
  seq.width = 48;
  seq.height = 36;
  seq.frameCount = 1;
  seq.contentHash = "furnace-" + std::to_string(centre.x) + "," + std::to_string(centre.y) + "," +
                    std::to_string(centre.z) + "-" + std::to_string(edge) + "-" + std::to_string(tiltDegrees) + "-" +
                    std::to_string(albedo) + "-" + std::to_string(radiance);
  Material wall;
  wall.name = "wall";
  wall.albedo = Vec3(static_cast<float>(albedo));
  seq.materials = {wall};
  const glm::dmat3 turn(glm::rotate(glm::dmat4(1.0), Radians(tiltDegrees), glm::normalize(D3(1.0, 1.0, 0.0))));
  const double h = 0.5 * edge;
  for (int axis = 0; axis < 3; ++axis)
    for (const double side : {-1.0, 1.0}) {
      D3 n(0.0), u(0.0);
      n[axis] = -side;              // inwards
      u[(axis + 1) % 3] = h;
      const D3 v = glm::cross(n, u);  // cross(u, v) = h² n: AddQuadLight emits along it
      test::AddQuadLight(seq, "wall" + std::to_string(seq.lights.size()), Vec3(centre - turn * (h * n)),
                         Vec3(turn * u), Vec3(turn * v), Vec3(static_cast<float>(radiance)));
      seq.lights.back().material = 0;
    }
  CameraKey k;
  k.position = Vec3(centre + turn * (D3(-0.15, -0.1, -0.2) * edge));
  k.lookAt = Vec3(centre + turn * (D3(0.5, 0.45, 0.5) * edge));
  k.vfovDegrees = 80.0f;
  seq.cameraKeys.push_back(k);
  f.state = test::StaticState(seq);
  f.albedo = albedo;
  f.radiance = radiance;
  return f;
}

// What a wall point reflects with `bounces` bounces of indirect light: (ρ + … + ρ^(bounces+1)) L_e.
double FurnaceTruth(const Furnace& f, int bounces) {
  double sum = 0.0, power = 1.0;
  for (int k = 0; k <= bounces; ++k) sum += (power *= f.albedo);
  return sum * f.radiance;
}

TEST(Furnace, ReferenceReflectsTheGeometricSeriesOfTheAlbedo) {
  struct Case {
    D3 centre;                   // the box's centre
    double edge, tilt, albedo;   // its edge (m), its turn about (1, 1, 0) (degrees), ρ
    int bounces;                 // of indirect light
  };
  const D3 far = 1000.0 * glm::normalize(D3(-0.6, 0.48, 0.64));
  for (const Case& c : {Case{D3(0.0), 2.0, 0.0, 0.5, 0}, Case{far, 2.0, 35.0, 0.8, 0},
                        Case{D3(0.0), 2.0, 0.0, 0.5, 1}, Case{D3(0.0), 0.05, 35.0, 0.8, 2},
                        Case{far, 2.0, 35.0, 0.8, 3}, Case{far, 400.0, 60.0, 0.3, 1},
                        Case{D3(0.0), 2.0, 80.0, 0.95, 2}}) {
    const Furnace f = FurnaceBox(c.centre, c.edge, c.tilt, c.albedo, 2.0);
    Rendered r = Render(f.seq, f.state, c.bounces, 256);
    EmbreeScene scene(f.seq);
    scene.Update(f.state);
    size_t walls = 0;
    for (size_t i = 0; i < r.g.Size(); ++i) {
      ASSERT_GE(r.g.lightId[i], 0) << "pixel " << i << " does not see a wall: the box leaks";
      ASSERT_TRUE(r.g.IsSurface(i)) << "pixel " << i << ": a wall that emits is a surface too";
      r.ref.mean.pixels[i] -= DirectEmission(r.g, i, scene.LightTriangles());
      walls += 1;
    }
    char what[112];
    std::snprintf(what, sizeof what, "furnace %g m out, edge %g m, tilt %g, albedo %.2f, %d bounce%s",
                  glm::length(c.centre), c.edge, c.tilt, c.albedo, c.bounces, c.bounces == 1 ? "" : "s");
    // Without bounces, a pixel's direct light can be exact rather than an estimate: where every wall triangle it
    // sees is sampled by the solid angle it subtends, a diffuse receiver gets each one's projected solid angle times
    // L_e exactly (docs/metrics.md, "How the reference is sampled"), ρ L_e in all to float rounding and with no
    // spread. Such a pixel is held to that; the rest (near the box's edges, and 1 km out where the sampled points
    // lie on float's 61 µm grid) are estimates, held to the claims.
    size_t exact = 0;
    for (size_t i = 0; i < r.g.Size(); ++i) {
      if (r.ref.lumaStandardError[i] > 0.0f) continue;
      ASSERT_EQ(c.bounces, 0) << what << ": pixel " << i << " has no spread";
      EXPECT_NEAR(Y(D3(r.ref.mean.pixels[i])) / FurnaceTruth(f, 0), 1.0, 1e-5) << what << ", pixel " << i;
      exact += 1;
    }
    std::printf("  %s: %zu pixels exact\n", what, exact);
    ExpectAgreement(
        r,
        [&](size_t i) { return r.ref.lumaStandardError[i] > 0.0f ? FurnaceTruth(f, c.bounces) : std::nan(""); },
        what, c.bounces == 0 ? 100 : walls);
  }
}

// A wall that emits is a surface only when it has a material: without one, the pixels that see it are emission
// alone, as before this existed, and the paths end there (nothing reflects inside).
TEST(Furnace, AnEmitterWithoutAMaterialOnlyEmits) {
  Furnace f = FurnaceBox(D3(0.0), 2.0, 35.0, 0.5, 2.0);
  for (Light& l : f.seq.lights) l.material = -1;
  const Rendered r = Render(f.seq, f.state, 2, 16);
  for (size_t i = 0; i < r.g.Size(); ++i) {
    ASSERT_GE(r.g.lightId[i], 0) << "pixel " << i;
    EXPECT_FALSE(r.g.IsSurface(i)) << "pixel " << i;
    EXPECT_EQ(r.ref.mean.pixels[i], Vec3(2.0f)) << "pixel " << i;
  }
}

TEST(Furnace, UnbiasedGiPresetsReflectTheGeometricSeries) {
  // 64 seeds: the frames' mean relative error has a standard error of about 0.1% here.
  constexpr int kSeeds = 64;
  const Furnace f = FurnaceBox(1000.0 * glm::normalize(D3(0.3, -0.8, 0.52)), 2.0, 35.0, 0.7, 2.0);
  for (const char* name : {"restir-gi-unbiased", "restir-gi-spmis"}) {
    const Preset* preset = FindPreset(name);
    ASSERT_NE(preset, nullptr) << name;
    const PipelineSettings& settings = preset->settings;
    ASSERT_EQ(settings.indirect.bounces, 1) << name;
    GBuffer g;
    const std::vector<ImageRgb> frames = GiFrames(f.seq, f.state, settings, 4, kSeeds, g, true);
    ExpectUnbiasedFrames(frames, g, [&](size_t) { return FurnaceTruth(f, 1); },
                         std::string(name) + ": furnace 1 km out, tilt 35, albedo 0.7, frame 4");
  }
}

}  // namespace furnace_test
}  // namespace restir
