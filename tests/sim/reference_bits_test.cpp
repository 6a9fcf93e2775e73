// The reference's SIMD paths (issue 16: the light-draw and QMC kernels, the vectorised per-pixel light
// distributions, emitter-only BSDF rays) changed how fast it renders, not what: on frames of the shipped
// sequences that reach every branch of sim/reference.cpp (diffuse and glossy receivers without a sky, a sun
// and an environment map, textured and layered assets, more light triangles than per-pixel distributions, the
// --reference-error allocation), its mean, standard errors and per-pixel luminance errors are the bytes the
// renderer wrote before them, on every SIMD target this machine runs and at one and two threads.
//
// The expected hashes are FNV-1a 64 of the reference cache entries' payloads (mean, standard error, luminance
// standard error, as sim/reference_cache.cpp stores them) written by `restir-sim run` built from commit
// 88a8006, the last one before these paths, rendered and hashed by scripts/reference_bits_hashes.sh (run it with
// that commit's binary to reproduce them). A NaN's payload is the one thing the kernels canonicalise; none occurs
// in these frames.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/simd.h"
#include "sim/frame_loop.h"
#include "sim/hash.h"
#include "sim/reference.h"
#include "sim/sequence.h"

namespace restir {
namespace {

struct Case {
  const char* name;
  const char* sequence;  // relative to the source directory
  int width, height, frame;
  int spp;  // 0: targetError instead
  double targetError;
  uint64_t hash;  // written by 88a8006
};

const Case kCases[] = {
    {"flagship", "sequences/window_bars_pan.json", 96, 54, 8, 48, 0.0, 0xc4593cd737516853ull},
    {"flagship_error", "sequences/window_bars_pan.json", 64, 36, 3, 0, 0.05, 0xcab951e30ad6ecc5ull},
    {"glossy_floor", "sequences/hard/glossy_floor.json", 64, 36, 0, 48, 0.0, 0xbe8c4f7781b43389ull},
    {"sky_smoke", "tests/data/sky_smoke.json", 48, 27, 1, 64, 0.0, 0x680603541f7ef887ull},
    {"asset_table", "sequences/asset_table.json", 64, 36, 0, 32, 0.0, 0xad616407e20956b1ull},
    {"many_rooms", "sequences/regimes/many_rooms.json", 48, 27, 0, 16, 0.0, 0x514e02f9ef5c138full},
    {"static_room", "sequences/static_room.json", 64, 36, 0, 64, 0.0, 0x1cede13b5bf480f1ull},
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

TEST_F(ReferenceBits, EqualTheRendererBeforeItsSimdPathsOnEveryTargetAndThreadCount) {
  for (const Case& c : kCases) {
    const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/" + c.sequence);
    FrameLoop loop(seq, c.width, c.height);
    loop.BeginFrame(c.frame);
    ReferenceParams params;
    params.samplesPerPixel = c.spp;
    params.targetRelativeError = c.targetError;
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
  Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/sequences/window_bars_pan.json");
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
