// The frame loop's preset frame (sim/run/frame_loop.h RenderPreset): the pipeline's passes, then the indirect
// pass where the preset's settings ask for indirect light.
#include "sim/run/frame_loop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "sim/estimator/presets.h"
#include "sim/reference/reference_paths.h"
#include "tests/sim/scene_fixtures.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace frame_loop_test {

// The floor under a quad light, with a box beside the light that the light's rays reflect off onto the floor.
Sequence FloorWithBox() {
  Sequence seq = test::FloorUnderQuadLight(48, 36, 1.5f, 0.6f);
  test::AddBoxObject(seq, "box", 0, Vec3(-1.2f, 0.0f, -1.0f), Vec3(-0.6f, 1.2f, 0.4f));
  return seq;
}

bool HasPass(const FrameResult& r, const std::string& name) {
  return std::any_of(r.passes.begin(), r.passes.end(), [&](const PassStats& p) { return p.name == name; });
}

TEST(FrameLoop, APresetWithBouncesAddsTheIndirectImageAsAPassOfItsOwn) {
  const Sequence seq = FloorWithBox();
  FrameLoop loop(seq, seq.width, seq.height);
  loop.BeginFrame(0);
  for (const char* name : {"ris", "restir-unbiased"}) {
    PipelineSettings direct = FindPreset(name)->settings, indirect = direct;
    indirect.indirect.bounces = 2;
    Pipeline plain(direct), withIndirect(indirect);
    const FrameResult a = loop.RenderPreset(plain, loop.Inputs(5));
    const FrameResult b = loop.RenderPreset(withIndirect, loop.Inputs(5));
    EXPECT_FALSE(HasPass(a, "indirect")) << name;
    ASSERT_EQ(b.passes.back().name, "indirect") << name;
    uint64_t rays = 0;
    const ImageRgb paths = IndirectImage(seq, loop.State(), loop.Scene(), loop.Gbuffer(), 2, 5, 0, rays);
    EXPECT_EQ(b.passes.back().rays, rays) << name;
    EXPECT_GT(rays, 0u) << name;
    size_t lit = 0;
    for (size_t i = 0; i < a.image.pixels.size(); ++i) {
      EXPECT_EQ(b.image.pixels[i], a.image.pixels[i] + paths.pixels[i]) << name << " pixel " << i;
      lit += paths.pixels[i] != Vec3(0.0f);
    }
    // One path a pixel: about a tenth of the floor's paths meet a lit face of the box.
    EXPECT_GT(lit, 50u) << name << ": the box's light reaches the floor";
  }
}

}  // namespace frame_loop_test
}  // namespace restir
