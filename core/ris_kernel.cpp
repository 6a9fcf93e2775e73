// Highway kernel and scalar twin of initial sampling (core/ris_kernel.h). The per-target part below is compiled
// once per Highway target (foreach_target.h); the scalar twin and the dispatcher are compiled once (HWY_ONCE).
//
// Bit-exactness (DESIGN §3): each lane computes exactly the scalar expression tree, in the same order, with
// per-lane IEEE operations only (core/shading-inl.h holds the shading equations and states the rules); here too
// float -> int is truncation (ConvertTo) and table lookups (gathers, or record loads transposed in registers)
// move table bits unchanged.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/ris_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"

#include <vector>

#include "core/ris_kernel.h"
#include "core/rng-inl.h"
#include "core/rng.h"
#include "core/light-inl.h"
#include "core/shading-inl.h"
#include "core/shading.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {

// DF, DI, VF, VI, MF and hn come from core/shading-inl.h.
using DU = hn::RebindToUnsigned<DF>;
using VU = hn::Vec<DU>;

// Lane-uniform words of the RNG key (core/rng.h RandomBits), with the first PCG4D LCG step of y and z, which
// do not depend on the dimension, already applied.
struct KeyWords {
  uint32_t y1;  // (frame ^ seed * 0x9E3779B9) after the LCG step
  uint32_t z1;  // seed after the LCG step
  uint32_t pass;
};

// The per-lane words of Pcg4d's first round that do not depend on the dimension: x after its LCG step, and
// z1 times it. Integer arithmetic is exact modulo 2^32, so y = y1 + z1 (x0 + s) = (y1 + z1 s) + z1 x0 with s
// lane-uniform: one scalar product and one vector add replace a vector multiply per uniform.
struct PixelWords {
  VU x0;   // pixel * 1664525 + 1013904223
  VU zx0;  // z1 * x0
};
HWY_INLINE PixelWords MakePixelWords(VU pixel, const KeyWords& k) {
  const DU du;
  const VU x0 = hn::Add(hn::Mul(pixel, hn::Set(du, 1664525u)), hn::Set(du, 1013904223u));
  return {x0, hn::Mul(hn::Set(du, k.z1), x0)};
}

// Uniform float in [0, 1) for each lane's pixel at one dimension: RandomBits + BitsToUnitFloat (core/rng.h).
HWY_INLINE VF UniformV(DF df, const PixelWords& p, const KeyWords& k, uint32_t dimension) {
  const DU du;
  const DI di;
  const uint32_t w0 = (k.pass << 20) ^ (dimension & 0xFFFFFu);
  const uint32_t w1 = w0 * 1664525u + 1013904223u;
  const uint32_t s = k.y1 * w1;
  // Pcg4d: x is per lane, y z w are uniform until they mix with x.
  VU x = hn::Add(p.x0, hn::Set(du, s));                              // x += y * w
  VU y = hn::Add(p.zx0, hn::Set(du, k.y1 + k.z1 * s));               // y += z * x
  VU z = hn::Add(hn::Set(du, k.z1), hn::Mul(x, y));                  // z += x * y
  VU w = hn::Add(hn::Set(du, w1), hn::Mul(y, z));                    // w += y * z
  const VU bits = Pcg4dFinishV(x, y, z, w);
  // bits >> 8 < 2^24: exact as int32 and as float.
  return hn::Mul(hn::ConvertTo(df, hn::BitCast(di, hn::ShiftRight<8>(bits))), hn::Set(df, 0x1.0p-24f));
}

// Table lookups, per lane at index `id`. The alias-table bin is one gather per half packet: two 32-bit fields
// share a 64-bit element (LightSamplerSoa::aliasPairs), then the even and odd 32-bit lanes are the two fields.
#if HWY_TARGET != HWY_SCALAR
using DU64 = hn::Repartition<uint64_t, DF>;
using DI64 = hn::RebindToSigned<DU64>;
HWY_INLINE void GatherPair(const std::vector<uint64_t>& table, VI id, VF& first, VF& second) {
  const DF df;
  const DU64 du64;
  const DI64 di64;
  const hn::Half<DI> dh;
  const VF lo = hn::BitCast(df, hn::GatherIndex(du64, table.data(), hn::PromoteTo(di64, hn::LowerHalf(dh, id))));
  const VF hi = hn::BitCast(df, hn::GatherIndex(du64, table.data(), hn::PromoteTo(di64, hn::UpperHalf(dh, id))));
  first = hn::ConcatEven(df, hi, lo);
  second = hn::ConcatOdd(df, hi, lo);
}
#endif

// The alias-table bin at `bin`: keep probability and alias.
HWY_INLINE void GatherBin(const LightSamplerSoa& L, VI bin, VF& q, VI& alias) {
#if HWY_TARGET != HWY_SCALAR
  VF aliasF;
  GatherPair(L.aliasPairs, bin, q, aliasF);
  alias = hn::BitCast(DI(), aliasF);
#else
  q = hn::GatherIndex(DF(), L.aliasQ.data(), bin);
  alias = hn::GatherIndex(DI(), L.aliasIndex.data(), bin);
#endif
}

// Every light field of light `id`: p0, e1, e2, normal, radiance (3 each), pdfArea.
struct LightFields {
  VF p0[3], e1[3], e2[3], n[3], radiance[3], pdf;
};

HWY_INLINE LightFields GatherLight(const LightSamplerSoa& L, VI id) {
  LightFields f;
#if HWY_TARGET != HWY_SCALAR
  VF o[16];
  LoadRecords16(L.records.data()->v, id, o);
  for (int c = 0; c < 3; ++c) {
    f.p0[c] = o[c];
    f.e1[c] = o[3 + c];
    f.e2[c] = o[6 + c];
    f.n[c] = o[9 + c];
    f.radiance[c] = o[12 + c];
  }
  f.pdf = o[15];
#else
  const DF df;
  for (int c = 0; c < 3; ++c) {
    f.p0[c] = hn::GatherIndex(df, L.p0[c].data(), id);
    f.e1[c] = hn::GatherIndex(df, L.e1[c].data(), id);
    f.e2[c] = hn::GatherIndex(df, L.e2[c].data(), id);
    f.n[c] = hn::GatherIndex(df, L.normal[c].data(), id);
    f.radiance[c] = hn::GatherIndex(df, L.radiance[c].data(), id);
  }
  f.pdf = hn::GatherIndex(df, L.pdfArea.data(), id);
#endif
  return f;
}

struct PacketIn {
  const float* pos[3];
  const float* ng[3];
  const float* ns[3];
  const float* wo[3];
  const int32_t* materialId;
  const uint8_t* active;
  uint32_t pixelBase;
};

struct PacketOut {
  int32_t* lightId;
  float* position[3];
  float* normal[3];
  float* radiance[3];
  float* pdfArea;
  float* weightSum;
  float* targetPdf;
};

// One packet of Lanes(df) pixels. `in` and `out` point at the packet's first element.
HWY_INLINE void RisPacket(const PacketIn& in, const LightSamplerSoa& L, const BsdfSoa& mt,
                          const RisParams& params, const KeyWords& key, const PacketOut& out) {
  const DF df;
  const DI di;
  const DU du;
  const size_t N = hn::Lanes(df);
  const VF zero = hn::Zero(df);

  // Active mask from the byte flags.
  HWY_ALIGN int32_t activeLanes[hn::MaxLanes(di)];
  for (size_t k = 0; k < N; ++k) activeLanes[k] = in.active[k] ? -1 : 0;
  const auto activeI = hn::Ne(hn::Load(di, activeLanes), hn::Zero(di));
  const MF active = hn::RebindMask(df, activeI);

  VI selId = hn::Zero(di);
  VF selX = zero, selY = zero, selZ = zero, selTarget = zero, wSum = zero;
  MF selected = hn::RebindMask(df, hn::Lt(hn::Zero(di), hn::Zero(di)));  // all false

  if (!hn::AllFalse(df, active)) {
    VF x[3], ng[3], ns[3], wo[3];
    for (int c = 0; c < 3; ++c) {
      x[c] = hn::LoadU(df, in.pos[c]);
      ng[c] = hn::LoadU(df, in.ng[c]);
      ns[c] = hn::LoadU(df, in.ns[c]);
      wo[c] = hn::LoadU(df, in.wo[c]);
    }
    // Inactive lanes read material 0, never used (their material id may be invalid).
    const VI mid = hn::IfThenElseZero(activeI, hn::LoadU(di, in.materialId));
    // The receiver-only parts of EvalBsdf, once for all M candidates.
    const ShadingPointV sp = MakeShadingPointV(x, ng, ns, wo, GatherBsdfV(mt, mid));

    const PixelWords pixel = MakePixelWords(hn::Add(hn::Set(du, in.pixelBase), hn::Iota(du, 0)), key);
    const uint32_t n = L.Size();
    const VF nF = hn::Set(df, static_cast<float>(n));
    const VI nMinus1 = hn::Set(di, static_cast<int32_t>(n - 1));

    // Candidate j's light choice (its uniforms, the alias-table gather, the light id) is made one iteration
    // ahead, so its latency overlaps candidate j - 1's shading; each candidate's values are unchanged. Choosing
    // the light fields ahead too would keep 16 more vectors live across the shading, which costs more than it
    // hides.
    struct Choice {
      VI id;
      VF uPoint0, uPoint1, uSel;
    };
    auto choose = [&](int j) {
      const uint32_t dim = 5u * static_cast<uint32_t>(j);
      const VF uSelect = UniformV(df, pixel, key, dim);
      const VF uCoin = UniformV(df, pixel, key, dim + 1);
      Choice c;
      c.uPoint0 = UniformV(df, pixel, key, dim + 2);
      c.uPoint1 = UniformV(df, pixel, key, dim + 3);
      c.uSel = UniformV(df, pixel, key, dim + 4);
      // AliasTable::Sample: i = min(uint(uSelect n), n - 1); keep i when uCoin < q_i, else its alias.
      const VI bin = hn::Min(hn::ConvertTo(di, hn::Mul(uSelect, nF)), nMinus1);
      VF q;
      VI alias;
      GatherBin(L, bin, q, alias);
      c.id = hn::IfThenElse(hn::RebindMask(di, hn::Lt(uCoin, q)), bin, alias);
      return c;
    };
    Choice next = choose(0);
    for (int j = 0; j < params.candidates; ++j) {
      const Choice cur = next;
      if (j + 1 < params.candidates) next = choose(j + 1);
      const VI id = cur.id;
      const VF uPoint0 = cur.uPoint0, uPoint1 = cur.uPoint1, uSel = cur.uSel;
      const LightFields lf = GatherLight(L, id);

      VF yp[3];
      SampleTrianglePointV(lf.p0, lf.e1, lf.e2, uPoint0, uPoint1, yp);

      // TargetFunction(UnshadowedContribution(sp, y)) (core/shading.h); inactive lanes give +0.
      LightPathV path = ConnectToLightV(sp, yp, lf.n);
      path.connects = hn::And(path.connects, active);
      VF contribution[3];
      UnshadowedContributionV(sp, path, lf.radiance, contribution);
      const VF target = LuminanceV(contribution);

      // RisWeight and StreamCandidate (core/reservoir.h).
      const VF pdf = lf.pdf;
      const VF weight = hn::IfThenElseZero(hn::Gt(pdf, zero), hn::Div(target, pdf));
      const MF positive = hn::And(hn::Gt(weight, zero), active);
      wSum = hn::IfThenElse(positive, hn::Add(wSum, weight), wSum);
      const MF take = hn::And(positive, hn::Lt(hn::Mul(uSel, wSum), weight));
      selected = hn::Or(selected, take);
      selId = hn::IfThenElse(hn::RebindMask(di, take), id, selId);
      selX = hn::IfThenElse(take, yp[0], selX);
      selY = hn::IfThenElse(take, yp[1], selY);
      selZ = hn::IfThenElse(take, yp[2], selZ);
      selTarget = hn::IfThenElse(take, target, selTarget);
    }
  }

  // The selected sample's light fields, zero where nothing was selected (selId is 0 there: a valid index).
  const auto selectedI = hn::RebindMask(di, selected);
  hn::StoreU(hn::IfThenElseZero(selectedI, selId), di, out.lightId);
  hn::StoreU(selX, df, out.position[0]);
  hn::StoreU(selY, df, out.position[1]);
  hn::StoreU(selZ, df, out.position[2]);
  const bool any = !hn::AllFalse(df, selected);
  for (int c = 0; c < 3; ++c) {
    hn::StoreU(any ? hn::IfThenElseZero(selected, hn::GatherIndex(df, L.normal[c].data(), selId)) : zero, df,
               out.normal[c]);
    hn::StoreU(any ? hn::IfThenElseZero(selected, hn::GatherIndex(df, L.radiance[c].data(), selId)) : zero, df,
               out.radiance[c]);
  }
  hn::StoreU(any ? hn::IfThenElseZero(selected, hn::GatherIndex(df, L.pdfArea.data(), selId)) : zero, df,
             out.pdfArea);
  hn::StoreU(wSum, df, out.weightSum);
  hn::StoreU(selTarget, df, out.targetPdf);
}

void RisKernel(const RisPixels& pixels, const LightSamplerSoa& lights, const BsdfSoa& materials,
               const RisParams& params, const RisOutput& out) {
  const DF df;
  const size_t N = hn::Lanes(df);
  KeyWords key;
  key.y1 = (params.frame ^ (params.seed * 0x9E3779B9u)) * 1664525u + 1013904223u;
  key.z1 = params.seed * 1664525u + 1013904223u;
  key.pass = params.pass;
  const bool usable = lights.Size() > 0 && materials.Size() > 0;
  static const uint8_t kNone[64] = {};

  auto packetIn = [&](size_t k) {
    PacketIn in;
    for (int c = 0; c < 3; ++c) {
      in.pos[c] = pixels.position[c] + k;
      in.ng[c] = pixels.geometricNormal[c] + k;
      in.ns[c] = pixels.shadingNormal[c] + k;
      in.wo[c] = pixels.wo[c] + k;
    }
    in.materialId = pixels.materialId + k;
    in.active = usable ? pixels.active + k : kNone;
    in.pixelBase = pixels.pixelBase + static_cast<uint32_t>(k);
    return in;
  };
  auto packetOut = [&](size_t k) {
    PacketOut o;
    o.lightId = out.lightId + k;
    for (int c = 0; c < 3; ++c) {
      o.position[c] = out.position[c] + k;
      o.normal[c] = out.normal[c] + k;
      o.radiance[c] = out.radiance[c] + k;
    }
    o.pdfArea = out.pdfArea + k;
    o.weightSum = out.weightSum + k;
    o.targetPdf = out.targetPdf + k;
    return o;
  };

  size_t k = 0;
  for (; k + N <= pixels.count; k += N) RisPacket(packetIn(k), lights, materials, params, key, packetOut(k));
  if (k == pixels.count) return;

  // Tail: copy the remaining pixels into a padded packet whose extra lanes are inactive.
  constexpr size_t kMax = hn::MaxLanes(DF());
  const size_t rest = pixels.count - k;
  HWY_ALIGN float inF[12][kMax] = {};
  HWY_ALIGN int32_t inMat[kMax] = {};
  uint8_t inActive[kMax] = {};
  const PacketIn src = packetIn(k);
  PacketIn in = src;
  for (int c = 0; c < 3; ++c) {
    const float* const* fields[4] = {src.pos, src.ng, src.ns, src.wo};
    for (int f = 0; f < 4; ++f) {
      for (size_t l = 0; l < rest; ++l) inF[f * 3 + c][l] = fields[f][c][l];
    }
    in.pos[c] = inF[0 * 3 + c];
    in.ng[c] = inF[1 * 3 + c];
    in.ns[c] = inF[2 * 3 + c];
    in.wo[c] = inF[3 * 3 + c];
  }
  for (size_t l = 0; l < rest; ++l) {
    inMat[l] = src.materialId[l];
    inActive[l] = src.active[l];
  }
  in.materialId = inMat;
  in.active = inActive;
  HWY_ALIGN float outF[12][kMax];
  HWY_ALIGN int32_t outId[kMax];
  PacketOut o;
  o.lightId = outId;
  for (int c = 0; c < 3; ++c) {
    o.position[c] = outF[c];
    o.normal[c] = outF[3 + c];
    o.radiance[c] = outF[6 + c];
  }
  o.pdfArea = outF[9];
  o.weightSum = outF[10];
  o.targetPdf = outF[11];
  RisPacket(in, lights, materials, params, key, o);
  const PacketOut dst = packetOut(k);
  for (size_t l = 0; l < rest; ++l) {
    dst.lightId[l] = outId[l];
    for (int c = 0; c < 3; ++c) {
      dst.position[c][l] = o.position[c][l];
      dst.normal[c][l] = o.normal[c][l];
      dst.radiance[c][l] = o.radiance[c][l];
    }
    dst.pdfArea[l] = o.pdfArea[l];
    dst.weightSum[l] = o.weightSum[l];
    dst.targetPdf[l] = o.targetPdf[l];
  }
}

const char* DispatchedTargetName() { return hwy::TargetName(HWY_TARGET); }

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

#include "core/reservoir.h"
#include "core/shading.h"

namespace restir {

HWY_EXPORT(RisKernel);
HWY_EXPORT(DispatchedTargetName);

namespace {

// LightSampler::Sample on the SoA copy: the same operations on the same values.
LightSample SampleLightSoa(const LightSamplerSoa& L, float uSelect, float uCoin, float uPoint0, float uPoint1) {
  const uint32_t n = L.Size();
  uint32_t i = static_cast<uint32_t>(uSelect * static_cast<float>(n));  // AliasTable::Sample
  if (i >= n) i = n - 1;
  LightSample s;
  s.lightId = uCoin < L.aliasQ[i] ? i : static_cast<uint32_t>(L.aliasIndex[i]);
  LightTriangle t;
  for (int c = 0; c < 3; ++c) {
    t.p0[c] = L.p0[c][s.lightId];
    t.e1[c] = L.e1[c][s.lightId];
    t.e2[c] = L.e2[c][s.lightId];
  }
  s.position = SampleTrianglePoint(t, uPoint0, uPoint1);
  s.normal = Vec3(L.normal[0][s.lightId], L.normal[1][s.lightId], L.normal[2][s.lightId]);
  s.radiance = Vec3(L.radiance[0][s.lightId], L.radiance[1][s.lightId], L.radiance[2][s.lightId]);
  s.pdfArea = L.pdfArea[s.lightId];
  return s;
}

}  // namespace

void RisInitialSamplingScalar(const RisPixels& px, const LightSamplerSoa& lights, const BsdfSoa& materials,
                              const RisParams& params, const RisOutput& out) {
  const bool usable = lights.Size() > 0 && materials.Size() > 0;
  for (size_t k = 0; k < px.count; ++k) {
    Reservoir r;
    r.sample = LightSample{};
    r.sample.position = r.sample.normal = r.sample.radiance = Vec3(0.0f);
    if (usable && px.active[k]) {
      ShadingPoint sp;
      sp.position = Vec3(px.position[0][k], px.position[1][k], px.position[2][k]);
      sp.geometricNormal = Vec3(px.geometricNormal[0][k], px.geometricNormal[1][k], px.geometricNormal[2][k]);
      sp.shadingNormal = Vec3(px.shadingNormal[0][k], px.shadingNormal[1][k], px.shadingNormal[2][k]);
      sp.wo = Vec3(px.wo[0][k], px.wo[1][k], px.wo[2][k]);
      sp.bsdf = materials.At(static_cast<size_t>(px.materialId[k]));
      // The pipeline's initial pass before the kernel existed (sim/estimator/pipeline.cpp), candidate by candidate.
      Sampler s(RngKey{params.seed, params.frame, px.pixelBase + static_cast<uint32_t>(k), params.pass});
      for (int j = 0; j < params.candidates; ++j) {
        const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next(), uSel = s.Next();
        const LightSample y = SampleLightSoa(lights, u0, u1, u2, u3);
        const float target = TargetFunction(UnshadowedContribution(sp, y));
        StreamCandidate(r, y, target, RisWeight(target, y.pdfArea), uSel);
      }
    }
    out.lightId[k] = static_cast<int32_t>(r.sample.lightId);
    for (int c = 0; c < 3; ++c) {
      out.position[c][k] = r.sample.position[c];
      out.normal[c][k] = r.sample.normal[c];
      out.radiance[c][k] = r.sample.radiance[c];
    }
    out.pdfArea[k] = r.sample.pdfArea;
    out.weightSum[k] = r.weightSum;
    out.targetPdf[k] = r.targetPdf;
  }
}

void RisInitialSampling(const RisPixels& pixels, const LightSamplerSoa& lights, const BsdfSoa& materials,
                        const RisParams& params, const RisOutput& out) {
  if (UseScalarTwins()) return RisInitialSamplingScalar(pixels, lights, materials, params, out);
  HWY_DYNAMIC_DISPATCH(RisKernel)(pixels, lights, materials, params, out);
}

const char* RisKernelDispatchedTargetName() {
  if (UseScalarTwins()) return "scalar";
  return HWY_DYNAMIC_DISPATCH(DispatchedTargetName)();
}

}  // namespace restir

#endif  // HWY_ONCE
