#include "sim/scene/gbuffer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace restir {

void GBuffer::Resize(int w, int h) {
  width = w > 0 ? w : 0;
  height = h > 0 ? h : 0;
  const size_t n = Size();
  for (auto* v : {&posX, &posY, &posZ, &ngX, &ngY, &ngZ, &nsX, &nsY, &nsZ, &errorScale, &depth}) v->assign(n, 0.0f);
  for (auto* v : {&texelR, &texelG, &texelB}) v->clear();  // TracePrimary sizes them for textured scenes only
  bsdfId.assign(n, -1);
  prevX.assign(n, -1.0f);  // -1: not reprojected (Reproject also writes -1 where a point cannot be projected)
  prevY.assign(n, -1.0f);
  objectId.assign(n, -1);
  materialId.assign(n, -1);
  lightId.assign(n, -1);
  prevValid.assign(n, 0);
  disoccluded.assign(n, 0);
}

int32_t TextureTableOffset(size_t materialCount, int width, int height, int frame) {
  const int64_t pixels = int64_t(width > 0 ? width : 0) * int64_t(height > 0 ? height : 0);
  return static_cast<int32_t>(int64_t(materialCount) + (frame & 1) * pixels);
}

void TracePrimary(const EmbreeScene& scene, const Camera& camera, GBuffer& gbuffer, const SurfaceTextures* tex) {
  if (gbuffer.width != camera.width || gbuffer.height != camera.height ||
      gbuffer.objectId.size() != gbuffer.Size() || gbuffer.bsdfId.size() != gbuffer.Size()) {
    gbuffer.Resize(camera.width, camera.height);
  }
  const int w = gbuffer.width;
  const float inf = std::numeric_limits<float>::infinity();
  // The texels cost 12 bytes per pixel: kept only while the scene has textures (issue 6's per-pixel budget).
  for (auto* v : {&gbuffer.texelR, &gbuffer.texelG, &gbuffer.texelB}) {
    if (tex)
      v->assign(gbuffer.Size(), 1.0f);
    else
      std::vector<float>().swap(*v);
  }
  // Every pixel is written by exactly one task and depends only on its own ray, so the partitioning (thread
  // count) cannot change a bit of the output.
  tbb::parallel_for(tbb::blocked_range<int>(0, gbuffer.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
        const Vec3 dir = camera.RayDirection(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
        const SurfaceHit h = scene.Intersect(camera.position, dir, inf);
        gbuffer.prevX[i] = -1.0f;
        gbuffer.prevY[i] = -1.0f;
        gbuffer.prevValid[i] = 0;
        gbuffer.disoccluded[i] = 0;
        if (!h.hit) {
          gbuffer.posX[i] = gbuffer.posY[i] = gbuffer.posZ[i] = 0.0f;
          gbuffer.ngX[i] = gbuffer.ngY[i] = gbuffer.ngZ[i] = 0.0f;
          gbuffer.nsX[i] = gbuffer.nsY[i] = gbuffer.nsZ[i] = 0.0f;
          gbuffer.errorScale[i] = 0.0f;
          gbuffer.objectId[i] = -1;
          gbuffer.materialId[i] = -1;
          gbuffer.bsdfId[i] = -1;
          gbuffer.lightId[i] = -1;
          gbuffer.depth[i] = 0.0f;
          continue;
        }
        gbuffer.posX[i] = h.position.x;
        gbuffer.posY[i] = h.position.y;
        gbuffer.posZ[i] = h.position.z;
        gbuffer.ngX[i] = h.geometricNormal.x;
        gbuffer.ngY[i] = h.geometricNormal.y;
        gbuffer.ngZ[i] = h.geometricNormal.z;
        gbuffer.nsX[i] = h.shadingNormal.x;
        gbuffer.nsY[i] = h.shadingNormal.y;
        gbuffer.nsZ[i] = h.shadingNormal.z;
        gbuffer.errorScale[i] = h.errorScale;
        gbuffer.objectId[i] = h.objectId;
        gbuffer.materialId[i] = h.materialId;
        gbuffer.bsdfId[i] = h.materialId;
        Vec3 texel(1.0f);
        if (tex && h.materialId >= 0 && size_t(h.materialId) < tex->materials->size()) {
          const int32_t t = (*tex->materials)[size_t(h.materialId)].baseColorTexture;
          if (t >= 0 && size_t(t) < tex->textures->size()) {
            texel = SampleBilinear((*tex->textures)[size_t(t)], h.texcoord.x, h.texcoord.y);
            gbuffer.bsdfId[i] = tex->tableOffset + static_cast<int32_t>(i);
          }
        }
        if (tex) {
          gbuffer.texelR[i] = texel.x;
          gbuffer.texelG[i] = texel.y;
          gbuffer.texelB[i] = texel.z;
        }
        gbuffer.lightId[i] = h.lightId;
        gbuffer.depth[i] = camera.ViewDepth(h.position);
      }
    }
  });
}

namespace {

bool SameMatrix(const Mat4& a, const Mat4& b) { return std::memcmp(&a[0][0], &b[0][0], sizeof(Mat4)) == 0; }

}  // namespace

void Reproject(const FrameState& currentState, const FrameState& previousState, const GBuffer& previous,
               int32_t lightObjectId, const ReprojectionParams& params, GBuffer& current) {
  const size_t n = current.Size();
  if (previous.Size() == 0) {
    for (size_t i = 0; i < n; ++i) {
      current.prevX[i] = -1.0f;
      current.prevY[i] = -1.0f;
      current.prevValid[i] = 0;
      current.disoccluded[i] = 0;
    }
    return;
  }

  // Per object: the world-to-world motion from this frame back to the previous one, for points and for
  // normals. Objects whose transform did not change map exactly onto themselves (no inverse round-off).
  const size_t objectCount = currentState.objectToWorld.size();
  std::vector<Mat4> pointMotion(objectCount, Mat4(1.0f));
  std::vector<glm::mat3> normalMotion(objectCount, glm::mat3(1.0f));
  std::vector<uint8_t> moved(objectCount, 0);
  std::vector<uint8_t> known(objectCount, 0);
  for (size_t o = 0; o < objectCount; ++o) {
    if (o >= previousState.objectToWorld.size()) continue;
    known[o] = 1;
    const Mat4& cur = currentState.objectToWorld[o];
    const Mat4& prev = previousState.objectToWorld[o];
    if (SameMatrix(cur, prev)) continue;
    moved[o] = 1;
    pointMotion[o] = prev * glm::inverse(cur);
    // Normals transform by the inverse transpose: back to object space with transpose(cur) (up to scale),
    // then out with inverse-transpose(prev).
    normalMotion[o] = glm::transpose(glm::inverse(glm::mat3(prev))) * glm::transpose(glm::mat3(cur));
  }

  const Camera& prevCam = previousState.camera;
  const int pw = previous.width;
  const int ph = previous.height;
  const int w = current.width;

  tbb::parallel_for(tbb::blocked_range<int>(0, current.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
        current.prevX[i] = -1.0f;
        current.prevY[i] = -1.0f;
        current.prevValid[i] = 0;
        current.disoccluded[i] = 0;
        const int32_t obj = current.objectId[i];
        if (obj < 0) continue;

        Vec3 p = current.Position(i);
        Vec3 ng = current.GeometricNormal(i);
        bool ok = true;
        // Emitters are static world-space geometry: identity motion.
        if (obj != lightObjectId) {
          const size_t o = static_cast<size_t>(obj);
          if (o >= objectCount || !known[o]) {
            ok = false;
          } else if (moved[o]) {
            p = Vec3(pointMotion[o] * Vec4(p, 1.0f));
            // The normal stays on the side of the surface it was on (the flipped, camera-facing one).
            ng = glm::normalize(normalMotion[o] * ng);
          }
        }

        float px = -1.0f, py = -1.0f;
        if (ok && prevCam.Project(p, px, py)) {
          current.prevX[i] = px;
          current.prevY[i] = py;
          if (px >= 0.0f && py >= 0.0f && px < static_cast<float>(pw) && py < static_cast<float>(ph)) {
            const int qx = std::min(static_cast<int>(std::floor(px)), pw - 1);
            const int qy = std::min(static_cast<int>(std::floor(py)), ph - 1);
            const size_t j = static_cast<size_t>(qy) * static_cast<size_t>(pw) + static_cast<size_t>(qx);
            const float expected = prevCam.ViewDepth(p);
            const bool sameSurface = previous.objectId[j] == obj && previous.materialId[j] == current.materialId[i];
            const bool depthOk = std::fabs(previous.depth[j] - expected) <= params.depthThreshold * expected;
            const bool normalOk = glm::dot(previous.GeometricNormal(j), ng) >= params.normalThreshold;
            current.prevValid[i] = sameSurface && depthOk && normalOk ? 1 : 0;
          }
        }
        current.disoccluded[i] = current.prevValid[i] ? 0 : 1;
      }
    }
  });
}

std::vector<uint16_t> AgeDisocclusion(const GBuffer& current, const std::vector<uint16_t>& previousAge) {
  const int w = current.width, h = current.height;
  std::vector<uint16_t> age(current.Size(), kNeverDisoccluded);
  for (size_t i = 0; i < current.Size(); ++i) {
    if (current.disoccluded[i]) {
      age[i] = 0;
    } else if (current.prevValid[i] && !previousAge.empty()) {
      const int px = std::clamp(static_cast<int>(current.prevX[i]), 0, w - 1);
      const int py = std::clamp(static_cast<int>(current.prevY[i]), 0, h - 1);
      const uint16_t a = previousAge[static_cast<size_t>(py) * w + px];
      age[i] = a == kNeverDisoccluded ? a : static_cast<uint16_t>(std::min<int>(a + 1, kNeverDisoccluded - 1));
    }
  }
  return age;
}

std::vector<uint8_t> RecentDisocclusionMask(const std::vector<uint16_t>& age) {
  std::vector<uint8_t> mask(age.size());
  for (size_t i = 0; i < age.size(); ++i) mask[i] = age[i] < kDisocclusionWindow;
  return mask;
}

}  // namespace restir
