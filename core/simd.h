// Process-wide choice of the SIMD target the kernels run on (DESIGN §3; issue 6 `--simd`). Every target gives
// the same bits; the choice only changes speed. kScalar runs the kernels' plain C++ twins; the others restrict
// Highway's dynamic dispatch to one target; kAuto lets it pick the best target this CPU supports.
#pragma once

#include <optional>
#include <string_view>
#include <vector>

namespace restir {

enum class SimdTarget { kAuto, kScalar, kSse4, kAvx2, kAvx512 };

// "auto", "scalar", "sse4", "avx2", "avx512".
const char* SimdTargetName(SimdTarget target);
// Inverse of SimdTargetName; nullopt for an unknown name.
std::optional<SimdTarget> ParseSimdTarget(std::string_view name);

// True when `target` is compiled in and this CPU can run it (kAuto and kScalar: always).
bool SimdTargetSupported(SimdTarget target);
// The concrete targets this machine can run, scalar first, then in increasing width.
std::vector<SimdTarget> SupportedSimdTargets();

// Selects the target for every later kernel call. Returns false (and changes nothing) when unsupported. Not
// meant to be called while kernels run on other threads.
bool SetSimdTarget(SimdTarget target);
// The target last set (kAuto unless SetSimdTarget chose another).
SimdTarget RequestedSimdTarget();
// The concrete target kernels run on now: kAuto resolved to the best supported one.
SimdTarget ActiveSimdTarget();
// Name of the target kernels run on now ("scalar", "sse4", "avx2", "avx512", or Highway's name for any other
// target auto-dispatch lands on). For run.json.
const char* ActiveSimdTargetName();

// True when kernels should call their scalar twins (internal: used by the kernels' dispatchers).
bool UseScalarTwins();

}  // namespace restir
