// Brute-force direct irradiance with exact visibility: an answer the project did not compute. The reference
// renderer and every estimator share one shadow-ray spawn rule, so comparing them with each other cannot find
// an error in that rule. This integrator is written independently of it: its own Embree scene, shadow
// segments traced from the receiver point itself to the emitter point itself with no offsets,
// self-intersections removed by an exact geometric argument instead, and a deterministic quadrature over
// every emitter triangle with an error estimate. Tests only; slow by design.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/math.h"
#include "sim/scene/sequence.h"

namespace restir::test {

struct QuadratureResult {
  glm::dvec3 irradiance{0.0};     // E(x) per RGB channel
  glm::dvec3 errorEstimate{0.0};  // estimated bound on |irradiance - exact|, per channel
  uint64_t rays = 0;              // shadow segments traced (all rules and grids)
};

// Direct irradiance E(x) = Σ_lights L_e ∫ cosθ_x cosθ_y / d² V(x, y) dA(y) at a receiver point x with unit
// normal n, over every switched-on emitter triangle of a frame.
//
// Visibility V(x, y) is the segment x -> y traced exactly: origin x, direction y - x (unnormalised),
// t in [0, 1], no origin or end offsets. Only two kinds of hits are ignored, both by the filter callback:
//   (a) triangles of the light that y lies on that are coplanar with y's emitter triangle, and
//   (b) triangles of the receiver's object that are coplanar with the receiver plane through x (normal n).
// Both are exact, not approximations. The segment from x (strictly in front of the emitter plane: emission is
// one-sided) to y (on that plane) meets the plane in y alone, so a triangle in that plane can only be hit at
// the segment's end, which is where the emitter is, not an occluder. Likewise only directions with positive
// n·(y - x) are traced, so the segment leaves the receiver plane at x and never returns to it: a triangle in
// that plane can only be hit at t = 0, which is x's own surface. For the shipped shapes this means: a quad
// light (two coplanar triangles) or a triangle light never shadows its own points; a flat quad or a box face
// (two coplanar triangles) never shadows its own points, while the box's other faces, other bars of a
// window_bars object and the other facets of a tessellated sphere (not coplanar with x's facet) still occlude
// as they physically do. Every other triangle in the scene, emitters included (from either side), is an
// occluder. The tolerance of "coplanar" only has to absorb float rounding of the stored vertices and of x and
// n (a few ulps of the coordinates' magnitude): kCoplanarTolerance times the largest coordinate, 4 µm at 1 m,
// 4 mm at 1 km. RTC_SCENE_FLAG_ROBUST keeps Embree's triangle test watertight, so a segment through the
// shared diagonal of an occluding quad cannot slip between its two triangles.
//
// Quadrature: two deterministic rules per emitter triangle, everything in double except the rays Embree
// traces.
//   R: the triangle's barycentric grid (grid² congruent subtriangles), Radon's 7-point rule (degree 5) on
//      each subtriangle;
//   D: the Duffy map of the unit square onto the triangle, apex at the vertex opposite the longest edge,
//      grid x grid cells with the 3 x 3 Gauss–Legendre product rule (degree 5 in each variable) on each.
// Their sample rows run in different directions: R's parallel to all three edges, D's parallel to the longest
// edge (a quad light's diagonal) and fanning out of the apex. That matters because shadow edges in the
// shipped scenes are mostly parallel to the emitters' edges (axis-aligned boxes, bars and lights), and a
// shadow edge parallel to a rule's rows is the worst case for that rule: every cell it cuts errs the same
// way, and a strip between the edge and the nearest row of samples is misclassified at every nested level
// alike, so that level differences of one rule stay small while its error does not (measured with R alone: a
// shadow edge 0.05% of the light's width off a grid line shared by grids 4 to 64 gave the same error, 3e-4 of
// the irradiance, at every one of them, and level differences at rounding level, 1e-16). The other rule's
// rows cross such an edge at an angle.
//
// The answer is (R_grid + D_grid) / 2. Where a shadow edge crosses the triangle the integrand jumps and both
// rules are only O(h) there, with pseudo-random signs from cell to cell, so the error estimate is
//   kErrorFactor · max(|R_grid - D_grid|, |R_grid/2 - D_grid/2|, |R_grid - R_grid/2|, |D_grid - D_grid/2|)
// per triangle, the triangles' estimates added (errors of different triangles are not assumed to cancel). The
// rule differences expose errors aligned with either rule's rows; the level differences expose the O(h) edge
// error (if a level's error at least halves when h does, |Q_grid - Q_grid/2| >= |e_grid|). No difference of
// finitely many samples bounds the error of an integrand with jumps, so the factor is empirical: on 256
// penumbra receivers behind straight edges at 10°, 45° and 72° to a quad light's sides and behind a thin
// slab's edge parallel to them, each at grids 16, 32 and 64 (768 evaluations against Lambert on the clipped
// light), the largest |error| / max(...) was 1.42 and the 99th percentile 0.75, so kErrorFactor = 3 leaves a
// margin of 2 (visibility_quadrature_test.cpp re-checks the bound on its own receivers). On the same
// receivers one rule's level differences alone would have needed a factor of 5 (grids N, N/2, N/4 and N - 1)
// to 10^12 (N and N/2), and the rule difference alone one of 110. Features narrower than the coarse level's
// sample spacing (about 1/(1.5 grid) of the emitter) can be missed by every rule and level alike; no estimate
// built from these samples can see them.
//
// Where the triangle lies wholly above x's horizon and every sample of both rules at grid/4 and grid/2 saw
// the same visibility (all unoccluded, or all blocked), the triangle is taken to have no shadow edge: the
// integrand is smooth there, both rules are of degree 5, and the fine grid would only cost rays. Its answer
// is then (R_grid/2 + D_grid/2) / 2 with the estimate
//   kErrorFactor · max(|R_grid/2 - D_grid/2|, |R_grid/2 - R_grid/4|, |D_grid/2 - D_grid/4|):
// the level differences are needed because two rules of the same degree at the same grid tend to err the same
// way on a smooth integrand, so their difference alone can be 10x below the error. A triangle crossing the
// horizon has a kink (cosθ_x clamped at 0) and always takes the full grid.
class VisibilityQuadrature {
 public:
  static constexpr double kErrorFactor = 3.0;
  static constexpr double kCoplanarTolerance = 4e-6;

  VisibilityQuadrature(const Sequence& sequence, const FrameState& state) {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw std::runtime_error("VisibilityQuadrature: rtcNewDevice failed");
    try {
      Build(sequence, state);
    } catch (...) {
      Release();  // the destructor does not run for a constructor that throws
      throw;
    }
  }
  ~VisibilityQuadrature() { Release(); }
  VisibilityQuadrature(const VisibilityQuadrature&) = delete;
  VisibilityQuadrature& operator=(const VisibilityQuadrature&) = delete;

  // Irradiance at x with geometric normal n (both the cosine and the hemisphere use it; shading normals are
  // not modelled) on object `receiverObject` (index into Sequence::objects; -1: a point on no object, which
  // excludes nothing). `grid`: a multiple of 4; cells per side of each rule's finest level. Thread-safe:
  // concurrent calls share only the committed Embree scene.
  QuadratureResult Irradiance(const Vec3& x, const Vec3& n, int receiverObject, int grid) const {
    if (grid < 4 || grid % 4 != 0)
      throw std::invalid_argument("VisibilityQuadrature: grid must be a multiple of 4");
    Query q;
    rtcInitIntersectContext(&q.base);
    q.base.filter = &Filter;
    q.owner = this;
    q.x = glm::dvec3(x);
    q.n = glm::normalize(glm::dvec3(n));
    q.receiverGroup = receiverObject >= 0 && receiverObject < objectCount_ ? receiverObject : -1;
    QuadratureResult result;
    for (size_t l = 0; l < lightGroup_.size(); ++l) {
      const glm::dvec3& radiance = lightRadiance_[l];
      if (radiance == glm::dvec3(0.0)) continue;
      q.lightGroup = lightGroup_[l];
      for (const Triangle& t : groups_[q.lightGroup].triangles) {
        if (t.area <= 0.0) continue;
        // One-sided emission: x must be strictly in front of the emitter's plane.
        const double s = glm::dot(t.normal, q.x - t.v[0]);
        if (!(s > 0.0)) continue;
        int above = 0;
        for (const glm::dvec3& v : t.v) above += glm::dot(q.n, v - q.x) > 0.0 ? 1 : 0;
        if (above == 0) continue;  // wholly below the receiver's horizon
        q.lightTriangle = &t;
        Tally coarse;
        const double r4 = IntegrateRadon(q, t, s, grid / 4, coarse),
                     d4 = IntegrateDuffy(q, t, s, grid / 4, coarse);
        const double r2 = IntegrateRadon(q, t, s, grid / 2, coarse),
                     d2 = IntegrateDuffy(q, t, s, grid / 2, coarse);
        result.rays += coarse.rays;
        double value, estimate;
        if (above == 3 && (coarse.visible == 0 || coarse.blocked == 0)) {
          value = 0.5 * (r2 + d2);
          estimate = std::max({std::abs(r2 - d2), std::abs(r2 - r4), std::abs(d2 - d4)});
        } else {
          Tally fine;
          const double r1 = IntegrateRadon(q, t, s, grid, fine), d1 = IntegrateDuffy(q, t, s, grid, fine);
          result.rays += fine.rays;
          value = 0.5 * (r1 + d1);
          estimate = std::max({std::abs(r1 - d1), std::abs(r2 - d2), std::abs(r1 - r2), std::abs(d1 - d2)});
        }
        result.irradiance += radiance * value;
        result.errorEstimate += radiance * (kErrorFactor * estimate);
      }
    }
    return result;
  }

 private:
  struct Triangle {
    std::array<glm::dvec3, 3> v;  // the float vertices Embree intersects, widened
    glm::dvec3 normal{0.0};       // unit, towards cross(v1 - v0, v2 - v0) (an emitter's lit side)
    double area = 0.0;
    double scale = 0.0;  // largest |coordinate|, for the coplanarity tolerance
  };

  // One Embree geometry: an object's triangles (world space) or a light's. Its geometry id tags it: ids below
  // the object count are Sequence::objects indices, the rest Sequence::lights indices plus the object count;
  // Embree's primID is the triangle's index within the object's mesh or the light's vertex list.
  struct Group {
    std::vector<Triangle> triangles;
  };

  // One ray's context. Embree hands the filter the RTCIntersectContext pointer it was given; `base` is the
  // first member of a standard-layout struct, so the filter can recover the rest.
  struct Query {
    RTCIntersectContext base;
    const VisibilityQuadrature* owner = nullptr;
    glm::dvec3 x{0.0}, n{0.0};
    int receiverGroup = -1;  // geometry id of the receiver's object, or -1
    int lightGroup = -1;     // geometry id of the light the segment ends on
    const Triangle* lightTriangle = nullptr;
  };

  struct Tally {
    uint64_t rays = 0, visible = 0, blocked = 0;
  };

  void Build(const Sequence& sequence, const FrameState& state) {
    scene_ = rtcNewScene(device_);
    // Robust: watertight triangle tests. Context filter: the per-ray exclusions need the ray's receiver and
    // emitter, which only the intersect context can carry.
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    for (size_t o = 0; o < sequence.objects.size(); ++o) {
      const Mesh& mesh = sequence.objects[o].mesh;
      const glm::dmat4 m(state.objectToWorld.at(o));
      std::vector<Vec3> world;
      world.reserve(mesh.positions.size());
      for (const Vec3& p : mesh.positions)
        world.push_back(Vec3(glm::dvec3(m * glm::dvec4(glm::dvec3(p), 1.0))));
      std::vector<Vec3> soup;
      soup.reserve(mesh.triangles.size() * 3);
      for (const glm::uvec3& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) soup.push_back(world.at(t[k]));
      AddGroup(soup);
    }
    objectCount_ = static_cast<int>(sequence.objects.size());
    for (size_t l = 0; l < sequence.lights.size(); ++l) {
      const Light& light = sequence.lights[l];
      lightGroup_.push_back(static_cast<int>(groups_.size()));
      AddGroup(light.vertices);
      const bool on = l < state.lightOn.size() ? state.lightOn[l] != 0 : true;
      lightRadiance_.push_back(on ? glm::dvec3(light.radiance) : glm::dvec3(0.0));
    }
    rtcCommitScene(scene_);
    if (rtcGetDeviceError(device_) != RTC_ERROR_NONE)
      throw std::runtime_error("VisibilityQuadrature: Embree scene build failed");
  }

  void AddGroup(const std::vector<Vec3>& soup) {
    Group g;
    const size_t count = soup.size() / 3;
    for (size_t i = 0; i < count; ++i) {
      Triangle t;
      for (int k = 0; k < 3; ++k) {
        t.v[k] = glm::dvec3(soup[3 * i + k]);
        t.scale = std::max({t.scale, std::abs(t.v[k].x), std::abs(t.v[k].y), std::abs(t.v[k].z)});
      }
      const glm::dvec3 c = glm::cross(t.v[1] - t.v[0], t.v[2] - t.v[0]);
      const double len = glm::length(c);
      t.area = 0.5 * len;
      if (len > 0.0) t.normal = c / len;
      g.triangles.push_back(t);
    }
    const unsigned id = static_cast<unsigned>(groups_.size());
    groups_.push_back(std::move(g));
    if (count == 0) return;
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), soup.size()));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                              RTC_FORMAT_UINT3, 3 * sizeof(unsigned), count));
    for (size_t i = 0; i < soup.size(); ++i) {
      vb[3 * i + 0] = soup[i].x;
      vb[3 * i + 1] = soup[i].y;
      vb[3 * i + 2] = soup[i].z;
    }
    for (size_t i = 0; i < 3 * count; ++i) ib[i] = static_cast<unsigned>(i);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene_, geom, id);
    rtcReleaseGeometry(geom);
  }

  void Release() {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
    scene_ = nullptr;
    device_ = nullptr;
  }

  // All three vertices of `t` within the tolerance of the plane through p with unit normal m.
  static bool Coplanar(const Triangle& t, const glm::dvec3& p, const glm::dvec3& m) {
    const double scale = std::max({1.0, t.scale, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    const double tol = kCoplanarTolerance * scale;
    for (const glm::dvec3& v : t.v)
      if (!(std::abs(glm::dot(m, v - p)) <= tol)) return false;
    return true;
  }

  static void Filter(const RTCFilterFunctionNArguments* args) {
    const Query& q = *reinterpret_cast<const Query*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
      if (args->valid[i] != -1) continue;
      const unsigned geomId = RTCHitN_geomID(args->hit, args->N, i);
      const unsigned primId = RTCHitN_primID(args->hit, args->N, i);
      const Triangle& hit = q.owner->groups_[geomId].triangles[primId];
      const int id = static_cast<int>(geomId);
      if (id == q.lightGroup && Coplanar(hit, q.lightTriangle->v[0], q.lightTriangle->normal))
        args->valid[i] = 0;
      else if (id == q.receiverGroup && Coplanar(hit, q.x, q.n))
        args->valid[i] = 0;
    }
  }

  bool Visible(Query& q, const glm::dvec3& y) const {
    RTCRay ray{};
    ray.org_x = static_cast<float>(q.x.x);
    ray.org_y = static_cast<float>(q.x.y);
    ray.org_z = static_cast<float>(q.x.z);
    const glm::dvec3 d = y - q.x;
    ray.dir_x = static_cast<float>(d.x);
    ray.dir_y = static_cast<float>(d.y);
    ray.dir_z = static_cast<float>(d.z);
    ray.tnear = 0.0f;
    ray.tfar = 1.0f;
    ray.mask = 0xffffffffu;
    rtcOccluded1(scene_, &q.base, &ray);
    return ray.tfar >= 0.0f;  // Embree sets tfar to -inf on an occluding hit
  }

  // The integrand at y times its visibility. With y on the emitter plane, cosθ_y · d = n_t · (x - y) = s is
  // the same for every y, so cosθ_x cosθ_y / d² = (n · ω) s / d⁴ with ω = y - x. Directions below x's horizon
  // are zero and not traced.
  double Sample(Query& q, const glm::dvec3& y, double s, Tally& tally) const {
    const glm::dvec3 w = y - q.x;
    const double cx = glm::dot(q.n, w);
    if (!(cx > 0.0)) return 0.0;
    const double d2 = glm::dot(w, w);
    ++tally.rays;
    if (!Visible(q, y)) {
      ++tally.blocked;
      return 0.0;
    }
    ++tally.visible;
    return cx * s / (d2 * d2);
  }

  // Rule R: grid² congruent subtriangles (upward cells (i, j) with i + j < grid, downward ones with
  // i + j < grid - 1), Radon's (1948) 7-point rule on each: the centroid and two orbits (a, a, 1 - 2a).
  double IntegrateRadon(Query& q, const Triangle& t, double s, int grid, Tally& tally) const {
    static const double r15 = std::sqrt(15.0);
    static const double a1 = (6.0 - r15) / 21.0, a2 = (6.0 + r15) / 21.0;
    static const double w0 = 9.0 / 40.0, w1 = (155.0 - r15) / 1200.0, w2 = (155.0 + r15) / 1200.0;
    static const std::array<std::array<double, 4>, 7> rule = {{{1.0 / 3, 1.0 / 3, 1.0 / 3, w0},
                                                               {a1, a1, 1.0 - 2.0 * a1, w1},
                                                               {a1, 1.0 - 2.0 * a1, a1, w1},
                                                               {1.0 - 2.0 * a1, a1, a1, w1},
                                                               {a2, a2, 1.0 - 2.0 * a2, w2},
                                                               {a2, 1.0 - 2.0 * a2, a2, w2},
                                                               {1.0 - 2.0 * a2, a2, a2, w2}}};
    const glm::dvec3 e1 = (t.v[1] - t.v[0]) / static_cast<double>(grid);
    const glm::dvec3 e2 = (t.v[2] - t.v[0]) / static_cast<double>(grid);
    auto corner = [&](int i, int j) {
      return t.v[0] + static_cast<double>(i) * e1 + static_cast<double>(j) * e2;
    };
    double sum = 0.0;
    auto cell = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
      for (const auto& p : rule) sum += p[3] * Sample(q, p[0] * a + p[1] * b + p[2] * c, s, tally);
    };
    for (int i = 0; i < grid; ++i) {
      for (int j = 0; i + j < grid; ++j) {
        cell(corner(i, j), corner(i + 1, j), corner(i, j + 1));
        if (i + j + 2 <= grid) cell(corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1));
      }
    }
    return sum * t.area / (static_cast<double>(grid) * static_cast<double>(grid));
  }

  // Rule D: y = A + σ (B - A) + σ τ (C - B) maps (σ, τ) in the unit square onto the triangle with Jacobian
  // 2 area σ (Duffy 1982); A is the vertex opposite the longest edge BC. grid x grid cells, 3 x 3
  // Gauss–Legendre points on each.
  double IntegrateDuffy(Query& q, const Triangle& t, double s, int grid, Tally& tally) const {
    static const double g = 0.5 * std::sqrt(0.6);
    static const std::array<double, 3> nodes = {0.5 - g, 0.5, 0.5 + g};
    static const std::array<double, 3> weights = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
    int apex = 0;
    double longest = -1.0;
    for (int k = 0; k < 3; ++k) {
      const double len = glm::length(t.v[(k + 2) % 3] - t.v[(k + 1) % 3]);
      if (len > longest) {
        longest = len;
        apex = k;
      }
    }
    const glm::dvec3 a = t.v[apex], b = t.v[(apex + 1) % 3], c = t.v[(apex + 2) % 3];
    const double inv = 1.0 / static_cast<double>(grid);
    double sum = 0.0;
    for (int i = 0; i < grid; ++i) {
      for (int k = 0; k < 3; ++k) {
        const double sigma = (static_cast<double>(i) + nodes[k]) * inv;
        const glm::dvec3 p = a + sigma * (b - a), d = sigma * (c - b);
        double row = 0.0;
        for (int j = 0; j < grid; ++j)
          for (int m = 0; m < 3; ++m)
            row += weights[m] * Sample(q, p + ((static_cast<double>(j) + nodes[m]) * inv) * d, s, tally);
        sum += weights[k] * sigma * row;
      }
    }
    return sum * 2.0 * t.area * inv * inv;
  }

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<Group> groups_;
  int objectCount_ = 0;
  std::vector<int> lightGroup_;            // geometry id of each Sequence::lights entry
  std::vector<glm::dvec3> lightRadiance_;  // zero while switched off (still an occluder)
};

}  // namespace restir::test
