// Highway kernel, scalar twin and dispatcher of the light-selection kernel (core/light_selection_kernel.h). The
// per-target part is compiled once per Highway target (foreach_target.h); the rest once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): a lane is a receiver and the light is broadcast, so each lane computes the scalar
// expressions of LightIrradianceEstimate, core/polygon_irradiance.h HorizonClippedPolygonIrradiance and
// LightSelectionWeight term for term in the same order (branches become selects; a value computed on a path the
// scalar code would not take never reaches a result), and each receiver's sums run over the lights in order,
// one add per light, whatever the width. No MulAdd, no approximate reciprocals.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/light_selection_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/kernel-inl.h"
#include "core/light_selection_kernel.h"
#include "core/polygon_irradiance.h"
#include "core/shading-inl.h"
#include "core/shading.h"
#include "core/simd.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace {

// core/polygon_irradiance.h ThetaOverSinTheta.
HWY_INLINE VF ThetaOverSinThetaV(VF x, VF sum2) {
  const DF df;
  const VF zero = hn::Zero(df);
  const VF y = hn::Abs(x);
  VF g = hn::Add(hn::Mul(hn::Set(df, -0.06696824729442596f), y), hn::Set(df, 0.27594730257987976f));
  g = hn::Sub(hn::Mul(g, y), hn::Set(df, 0.5419473648071289f));
  g = hn::Add(hn::Mul(g, y), hn::Set(df, 0.7602066397666931f));
  g = hn::Sub(hn::Mul(g, y), hn::Set(df, 0.9980255961418152f));
  g = hn::Add(hn::Mul(g, y), hn::Set(df, 1.570770502090454f));
  const VF sin2 = hn::Mul(hn::Sub(hn::Set(df, 1.0f), x), hn::Mul(hn::Set(df, 0.5f), sum2));
  const VF floor = hn::Set(df, 1e-12f);
  const VF back =
      hn::Sub(hn::Div(hn::Set(df, 3.14159265358979f), hn::Sqrt(hn::IfThenElse(hn::Gt(sin2, floor), sin2, floor))), g);
  return hn::IfThenElse(hn::Ge(x, zero), g, back);
}

// core/polygon_irradiance.h LambertEdgeTerm.
HWY_INLINE VF LambertEdgeTermV(const VF (&a)[3], const VF (&b)[3], const VF (&n)[3]) {
  const VF c[3] = {hn::Sub(hn::Mul(a[1], b[2]), hn::Mul(b[1], a[2])), hn::Sub(hn::Mul(a[2], b[0]), hn::Mul(b[2], a[0])),
                   hn::Sub(hn::Mul(a[0], b[1]), hn::Mul(b[0], a[1]))};
  const VF s[3] = {hn::Add(a[0], b[0]), hn::Add(a[1], b[1]), hn::Add(a[2], b[2])};
  return hn::Mul(Dot(n, c), ThetaOverSinThetaV(Dot(a, b), Dot(s, s)));
}

// core/polygon_irradiance.h HorizonClippedPolygonIrradiance, for vertices a[i] relative to each lane's receiver.
template <int K>
HWY_INLINE VF HorizonClippedPolygonIrradianceV(const VF (&a)[K][3], const VF (&n)[3]) {
  const DF df;
  const VF zero = hn::Zero(df);
  VF s[K], unit[K][3];
  MF in[K];
  for (int i = 0; i < K; ++i) {
    s[i] = Dot(n, a[i]);
    in[i] = hn::Ge(s[i], zero);
    NormalizeV(a[i], unit[i]);
  }
  VF term[K];
  MF crosses = hn::Lt(zero, zero);
  for (int i = 0; i < K; ++i) crosses = hn::Or(crosses, hn::Xor(in[i], in[i == K - 1 ? 0 : i + 1]));
  VF horizon = zero;
  if (hn::AllFalse(df, crosses)) {
    // No lane's polygon crosses its horizon: each edge is wholly inside or wholly outside (the general path below
    // gives these lanes the same terms, and a horizon term of +0).
    for (int i = 0; i < K; ++i) term[i] = hn::IfThenElseZero(in[i], LambertEdgeTermV(unit[i], unit[i == K - 1 ? 0 : i + 1], n));
  } else {
    VF exit[3] = {zero, zero, zero}, entry[3] = {zero, zero, zero};
    for (int i = 0; i < K; ++i) {
      const int j = i == K - 1 ? 0 : i + 1;
      const VF t = hn::Div(s[i], hn::Sub(s[i], s[j]));
      VF p[3], pu[3], start[3], end[3];
      for (int c = 0; c < 3; ++c) p[c] = hn::Add(a[i][c], hn::Mul(hn::Sub(a[j][c], a[i][c]), t));
      NormalizeV(p, pu);
      const MF leaves = hn::AndNot(in[j], in[i]);  // in[i] and not in[j]
      const MF enters = hn::AndNot(in[i], in[j]);
      for (int c = 0; c < 3; ++c) {
        start[c] = hn::IfThenElse(in[i], unit[i][c], pu[c]);
        end[c] = hn::IfThenElse(in[j], unit[j][c], pu[c]);
        exit[c] = hn::IfThenElse(leaves, pu[c], exit[c]);
        entry[c] = hn::IfThenElse(enters, pu[c], entry[c]);
      }
      term[i] = hn::IfThenElseZero(hn::Or(in[i], in[j]), LambertEdgeTermV(start, end, n));
    }
    horizon = hn::IfThenElseZero(crosses, LambertEdgeTermV(exit, entry, n));
  }
  VF sum = term[0];
  for (int i = 1; i < K; ++i) sum = hn::Add(sum, term[i]);
  return hn::Mul(hn::Set(df, 0.5f), hn::Abs(hn::Add(sum, horizon)));
}

// LightIrradianceEstimate for each lane's receiver (position x, shading normal n), for a light of K vertices.
template <int K>
HWY_INLINE VF LightIrradianceEstimateV(const VF (&x)[3], const VF (&n)[3], const SelectionLight& L) {
  const DF df;
  const VF zero = hn::Zero(df);
  VF ln[3], d[3], a[K][3], s[K];
  for (int c = 0; c < 3; ++c) {
    ln[c] = hn::Set(df, L.normal[c]);
    d[c] = hn::Sub(hn::Set(df, L.centroid[c]), x[c]);
  }
  MF below = hn::Not(hn::Lt(zero, zero)), above = below;
  for (int i = 0; i < K; ++i) {
    for (int c = 0; c < 3; ++c) a[i][c] = hn::Sub(hn::Set(df, L.v[i][c]), x[c]);
    s[i] = Dot(n, a[i]);
    below = hn::And(below, hn::Lt(s[i], zero));
    above = hn::And(above, hn::Ge(s[i], zero));
  }
  const VF facing = hn::Sub(Dot(ln, x), hn::Set(df, L.offset));
  const MF front = hn::And(hn::Gt(facing, zero), hn::Gt(hn::Mul(facing, facing), hn::Set(df, kEdgeOn2 * L.size2)));
  const MF none = hn::Or(hn::Or(hn::Not(front), hn::Not(hn::Gt(hn::Set(df, L.lumArea), zero))), below);
  const VF d2 = Dot(d, d);
  const MF far = hn::And(hn::Gt(d2, hn::Set(df, kPointLightDistance2 * L.size2)), above);
  const VF cosXd = Dot(n, d);
  const VF cosYd = hn::Neg(Dot(ln, d));
  const VF cosXc = hn::IfThenElse(hn::Lt(cosXd, zero), zero, cosXd);
  const VF cosYc = hn::IfThenElse(hn::Lt(cosYd, zero), zero, cosYd);
  VF value = hn::Div(hn::Mul(hn::Mul(hn::Set(df, L.lumArea), cosXc), cosYc), hn::Mul(d2, d2));
  const MF exact = hn::AndNot(none, hn::Not(far));  // not none, not far
  if (!hn::AllFalse(df, exact))
    value = hn::IfThenElse(far, value, hn::Mul(hn::Set(df, L.lumRadiance), HorizonClippedPolygonIrradianceV<K>(a, n)));
  return hn::IfThenZeroElse(none, value);
}

// SelectionRows: 4 × 4 tiles transposed in registers.
void RowsKernel(const float* columns, size_t n, size_t count, float* cdf) {
  size_t t = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::Full128<float> d4;
  const hn::Repartition<uint64_t, decltype(d4)> d64;
  for (; t + 4 <= n; t += 4)
    for (size_t r = 0; r < count; r += 4) {
      // Triangles t..t+3 of receivers r..r+3 (kSelectionBlock is a multiple of 4: a short block's extra lanes are
      // read and not written).
      const auto q0 = hn::LoadU(d4, columns + (t + 0) * kSelectionBlock + r);
      const auto q1 = hn::LoadU(d4, columns + (t + 1) * kSelectionBlock + r);
      const auto q2 = hn::LoadU(d4, columns + (t + 2) * kSelectionBlock + r);
      const auto q3 = hn::LoadU(d4, columns + (t + 3) * kSelectionBlock + r);
      const auto a0 = hn::BitCast(d64, hn::InterleaveLower(d4, q0, q1));
      const auto a1 = hn::BitCast(d64, hn::InterleaveLower(d4, q2, q3));
      const auto a2 = hn::BitCast(d64, hn::InterleaveUpper(d4, q0, q1));
      const auto a3 = hn::BitCast(d64, hn::InterleaveUpper(d4, q2, q3));
      const decltype(q0) rows[4] = {hn::BitCast(d4, hn::InterleaveLower(d64, a0, a1)),
                                    hn::BitCast(d4, hn::InterleaveUpper(d64, a0, a1)),
                                    hn::BitCast(d4, hn::InterleaveLower(d64, a2, a3)),
                                    hn::BitCast(d4, hn::InterleaveUpper(d64, a2, a3))};
      for (size_t k = 0; k < 4 && r + k < count; ++k) hn::StoreU(rows[k], d4, cdf + (r + k) * n + t);
    }
#endif
  for (; t < n; ++t)
    for (size_t r = 0; r < count; ++r) cdf[r * n + t] = columns[t * kSelectionBlock + r];
}

void SelectionKernel(const SelectionReceivers& R, const BsdfSoa& materials, const SelectionLights& L, float* work,
                     float* columns, float* estimate) {
  const DF df;
  const DI di;
  // Whole packets within a block's arrays: a wider target (SVE, RVV) would read past them.
  static_assert(hn::MaxLanes(DF()) <= kSelectionBlock && kSelectionBlock % hn::MaxLanes(DF()) == 0);
  const size_t N = hn::Lanes(df);
  const VF zero = hn::Zero(df);
  const VF maxFloat = hn::Set(df, std::numeric_limits<float>::max());
  const VF keep = hn::Set(df, 1.0f - kDefensivePowerShare);
  float* const weights = work;  // per light, light-major
  for (size_t r0 = 0; r0 < R.count; r0 += N) {
    VF x[3], ng[3], n[3], wo[3];
    for (int c = 0; c < 3; ++c) {
      x[c] = hn::Load(df, R.x[c] + r0);
      ng[c] = hn::Load(df, R.ng[c] + r0);
      n[c] = hn::Load(df, R.n[c] + r0);
      wo[c] = hn::Load(df, R.wo[c] + r0);
    }
    const ShadingPointV sp = MakeShadingPointV(x, ng, n, wo, GatherBsdfV(materials, hn::Load(di, R.materialId + r0)));
    const VF albedo = hn::Mul(LuminanceV(sp.bsdf.albedo), hn::Set(df, kInvPi));
    const MF glossy = hn::Or(sp.bsdf.isGgx, sp.bsdf.isLayered);
    const bool anyGlossy = !hn::AllFalse(df, glossy);
    // First the weights and their total, then the cdf over the triangles.
    VF total = zero;
    for (size_t l = 0; l < L.count; ++l) {
      const SelectionLight& light = L.lights[l];
      const VF e = light.vertices == 4 ? LightIrradianceEstimateV<4>(x, n, light) : LightIrradianceEstimateV<3>(x, n, light);
      VF w = hn::Mul(e, albedo);
      if (anyGlossy) {
        VF y[3], ny[3], radiance[3], f[3];
        for (int c = 0; c < 3; ++c) {
          y[c] = hn::Set(df, light.centroid[c]);
          ny[c] = hn::Set(df, light.normal[c]);
          radiance[c] = hn::Set(df, light.radiance[c]);
        }
        UnshadowedContributionV(sp, ConnectToLightV(sp, y, ny), radiance, f);
        const VF lobe = hn::Add(hn::Mul(hn::Set(df, kGlossyDiffuseShare), w),
                                hn::Mul(LuminanceV(f), hn::Set(df, light.area)));
        w = hn::IfThenElse(glossy, lobe, w);
      }
      w = hn::IfThenElseZero(hn::Le(hn::Abs(w), maxFloat), w);
      hn::StoreU(w, df, weights + l * kSelectionBlock + r0);
      total = hn::Add(total, w);
    }
    // A subnormal total overflows keep / total: such a pixel falls back to power alone, like a zero total.
    const VF quotient = hn::Div(keep, total);
    const MF ok = hn::And(hn::And(hn::Gt(total, zero), hn::Le(total, maxFloat)), hn::Le(quotient, maxFloat));
    const VF a = hn::IfThenElseZero(ok, quotient);
    const VF b = hn::IfThenElse(ok, hn::Set(df, kDefensivePowerShare), hn::Set(df, 1.0f));
    VF running = zero;
    for (size_t l = 0; l < L.count; ++l) {
      const VF w = hn::LoadU(df, weights + l * kSelectionBlock + r0);
      running = hn::Add(running, hn::Add(hn::Mul(w, a), hn::Mul(b, hn::Set(df, L.lights[l].powerPmf))));
      hn::StoreU(running, df, columns + l * kSelectionBlock + r0);
    }
    hn::StoreU(total, df, estimate + r0);
  }
}

const char* SelectionKernelTargetName() {
  return hwy::TargetName(HWY_TARGET);
}

}  // namespace
// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

namespace restir {

HWY_EXPORT(SelectionKernel);
HWY_EXPORT(SelectionKernelTargetName);
HWY_EXPORT(RowsKernel);

namespace {

template <int K>
float IrradianceEstimate(const Vec3& x, const Vec3& n, const SelectionLight& L) {
  const float facing = glm::dot(L.normal, x) - L.offset;
  if (!(facing > 0.0f && facing * facing > kEdgeOn2 * L.size2) || !(L.lumArea > 0.0f)) return 0.0f;
  Vec3 a[K];
  bool below = true, above = true;
  for (int i = 0; i < K; ++i) {
    a[i] = L.v[i] - x;
    const float height = glm::dot(n, a[i]);  // above x's horizon
    below = below && height < 0.0f;
    above = above && height >= 0.0f;
  }
  if (below) return 0.0f;
  const Vec3 d = L.centroid - x;
  const float d2 = glm::dot(d, d);
  // Wholly above the horizon and beyond kPointLightDistance2 sizes: a point at the centroid.
  if (d2 > kPointLightDistance2 * L.size2 && above) {
    const float cosXd = glm::dot(n, d);          // cos θx · d
    const float cosYd = -glm::dot(L.normal, d);  // cos θy · d
    return L.lumArea * (cosXd < 0.0f ? 0.0f : cosXd) * (cosYd < 0.0f ? 0.0f : cosYd) / (d2 * d2);
  }
  return L.lumRadiance * HorizonClippedPolygonIrradiance<K>(a, n);
}

}  // namespace

std::vector<SelectionLight> MakeSelectionLights(const std::vector<LightTriangle>& triangles, const LightGroups& groups,
                                                const std::vector<float>& powerPmf) {
  std::vector<SelectionLight> out;
  for (size_t g = 0; g < groups.first.size(); ++g) {
    const uint32_t t = groups.first[g];
    const LightTriangle& t0 = triangles[t];
    const bool quad = groups.split[g] <= 1.0f;
    SelectionLight s;
    s.normal = t0.normal;
    s.radiance = t0.radiance;
    s.lumRadiance = Luminance(t0.radiance);
    s.powerPmf = powerPmf[t];
    s.v[0] = t0.p0;
    s.v[1] = t0.p0 + t0.e1;
    s.v[2] = t0.p0 + t0.e2;
    const Vec3 c0 = t0.p0 + (t0.e1 + t0.e2) * (1.0f / 3.0f);
    if (quad) {
      const LightTriangle& t1 = triangles[t + 1];
      s.vertices = 4;
      s.v[3] = t1.p0 + t1.e2;
      s.area = t0.area + t1.area;
      s.centroid = (c0 * t0.area + (t1.p0 + (t1.e1 + t1.e2) * (1.0f / 3.0f)) * t1.area) / s.area;
      s.size2 = std::max(glm::dot(s.v[2] - s.v[0], s.v[2] - s.v[0]), glm::dot(s.v[3] - s.v[1], s.v[3] - s.v[1]));
      s.powerPmf += powerPmf[t + 1];
    } else {
      s.v[3] = s.v[2];
      s.area = t0.area;
      s.centroid = c0;
      s.size2 = std::max({glm::dot(t0.e1, t0.e1), glm::dot(t0.e2, t0.e2), glm::dot(t0.e1 - t0.e2, t0.e1 - t0.e2)});
    }
    s.offset = glm::dot(s.normal, s.v[0]);
    s.lumArea = s.lumRadiance > 0.0f ? s.lumRadiance * s.area : 0.0f;
    out.push_back(s);
  }
  return out;
}

float LightIrradianceEstimate(const Vec3& x, const Vec3& n, const SelectionLight& L) {
  return L.vertices == 4 ? IrradianceEstimate<4>(x, n, L) : IrradianceEstimate<3>(x, n, L);
}

float TileLightWeight(const Vec3& x, const SelectionLight& L) {
  const Vec3 d = x - L.centroid;
  const float facing = glm::dot(L.normal, d);
  if (!(facing > 0.0f) || !(L.lumArea > 0.0f)) return 0.0f;
  const float d2 = std::max(glm::dot(d, d), L.size2);
  const float w = L.lumArea * facing / (d2 * std::sqrt(d2));
  return std::fabs(w) <= std::numeric_limits<float>::max() ? w : 0.0f;
}

float LightSelectionWeight(const ShadingPoint& sp, const SelectionLight& L) {
  float w = LightIrradianceEstimate(sp.position, sp.shadingNormal, L) * (Luminance(sp.bsdf.albedo) * kInvPi);
  if (sp.bsdf.type != BsdfType::kDiffuse) {
    LightSample c;
    c.position = L.centroid;
    c.normal = L.normal;
    c.radiance = L.radiance;
    w = kGlossyDiffuseShare * w + TargetFunction(UnshadowedContribution(sp, c)) * L.area;
  }
  return std::fabs(w) <= std::numeric_limits<float>::max() ? w : 0.0f;
}

void BuildLightSelectionScalar(const SelectionReceivers& R, const BsdfSoa& materials, const SelectionLights& L,
                               float* work, float* columns, float* estimate) {
  const float keep = 1.0f - kDefensivePowerShare;
  for (size_t r = 0; r < R.count; ++r) {
    ShadingPoint sp;
    for (int c = 0; c < 3; ++c) {
      sp.position[c] = R.x[c][r];
      sp.geometricNormal[c] = R.ng[c][r];
      sp.shadingNormal[c] = R.n[c][r];
      sp.wo[c] = R.wo[c][r];
    }
    sp.bsdf = materials.At(static_cast<size_t>(R.materialId[r]));
    float total = 0.0f;
    for (size_t l = 0; l < L.count; ++l) {
      const float w = LightSelectionWeight(sp, L.lights[l]);
      work[l * kSelectionBlock + r] = w;
      total += w;
    }
    const float quotient = keep / total;
    const bool ok = total > 0.0f && total <= std::numeric_limits<float>::max() &&
                    quotient <= std::numeric_limits<float>::max();
    const float a = ok ? quotient : 0.0f;
    const float b = ok ? kDefensivePowerShare : 1.0f;
    float running = 0.0f;
    for (size_t l = 0; l < L.count; ++l) {
      running += work[l * kSelectionBlock + r] * a + b * L.lights[l].powerPmf;
      columns[l * kSelectionBlock + r] = running;
    }
    estimate[r] = total;
  }
}

void BuildLightSelection(const SelectionReceivers& receivers, const BsdfSoa& materials, const SelectionLights& lights,
                         float* work, float* columns, float* estimate) {
  if (UseScalarTwins()) return BuildLightSelectionScalar(receivers, materials, lights, work, columns, estimate);
  HWY_DYNAMIC_DISPATCH(SelectionKernel)(receivers, materials, lights, work, columns, estimate);
}

void SelectionRows(const float* columns, size_t n, size_t count, float* rows) {
  // A copy, the same on every target: the scalar build copies it element by element.
  if (UseScalarTwins()) {
    for (size_t t = 0; t < n; ++t)
      for (size_t r = 0; r < count; ++r) rows[r * n + t] = columns[t * kSelectionBlock + r];
    return;
  }
  HWY_DYNAMIC_DISPATCH(RowsKernel)(columns, n, count, rows);
}

const char* LightSelectionKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(SelectionKernelTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
