// Per-target Highway forms of what the kernels that draw points on light triangles share
// (core/ris_kernel.cpp, core/light_draw_kernel.cpp): core/light.h SampleTrianglePoint, and the transposing
// load of per-light records.
//
// Include after "hwy/foreach_target.h", "hwy/highway.h" and core/kernel-inl.h, outside any namespace: like
// every Highway -inl header it is compiled once per target and opens restir::HWY_NAMESPACE itself.
//
// Bit-exactness (DESIGN §3): GLM's p0 + b0 e1 + b1 e2 is (p0 + b0 e1) + b1 e2 per component; no MulAdd.

#include "core/kernel-inl.h"

// Highway's per-target include guard: the body is compiled once for each target foreach_target.h toggles.
#if defined(RESTIR_CORE_LIGHT_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_LIGHT_INL_H_
#undef RESTIR_CORE_LIGHT_INL_H_
#else
#define RESTIR_CORE_LIGHT_INL_H_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {

// SampleTrianglePoint (core/light.h): p0 + b0 e1 + b1 e2 with su0 = sqrt(u0), b0 = 1 - su0, b1 = u1 su0.
HWY_INLINE void SampleTrianglePointV(const VF (&p0)[3], const VF (&e1)[3], const VF (&e2)[3], VF u0, VF u1,
                                     VF (&out)[3]) {
  const VF su0 = hn::Sqrt(u0);
  const VF b0 = hn::Sub(hn::Set(DF(), 1.0f), su0);
  const VF b1 = hn::Mul(u1, su0);
  for (int c = 0; c < 3; ++c) out[c] = hn::Add(hn::Add(p0[c], hn::Mul(b0, e1[c])), hn::Mul(b1, e2[c]));
}

#if HWY_TARGET != HWY_SCALAR
// The 16 fields of each lane's 64-byte record (at base + 16 id, 64-byte aligned: LightSamplerSoa::records,
// core/light_draw_kernel.h's records) as 16 vectors, field k in o[k]: one aligned load per lane and 64 bytes,
// then an in-register transpose. Gathers cost about one load per element on the CPUs this runs on; a record
// load fetches 4 to 16 fields at once, and the shuffles are cheaper than the element loads they replace. The
// values are the same bits as a gather of each field.
HWY_INLINE void LoadRecords16(const float* base, VI id, VF (&o)[16]) {
  const DF df;
  const hn::Repartition<uint64_t, DF> du64;
  constexpr size_t N = hn::MaxLanes(DF());
  static_assert(N == 4 || N == 8 || N == 16, "a packet is one to four 128-bit blocks");
  constexpr size_t kParts = 16 / N;  // vectors per record
  HWY_ALIGN int32_t ids[N];
  hn::Store(id, DI(), ids);
  // Per part of the record: 32-bit then 64-bit interleaves transpose each 4 x 4 block of rows 4g..4g+3 and
  // fields 4j..4j+3, leaving block j of t[4g + k] = field 4j + k of rows 4g..4g+3.
  VF t[kParts][N];
  for (size_t part = 0; part < kParts; ++part) {
    VF r[N];
    for (size_t i = 0; i < N; ++i) r[i] = hn::Load(df, base + 16 * static_cast<size_t>(ids[i]) + N * part);
    for (size_t g = 0; g < N / 4; ++g) {
      const VF* q = r + 4 * g;
      const auto a0 = hn::BitCast(du64, hn::InterleaveLower(df, q[0], q[1]));
      const auto a1 = hn::BitCast(du64, hn::InterleaveUpper(df, q[0], q[1]));
      const auto a2 = hn::BitCast(du64, hn::InterleaveLower(df, q[2], q[3]));
      const auto a3 = hn::BitCast(du64, hn::InterleaveUpper(df, q[2], q[3]));
      t[part][4 * g + 0] = hn::BitCast(df, hn::InterleaveLower(du64, a0, a2));
      t[part][4 * g + 1] = hn::BitCast(df, hn::InterleaveUpper(du64, a0, a2));
      t[part][4 * g + 2] = hn::BitCast(df, hn::InterleaveLower(du64, a1, a3));
      t[part][4 * g + 3] = hn::BitCast(df, hn::InterleaveUpper(du64, a1, a3));
    }
  }
  // Field N part + 4j + k takes block j of t[part][4g + k] into its block g.
  for (size_t part = 0; part < kParts; ++part) {
    VF* out = o + N * part;
    const VF* b = t[part];
    for (size_t k = 0; k < 4; ++k) {
      if constexpr (N == 4) {
        out[k] = b[k];
      } else if constexpr (N == 8) {
        out[k] = hn::ConcatLowerLower(df, b[4 + k], b[k]);
        out[4 + k] = hn::ConcatUpperUpper(df, b[4 + k], b[k]);
      } else {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
        // Highway 1.0 has no 128-bit block shuffle of two vectors: vshuff32x4 directly.
        const __m512 c0 = _mm512_shuffle_f32x4(b[k].raw, b[4 + k].raw, 0x44);
        const __m512 c1 = _mm512_shuffle_f32x4(b[k].raw, b[4 + k].raw, 0xEE);
        const __m512 c2 = _mm512_shuffle_f32x4(b[8 + k].raw, b[12 + k].raw, 0x44);
        const __m512 c3 = _mm512_shuffle_f32x4(b[8 + k].raw, b[12 + k].raw, 0xEE);
        out[k] = VF{_mm512_shuffle_f32x4(c0, c2, 0x88)};
        out[4 + k] = VF{_mm512_shuffle_f32x4(c0, c2, 0xDD)};
        out[8 + k] = VF{_mm512_shuffle_f32x4(c1, c3, 0x88)};
        out[12 + k] = VF{_mm512_shuffle_f32x4(c1, c3, 0xDD)};
#else
        static_assert(N != 16, "16-lane block transpose written for AVX-512 only");
#endif
      }
    }
  }
}
#endif

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_LIGHT_INL_H_ toggle
