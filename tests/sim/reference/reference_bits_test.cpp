// The reference's bits are one answer (DESIGN §3): on frames of the shipped sequences that reach every branch of
// sim/reference/reference.cpp (diffuse and glossy receivers without a sky, quad lights weighed as one group, a sun
// and an environment map, textured and layered assets, more light triangles than per-pixel distributions take, the
// --reference-error allocation), its mean, standard errors and per-pixel luminance errors are the same bytes on every
// SIMD target this machine runs and at one and two threads, and those bytes are the recorded ones: a change in them
// is a deliberate change of the reference (kReferenceVersion), made with these hashes.
//
// The expected hashes are FNV-1a 64 of the payloads (mean, standard error, luminance standard error, as
// sim/reference/reference_cache.cpp stores them), recorded from this test's scalar-twin runs when issue 16
// redesigned the reference (light-selection and BSDF-draw kernels, light groups, fixed-point QMC points;
// kReferenceVersion 8) and again when a BSDF draw's distance to the emitter it meets stopped being Embree's
// (kReferenceVersion 9: the recorded hashes, made on an Intel Xeon, failed on an AMD EPYC for the five cases with
// local lights; the probe test ReferenceVendor proves the cause is gone), and when issue 40's visibility learning
// reshaped the main pass's distributions and gave frames above 4096 light triangles per-tile distributions
// (kReferenceVersion 10: every case but glossy_floor, whose one light leaves nothing to reshape, and sky_smoke), and
// when the pilot's per-pixel probes came (kReferenceVersion 12: door_ajar added, the one case with 2 to 32 groups), and
// when per-pixel distributions were taken up to 32768 light triangles (kReferenceVersion 15: many_rooms' changed;
// tile_lights added, 33,802 triangles, the one case whose distributions stay per tile), and when the pilot's
// relative variances were spread to their neighbourhood before the allocation (kReferenceVersion 16: every case),
// and when the indirect paths' first direction came to be guided by the pilot's (kPathsVersion 4: sun_room_paths
// added, one bounce of indirect light under a sun);
// scripts/reference_bits_hashes.sh renders the same configurations with a restir-sim binary and prints the same hashes from its cache entries. The hashes come
// from this code, so this is a determinism and regression check, not a proof of correctness: the answers the project
// did not compute are in reference_test (Lambert's formula), reference_glossy_test (quadrature),
// light_selection_kernel_test and light_test. A NaN's payload is the one thing the kernels canonicalise; none occurs
// in these frames.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/simd.h"
#include "sim/run/frame_loop.h"
#include "sim/util/hash.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

struct Case {
  const char* name;
  const char* sequence;  // relative to the source directory
  int width, height, frame;
  int spp;  // 0: targetError instead
  double targetError;
  uint64_t hash;  // the payload's FNV-1a 64
  int indirectBounces = 0;  // the indirect light's bounces (ReferenceParams::indirectBounces)
};

const Case kCases[] = {
    {"flagship", "sequences/window_bars_pan.json", 96, 54, 8, 48, 0.0, 0x30e42b49bc8b81ddull},
    {"flagship_error", "sequences/window_bars_pan.json", 64, 36, 3, 0, 0.05, 0x140983586eba1266ull},
    {"glossy_floor", "sequences/hard/glossy_floor.json", 64, 36, 0, 48, 0.0, 0xf8aaec4cc424c3d5ull},
    {"sky_smoke", "tests/data/sky_smoke.json", 48, 27, 1, 64, 0.0, 0x6064439b2b30dfd5ull},
    {"asset_table", "sequences/asset_table.json", 64, 36, 0, 32, 0.0, 0x11e5b4c9797faceaull},
    {"many_rooms", "sequences/regimes/many_rooms.json", 48, 27, 0, 16, 0.0, 0x62008acd4daa45a0ull},
    {"static_room", "sequences/static_room.json", 64, 36, 0, 64, 0.0, 0x11896c6526ad708dull},
    {"door_ajar", "sequences/regimes/door_ajar.json", 48, 27, 0, 32, 0.0, 0x9f2bd68615784df0ull},
    {"tile_lights", "tests/data/tile_lights.json", 48, 27, 0, 16, 0.0, 0xe96892d72913841bull},
    {"sun_room_paths", "sequences/window_bars_sun.json", 48, 27, 20, 16, 0.0, 0xb4bde1456e582b34ull, 1},
};

uint64_t PayloadHash(const ReferenceImage& r) {
  uint64_t h = Fnv1a(r.mean.pixels.data(), r.mean.pixels.size() * sizeof(Vec3));
  h = Fnv1a(r.standardError.pixels.data(), r.standardError.pixels.size() * sizeof(Vec3), h);
  return Fnv1a(r.lumaStandardError.data(), r.lumaStandardError.size() * sizeof(float), h);
}

class ReferenceBits : public ::testing::Test {
 protected:
  void TearDown() override { SetSimdTarget(SimdTarget::kAuto); }
};

TEST_F(ReferenceBits, AreTheRecordedOnesOnEveryTargetAndThreadCount) {
  for (const Case& c : kCases) {
    const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/" + c.sequence);
    FrameLoop loop(seq, c.width, c.height);
    loop.BeginFrame(c.frame);
    ReferenceParams params;
    params.samplesPerPixel = c.spp;
    params.targetRelativeError = c.targetError;
    params.indirectBounces = c.indirectBounces;
    for (SimdTarget t : SupportedSimdTargets()) {
      ASSERT_TRUE(SetSimdTarget(t));
      for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
        const ReferenceImage ref = RenderReference(seq, loop.State(), loop.Scene(), loop.Gbuffer(), params);
        EXPECT_EQ(PayloadHash(ref), c.hash)
            << c.name << " on " << SimdTargetName(t) << " with " << threads << " thread(s)";
      }
    }
  }
}

// A frame whose every light is switched off has an empty power sampler: the reference is the dark frame it was
// (zero wherever no emitter is seen), not a read of the sampler's missing table.
TEST_F(ReferenceBits, EveryLightSwitchedOffGivesADarkFrame) {
  Sequence seq = LoadSequence(RESTIR_SOURCE_DIR "/sequences/window_bars_pan.json");
  FrameLoop loop(seq, 32, 18);
  loop.BeginFrame(0);
  FrameState dark = loop.State();
  std::fill(dark.lightOn.begin(), dark.lightOn.end(), uint8_t{0});
  loop.Scene().Update(dark);
  ReferenceParams params;
  params.samplesPerPixel = 32;
  const ReferenceImage ref = RenderReference(seq, dark, loop.Scene(), loop.Gbuffer(), params);
  for (const Vec3& v : ref.mean.pixels) EXPECT_EQ(v, Vec3(0.0f));
  EXPECT_EQ(ref.rays, 0u);
}

}  // namespace
}  // namespace restir
