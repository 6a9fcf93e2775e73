// Randomised-QMC point kernel (issue 16): the coordinates of independently shifted copies of a Roberts
// sequence (core/sampling.h RobertsCoordinate), which the converged reference draws for every pixel
// (sim/reference.cpp), a packet of points per register; and the independent uniforms it draws beside them (its
// pilot's samples, the copies' shifts), core/rng.h UniformFloat a packet of dimensions at a time.
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin. Same bits on every target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/rng.h"

namespace restir {

// out[r * count + k] = RobertsCoordinate(shifts[r], k, alpha) for r < copies, k < count. Shifts in [0, 1),
// alpha > 0.
void RobertsCoordinates(const float* shifts, size_t copies, size_t count, double alpha, float* out);

// The scalar twin, callable directly (tests and benchmarks).
void RobertsCoordinatesScalar(const float* shifts, size_t copies, size_t count, double alpha, float* out);

// out[r * count + k] = UniformFloat(key, first + r * rowStride + k * stride) for r < rows, k < count (dimensions
// modulo 2^32, as RandomBits folds them): rows of uniforms in one call, whose packets' hashes then overlap.
void UniformFloats(const RngKey& key, uint32_t first, uint32_t stride, size_t count, float* out, size_t rows = 1,
                   uint32_t rowStride = 0);

// The scalar twin, callable directly (tests and benchmarks).
void UniformFloatsScalar(const RngKey& key, uint32_t first, uint32_t stride, size_t count, float* out,
                         size_t rows = 1, uint32_t rowStride = 0);

// Name of the Highway target RobertsCoordinates runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* QmcKernelDispatchedTargetName();

}  // namespace restir
