// The reference is one answer on every CPU, not only on every SIMD target of one (DESIGN §3): Embree reports a
// hit's t and barycentrics through an approximate reciprocal (rcpps and one Newton step in its SSE4.2 kernels),
// whose last bits differ between Intel and AMD, so no bit of the reference may follow those numbers. Test: every
// closest-hit query is answered by Embree's own hit with t, u and v moved by a few ulps, as another vendor's
// reciprocal moves them, and the reference's payload (mean, standard errors) must keep every bit. Before
// EmbreeScene::FirstEmitter recomputed t from the triangle, this is what made ReferenceBits' recorded hashes
// (made on an Intel Xeon) fail on an AMD EPYC. Occlusion answers are not moved: Embree decides them without the
// reciprocal. Deterministic, no false failures.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sim/scene/embree_probe.h"
#include "sim/scene/embree_scene.h"
#include "sim/run/frame_loop.h"
#include "sim/util/hash.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

float Ulps(float x, int n) {
  for (int i = 0; i < n; ++i) x = std::nextafter(x, n > 0 ? INFINITY : -INFINITY);
  return x;
}

// Embree's answer with another CPU's last bits.
class OtherVendor final : public RayHook {
 public:
  explicit OtherVendor(const EmbreeScene& scene) : scene_(scene) {}
  bool AnswerIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame, RawHit& hit) const override {
    hit = IntersectRaw(scene_, org, dir, tmax, frame);
    if (hit.geomId == 0xffffffffu) return true;
    hit.t = Ulps(hit.t, 3);
    hit.u = Ulps(hit.u, -2);
    hit.v = Ulps(hit.v, 2);
    return true;
  }

 private:
  const EmbreeScene& scene_;
};

uint64_t PayloadHash(const ReferenceImage& r) {
  uint64_t h = Fnv1a(r.mean.pixels.data(), r.mean.pixels.size() * sizeof(Vec3));
  h = Fnv1a(r.standardError.pixels.data(), r.standardError.pixels.size() * sizeof(Vec3), h);
  return Fnv1a(r.lumaStandardError.data(), r.lumaStandardError.size() * sizeof(float), h);
}

struct Case {
  const char* sequence;  // relative to the source directory
  int frame;
};

// The branches of sim/reference/reference.cpp that trace closest hits: BSDF draws meeting emitters at diffuse and
// glossy receivers, the sky, textured assets with their own normals.
TEST(ReferenceVendor, ItsBitsDoNotFollowEmbreesReciprocal) {
  const Case cases[] = {{"sequences/window_bars_pan.json", 8},
                        {"sequences/hard/glossy_floor.json", 0},
                        {"tests/data/sky_smoke.json", 1},
                        {"sequences/asset_table.json", 0}};
  for (const Case& c : cases) {
    const Sequence seq = LoadSequence(std::string(RESTIR_SOURCE_DIR) + "/" + c.sequence);
    ReferenceParams params;
    params.samplesPerPixel = 32;
    uint64_t hash[2] = {};
    for (int moved = 0; moved < 2; ++moved) {
      FrameLoop loop(seq, 48, 27);
      OtherVendor hook(loop.Scene());
      if (moved) SetRayHook(loop.Scene(), &hook);  // before the G-buffer is traced
      loop.BeginFrame(c.frame);
      hash[moved] = PayloadHash(RenderReference(seq, loop.State(), loop.Scene(), loop.Gbuffer(), params));
      SetRayHook(loop.Scene(), nullptr);
    }
    EXPECT_EQ(hash[1], hash[0]) << c.sequence;
  }
}

}  // namespace
}  // namespace restir
