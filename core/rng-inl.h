// Per-target Highway form of core/rng.h's hash: RandomWords4 for a packet of pixels (core/qmc_kernel.cpp draws the
// reference's random shifts with it), and PCG4D's second half, which the RIS kernel's hash (core/ris_kernel.cpp,
// its first half specialised to lanes that share y z w) finishes with.
//
// Include after "hwy/foreach_target.h" and "hwy/highway.h", outside any namespace: like every Highway -inl header
// it is compiled once per target and opens restir::HWY_NAMESPACE itself.
//
// Bit-exactness (DESIGN §3): integer arithmetic modulo 2^32, lane by lane, as the scalar code's.

// Highway's per-target include guard: the body is compiled once for each target foreach_target.h toggles.
#if defined(RESTIR_CORE_RNG_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef RESTIR_CORE_RNG_INL_H_
#undef RESTIR_CORE_RNG_INL_H_
#else
#define RESTIR_CORE_RNG_INL_H_
#endif

#include "hwy/highway.h"

#include "core/rng.h"

HWY_BEFORE_NAMESPACE();
namespace restir {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Pcg4d's second half (core/rng.h): the shift round and the last mixing round of x y z w, in place.
template <class V>
HWY_INLINE void Pcg4dSecondHalfV(V& x, V& y, V& z, V& w) {
  x = hn::Xor(x, hn::ShiftRight<16>(x));
  y = hn::Xor(y, hn::ShiftRight<16>(y));
  z = hn::Xor(z, hn::ShiftRight<16>(z));
  w = hn::Xor(w, hn::ShiftRight<16>(w));
  x = hn::Add(x, hn::Mul(y, w));
  y = hn::Add(y, hn::Mul(z, x));
  z = hn::Add(z, hn::Mul(x, y));
  w = hn::Add(w, hn::Mul(y, z));
}

// Pcg4d's second half and RandomBits' output word x ^ (w >> 7). Callers whose first half is partly uniform across
// lanes (core/ris_kernel.cpp) start here.
template <class V>
HWY_INLINE V Pcg4dFinishV(V x, V y, V z, V w) {
  Pcg4dSecondHalfV(x, y, z, w);
  return hn::Xor(x, hn::ShiftRight<7>(w));
}

// RandomWords4(key, q) (core/rng.h) per lane of `pixel` (in place of key.pixel): words[i] is word i.
template <class DU>
HWY_INLINE void RandomWords4V(DU du, const RngKey& key, hn::Vec<DU> pixel, uint32_t q, hn::Vec<DU> (&words)[4]) {
  const auto lcg = [&](hn::Vec<DU> v) {
    return hn::Add(hn::Mul(v, hn::Set(du, 1664525u)), hn::Set(du, 1013904223u));
  };
  auto x = lcg(pixel);
  auto y = lcg(hn::Set(du, key.frame ^ (key.seed * 0x9E3779B9u)));
  auto z = lcg(hn::Set(du, key.seed));
  auto w = lcg(hn::Set(du, (key.pass << 20) ^ (q & 0xFFFFFu)));
  // Pcg4d's first mixing round, then its second half.
  x = hn::Add(x, hn::Mul(y, w));
  y = hn::Add(y, hn::Mul(z, x));
  z = hn::Add(z, hn::Mul(x, y));
  w = hn::Add(w, hn::Mul(y, z));
  Pcg4dSecondHalfV(x, y, z, w);
  words[0] = x;
  words[1] = y;
  words[2] = z;
  words[3] = w;
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace restir
HWY_AFTER_NAMESPACE();

#endif  // RESTIR_CORE_RNG_INL_H_ toggle
