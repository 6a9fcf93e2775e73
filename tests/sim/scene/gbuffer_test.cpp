#include "sim/scene/gbuffer.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "tests/sim/mesh_fixtures.h"

namespace restir {
// Named after the file, not anonymous: the unity build compiles it with other test files (CMakeLists.txt).
namespace gbuffer_test {

constexpr float kInf = std::numeric_limits<float>::infinity();

using test::BoxMesh;
using test::MakeObject;
using test::QuadMesh;
using test::Trs;

// Camera looking along `forward` (yaw/pitch applied by the caller), +Y up.
Camera MakeCamera(const Vec3& position, const Vec3& forward, int w, int h, float vfov) {
  Camera c;
  c.position = position;
  c.forward = glm::normalize(forward);
  c.right = glm::normalize(glm::cross(c.forward, Vec3(0, 1, 0)));
  c.up = glm::cross(c.right, c.forward);
  c.vfovDegrees = vfov;
  c.width = w;
  c.height = h;
  return c;
}

Vec3 YawPitch(float yawDeg, float pitchDeg) {
  const float y = glm::radians(yawDeg), p = glm::radians(pitchDeg);
  return Vec3(-std::sin(y) * std::cos(p), std::sin(p), -std::cos(y) * std::cos(p));
}

FrameState StateFor(const Camera& cam, std::vector<Mat4> xforms, int frame) {
  FrameState st;
  st.frame = frame;
  st.camera = cam;
  st.objectToWorld = std::move(xforms);
  return st;
}

// Independent ray tests (double precision, no Embree).
std::optional<double> RayPlaneZ(const glm::dvec3& o, const glm::dvec3& d, double z) {
  if (d.z == 0.0) return std::nullopt;
  const double t = (z - o.z) / d.z;
  return t > 0.0 ? std::optional<double>(t) : std::nullopt;
}

std::optional<double> RayBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return std::nullopt;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return std::nullopt;
  }
  return t0 > 0.0 ? std::optional<double>(t0) : std::nullopt;
}

glm::dvec3 PixelDir(const Camera& c, int x, int y) {
  return glm::dvec3(c.RayDirection(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f));
}

// The G-buffer's fields compared bit for bit.
bool SameBits(const GBuffer& a, const GBuffer& b) {
  std::vector<std::string> bytesA, bytesB;
  auto collect = [](std::vector<std::string>& out) {
    return [&out](const auto& v) { out.emplace_back(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0])); };
  };
  GBuffer::ForEachArray(a, collect(bytesA));
  GBuffer::ForEachArray(b, collect(bytesB));
  return bytesA == bytesB;
}

// ---------------------------------------------------------------------------------------------------------------
// Wall at z = -10 and a floor at y = -2 (both static).
Sequence WallAndFloor() {
  Sequence s;
  s.materials.resize(2);
  s.objects.push_back(MakeObject("wall", QuadMesh(), false, 0));
  s.objects.push_back(MakeObject("floor", QuadMesh(), false, 1));
  return s;
}
std::vector<Mat4> WallAndFloorXforms() {
  return {Trs(Vec3(0, 0, -10), Vec3(0), Vec3(50, 50, 1)), Trs(Vec3(0, -2, 0), Vec3(-90, 0, 0), Vec3(50, 50, 1))};
}
// Analytic first hit of WallAndFloor.
std::optional<glm::dvec3> WallAndFloorHit(const glm::dvec3& o, const glm::dvec3& d) {
  double best = std::numeric_limits<double>::infinity();
  if (auto t = RayPlaneZ(o, d, -10.0)) {
    const glm::dvec3 p = o + *t * d;
    if (std::fabs(p.x) <= 50 && std::fabs(p.y) <= 50) best = *t;
  }
  if (d.y != 0.0) {
    const double t = (-2.0 - o.y) / d.y;
    const glm::dvec3 p = o + t * d;
    if (t > 0 && t < best && std::fabs(p.x) <= 50 && std::fabs(p.z) <= 50) best = t;
  }
  if (!std::isfinite(best)) return std::nullopt;
  return o + best * d;
}

TEST(TracePrimary, HitsMatchAnalyticPlanesAndMissesAreCleared) {
  Sequence s = WallAndFloor();
  EmbreeScene scene(s);
  // Looking up a bit so the top rows miss everything above the wall.
  const Camera cam = MakeCamera(Vec3(0, 0, 0), YawPitch(0, 75), 64, 48, 60);
  scene.Update(StateFor(cam, WallAndFloorXforms(), 0));
  GBuffer g;
  TracePrimary(scene, cam, g);
  ASSERT_EQ(g.Size(), 64u * 48u);
  size_t hits = 0, misses = 0;
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      const size_t i = static_cast<size_t>(y) * cam.width + x;
      const auto p = WallAndFloorHit(glm::dvec3(cam.position), PixelDir(cam, x, y));
      if (!p) {
        ++misses;
        EXPECT_EQ(g.objectId[i], -1);
        EXPECT_EQ(g.materialId[i], -1);
        EXPECT_EQ(g.lightId[i], -1);
        EXPECT_EQ(g.depth[i], 0.0f);
        EXPECT_EQ(g.Position(i), Vec3(0));
        EXPECT_FALSE(g.IsSurface(i));
        continue;
      }
      ++hits;
      ASSERT_GE(g.objectId[i], 0);
      EXPECT_TRUE(g.IsSurface(i));
      EXPECT_LT(glm::length(glm::dvec3(g.Position(i)) - *p), 1e-3 * glm::length(*p));
      EXPECT_NEAR(g.depth[i], cam.ViewDepth(Vec3(*p)), 1e-3f * g.depth[i]);
      const Vec3 n = g.objectId[i] == 0 ? Vec3(0, 0, 1) : Vec3(0, 1, 0);
      EXPECT_NEAR(glm::dot(g.GeometricNormal(i), n), 1.0f, 1e-5f);
      EXPECT_EQ(g.materialId[i], g.objectId[i]);
    }
  }
  EXPECT_GT(hits, 100u);
  EXPECT_GT(misses, 100u);
}

TEST(Reproject, StaticPointUnderMovingCameraMapsOntoItself) {
  Sequence s = WallAndFloor();
  EmbreeScene scene(s);
  const int w = 120, h = 80;
  // Pan and rotate (yaw and pitch) between the frames.
  const Camera prevCam = MakeCamera(Vec3(0, 0, 0), YawPitch(0, -5), w, h, 50);
  const Camera curCam = MakeCamera(Vec3(0.6f, 0.3f, -0.5f), YawPitch(6, -8), w, h, 50);
  const FrameState prevState = StateFor(prevCam, WallAndFloorXforms(), 0);
  const FrameState curState = StateFor(curCam, WallAndFloorXforms(), 1);
  GBuffer prev, cur;
  scene.Update(prevState);
  TracePrimary(scene, prevCam, prev);
  scene.Update(curState);
  TracePrimary(scene, curCam, cur);
  Reproject(curState, prevState, prev, scene.LightObjectId(), ReprojectionParams{}, cur);

  size_t onScreen = 0, valid = 0, offScreen = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const auto p = WallAndFloorHit(glm::dvec3(curCam.position), PixelDir(curCam, x, y));
      ASSERT_TRUE(p.has_value());
      // Analytic projection of this pixel's surface point into the previous camera.
      float ax = 0, ay = 0;
      ASSERT_TRUE(prevCam.Project(Vec3(*p), ax, ay));
      EXPECT_NEAR(cur.prevX[i], ax, 0.02f) << x << "," << y;
      EXPECT_NEAR(cur.prevY[i], ay, 0.02f) << x << "," << y;
      if (ax < 0.0f || ay < 0.0f || ax >= w || ay >= h) {
        ++offScreen;
        EXPECT_FALSE(cur.prevValid[i]);
        EXPECT_TRUE(cur.disoccluded[i]);
        continue;
      }
      ++onScreen;
      const int qx = static_cast<int>(std::floor(cur.prevX[i])), qy = static_cast<int>(std::floor(cur.prevY[i]));
      if (cur.prevValid[i]) {
        ++valid;
        EXPECT_FALSE(cur.disoccluded[i]);
        // The previous pixel that saw this point: its own surface point projects to its centre, and this
        // point lands within half a pixel of that centre.
        const size_t j = static_cast<size_t>(qy) * w + qx;
        float cx = 0, cy = 0;
        ASSERT_TRUE(prevCam.Project(prev.Position(j), cx, cy));
        EXPECT_NEAR(cx, qx + 0.5f, 0.01f);
        EXPECT_NEAR(cy, qy + 0.5f, 0.01f);
        EXPECT_LE(std::fabs(ax - cx), 0.5f + 0.02f);
        EXPECT_LE(std::fabs(ay - cy), 0.5f + 0.02f);
        EXPECT_EQ(prev.objectId[j], cur.objectId[i]);
      } else {
        // The only legitimate failure on screen: the nearest previous pixel lies on the wall/floor seam.
        bool seam = false;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = std::clamp(qx + dx, 0, w - 1), ny = std::clamp(qy + dy, 0, h - 1);
            seam |= prev.objectId[static_cast<size_t>(ny) * w + nx] != cur.objectId[i];
          }
        EXPECT_TRUE(seam) << "invalid reprojection away from the seam at " << x << "," << y;
        EXPECT_TRUE(cur.disoccluded[i]);
      }
    }
  }
  EXPECT_GT(offScreen, 0u);  // the pan must push some content out of view, or the test is too easy
  EXPECT_GE(valid, onScreen * 97 / 100);
}

TEST(Reproject, MovingObjectReprojectsThroughItsTransform) {
  Sequence s;
  s.materials.resize(2);
  s.objects.push_back(MakeObject("wall", QuadMesh(), false, 0));
  s.objects.push_back(MakeObject("box", BoxMesh(), true, 1));
  EmbreeScene scene(s);
  const int w = 120, h = 90;
  const Mat4 wall = Trs(Vec3(0, 0, -10), Vec3(0), Vec3(50, 50, 1));
  const Mat4 boxPrev = Trs(Vec3(-0.3f, 0.1f, -6), Vec3(10, 20, 0), Vec3(2));
  const Mat4 boxCur = Trs(Vec3(0.4f, 0.0f, -6), Vec3(10, 35, 5), Vec3(2));
  const Camera prevCam = MakeCamera(Vec3(0, 0.5f, 0), YawPitch(0, -4), w, h, 45);
  const Camera curCam = MakeCamera(Vec3(0.2f, 0.5f, 0), YawPitch(2, -4), w, h, 45);
  const FrameState prevState = StateFor(prevCam, {wall, boxPrev}, 0);
  const FrameState curState = StateFor(curCam, {wall, boxCur}, 1);
  GBuffer prev, cur;
  scene.Update(prevState);
  TracePrimary(scene, prevCam, prev);
  scene.Update(curState);
  TracePrimary(scene, curCam, cur);
  Reproject(curState, prevState, prev, scene.LightObjectId(), ReprojectionParams{}, cur);

  const glm::dmat4 motion = glm::dmat4(boxPrev) * glm::inverse(glm::dmat4(boxCur));
  size_t boxPixels = 0, valid = 0, wallDisoccluded = 0;
  for (size_t i = 0; i < cur.Size(); ++i) {
    if (cur.objectId[i] == 0 && cur.disoccluded[i]) ++wallDisoccluded;
    if (cur.objectId[i] != 1) continue;
    ++boxPixels;
    const glm::dvec3 pPrev = glm::dvec3(motion * glm::dvec4(glm::dvec3(cur.Position(i)), 1.0));
    float ax = 0, ay = 0;
    ASSERT_TRUE(prevCam.Project(Vec3(pPrev), ax, ay));
    EXPECT_NEAR(cur.prevX[i], ax, 0.02f);
    EXPECT_NEAR(cur.prevY[i], ay, 0.02f);
    if (cur.prevValid[i]) {
      ++valid;
      const size_t j = static_cast<size_t>(std::floor(ay)) * w + static_cast<size_t>(std::floor(ax));
      EXPECT_EQ(prev.objectId[j], 1);
      // The previous pixel saw the same face: the carried point lies on its plane, within half a pixel of
      // its centre on screen.
      const glm::dvec3 q(prev.Position(j));
      EXPECT_LT(std::fabs(glm::dot(pPrev - q, glm::dvec3(prev.GeometricNormal(j)))), 1e-4);
      float cx = 0, cy = 0;
      ASSERT_TRUE(prevCam.Project(prev.Position(j), cx, cy));
      EXPECT_LE(std::fabs(ax - cx), 0.5f + 0.02f);
      EXPECT_LE(std::fabs(ay - cy), 0.5f + 0.02f);
    }
  }
  EXPECT_GT(boxPixels, 500u);
  // Rotation turns some faces away and exposes others, so not all; but most of the box must carry over.
  EXPECT_GE(valid, boxPixels * 3 / 4);
  // The box moved right: wall it covered before, now visible, must be disoccluded.
  EXPECT_GT(wallDisoccluded, 50u);
}

TEST(Reproject, NoPreviousFrameLeavesEverythingInvalidAndNothingDisoccluded) {
  Sequence s = WallAndFloor();
  EmbreeScene scene(s);
  const Camera cam = MakeCamera(Vec3(0), YawPitch(0, 0), 32, 24, 45);
  const FrameState st = StateFor(cam, WallAndFloorXforms(), 0);
  scene.Update(st);
  GBuffer g, empty;
  TracePrimary(scene, cam, g);
  Reproject(st, st, empty, scene.LightObjectId(), ReprojectionParams{}, g);
  for (size_t i = 0; i < g.Size(); ++i) {
    EXPECT_FALSE(g.prevValid[i]);
    EXPECT_FALSE(g.disoccluded[i]);
  }
  // The same frame reprojected onto itself is valid everywhere it hit something.
  GBuffer again = g;
  Reproject(st, st, g, scene.LightObjectId(), ReprojectionParams{}, again);
  for (size_t i = 0; i < g.Size(); ++i) {
    EXPECT_EQ(again.prevValid[i], g.objectId[i] >= 0 ? 1 : 0);
    EXPECT_FALSE(again.disoccluded[i]);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Window bars: a wall with thin vertical bars in front, the camera pans parallel to the wall.
struct BarsScene {
  static constexpr int kBars = 7;
  static constexpr double kWallZ = -10.0;
  static constexpr double kBarZ = -4.0, kBarDepth = 0.1, kBarWidth = 0.2, kBarHeight = 40.0;
  static double BarX(int k) { return -3.25 + k; }  // no bar face is edge-on to either camera

  Sequence sequence;
  std::vector<Mat4> xforms;
  BarsScene() {
    sequence.materials.resize(2);
    sequence.objects.push_back(MakeObject("wall", QuadMesh(), false, 0));
    xforms.push_back(Trs(Vec3(0, 0, static_cast<float>(kWallZ)), Vec3(0), Vec3(100, 100, 1)));
    for (int k = 0; k < kBars; ++k) {
      sequence.objects.push_back(MakeObject("bar" + std::to_string(k), BoxMesh(), false, 1));
      xforms.push_back(Trs(Vec3(static_cast<float>(BarX(k)), 0, static_cast<float>(kBarZ)), Vec3(0),
                           Vec3(static_cast<float>(kBarWidth), static_cast<float>(kBarHeight),
                                static_cast<float>(kBarDepth))));
    }
  }
  static glm::dvec3 Lo(int k) { return {BarX(k) - kBarWidth / 2, -kBarHeight / 2, kBarZ - kBarDepth / 2}; }
  static glm::dvec3 Hi(int k) { return {BarX(k) + kBarWidth / 2, kBarHeight / 2, kBarZ + kBarDepth / 2}; }
  // First bar hit before tmax, as object id (1 + bar index), or 0 for none.
  static int BarHit(const glm::dvec3& o, const glm::dvec3& d, double tmax, double* tHit = nullptr) {
    int id = 0;
    double best = tmax;
    for (int k = 0; k < kBars; ++k) {
      if (auto t = RayBox(o, d, Lo(k), Hi(k)); t && *t < best) {
        best = *t;
        id = 1 + k;
      }
    }
    if (tHit) *tHit = best;
    return id;
  }
  // Object id the pixel centre ray sees (0 = wall).
  static int AnalyticId(const Camera& c, int x, int y) {
    const glm::dvec3 o(c.position), d = PixelDir(c, x, y);
    return BarHit(o, d, std::numeric_limits<double>::infinity());
  }
};

TEST(Reproject, WindowBarsPanFlagsExactlyTheBackgroundHiddenBehindBars) {
  BarsScene bars;
  EmbreeScene scene(bars.sequence);
  const int w = 160, h = 90;
  const Camera prevCam = MakeCamera(Vec3(0, 0, 0), Vec3(0, 0, -1), w, h, 40);
  const Camera curCam = MakeCamera(Vec3(0.35f, 0, 0), Vec3(0, 0, -1), w, h, 40);
  const FrameState prevState = StateFor(prevCam, bars.xforms, 0);
  const FrameState curState = StateFor(curCam, bars.xforms, 1);
  GBuffer prev, cur;
  scene.Update(prevState);
  TracePrimary(scene, prevCam, prev);
  scene.Update(curState);
  TracePrimary(scene, curCam, cur);
  Reproject(curState, prevState, prev, scene.LightObjectId(), ReprojectionParams{}, cur);

  std::vector<int> idCur(cur.Size()), idPrev(prev.Size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      idCur[static_cast<size_t>(y) * w + x] = BarsScene::AnalyticId(curCam, x, y);
      idPrev[static_cast<size_t>(y) * w + x] = BarsScene::AnalyticId(prevCam, x, y);
    }
  auto nearEdge = [&](const std::vector<int>& ids, int x, int y) {
    const int c = ids[static_cast<size_t>(std::clamp(y, 0, h - 1)) * w + std::clamp(x, 0, w - 1)];
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        if (ids[static_cast<size_t>(ny) * w + nx] != c) return true;
      }
    return false;
  };

  size_t expectedTotal = 0, flaggedTotal = 0, hiddenCount = 0, offScreenCount = 0;
  size_t tolerated = 0, toleratedMismatches = 0, exactMatches = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const glm::dvec3 o(curCam.position), d = PixelDir(curCam, x, y);
      // What the current pixel sees, analytically: a bar point or a wall point.
      double tBar = 0;
      const int id = BarsScene::BarHit(o, d, std::numeric_limits<double>::infinity(), &tBar);
      const glm::dvec3 p = id ? o + tBar * d : o + *RayPlaneZ(o, d, BarsScene::kWallZ) * d;
      float ax = -1, ay = -1;
      const bool projected = prevCam.Project(Vec3(p), ax, ay);
      const bool onScreen = projected && ax >= 0 && ay >= 0 && ax < w && ay < h;
      bool expected = !onScreen;
      if (id == 0 && onScreen) {
        // Hidden from the previous camera: a bar lies on the segment from it to the wall point.
        const glm::dvec3 po(prevCam.position);
        const glm::dvec3 seg = p - po;
        const double len = glm::length(seg);
        if (BarsScene::BarHit(po, seg / len, len * (1 - 1e-9))) {
          expected = true;
          ++hiddenCount;
        }
      }
      offScreenCount += !onScreen;
      const bool flagged = cur.disoccluded[i] != 0;
      expectedTotal += expected;
      flaggedTotal += flagged;
      EXPECT_EQ(cur.objectId[i] >= 0, true);
      const bool nearSilhouette =
          nearEdge(idCur, x, y) ||
          (onScreen && nearEdge(idPrev, static_cast<int>(std::floor(ax)), static_cast<int>(std::floor(ay))));
      if (nearSilhouette) {
        ++tolerated;
        toleratedMismatches += flagged != expected;
        continue;
      }
      EXPECT_EQ(cur.objectId[i], id) << "Embree and the analytic scene disagree at " << x << "," << y;
      EXPECT_EQ(flagged, expected) << "pixel " << x << "," << y << " id " << id;
      exactMatches += flagged == expected;
    }
  }
  std::printf("window bars: %zu expected (%zu hidden, %zu off screen), %zu flagged; %zu pixels near a silhouette, "
              "%zu of them differ\n",
              expectedTotal, hiddenCount, offScreenCount, flaggedTotal, tolerated, toleratedMismatches);
  // Non-vacuous: each bar hides a strip of several pixels' width over the full height.
  EXPECT_GT(hiddenCount, static_cast<size_t>(BarsScene::kBars * h * 2));
  EXPECT_GT(offScreenCount, 0u);
  // The silhouette band is thin, and only part of it differs.
  EXPECT_LT(tolerated, cur.Size() / 3);
  EXPECT_LE(toleratedMismatches, tolerated / 2);
  EXPECT_EQ(exactMatches, cur.Size() - tolerated);
}

TEST(TracePrimary, OutputIdenticalWithOneAndTwoThreads) {
  BarsScene bars;
  bars.sequence.objects.push_back(MakeObject("box", BoxMesh(), true, 1));
  bars.xforms.push_back(Trs(Vec3(0.5f, -0.5f, -6), Vec3(15, 30, 0), Vec3(1.5f)));
  Light l;
  l.name = "light";
  l.vertices = {Vec3(-1, 3, -5), Vec3(1, 3, -5), Vec3(1, 3, -7)};
  bars.sequence.lights.push_back(l);
  EmbreeScene scene(bars.sequence);
  const Camera cam = MakeCamera(Vec3(0.1f, 0.2f, 0), YawPitch(3, 5), 96, 64, 50);
  FrameState st = StateFor(cam, bars.xforms, 0);
  st.lightOn = {1};
  scene.Update(st);
  GBuffer one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    TracePrimary(scene, cam, one);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    TracePrimary(scene, cam, two);
  }
  EXPECT_TRUE(SameBits(one, two));
  size_t lightPixels = 0;
  for (size_t i = 0; i < one.Size(); ++i) lightPixels += one.lightId[i] >= 0;
  EXPECT_GT(lightPixels, 0u);
}

}  // namespace gbuffer_test
}  // namespace restir
