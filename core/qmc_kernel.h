// Randomised-QMC point kernel (issue 16): the coordinates of independently shifted copies of a Roberts
// sequence (core/sampling.h RobertsCoordinate), which the converged reference draws for every pixel
// (sim/reference/reference.cpp), a packet of points per register; and the random words that shift them, core/rng.h
// RandomWords4 for a packet of pixels at a time.
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin. Same bits on every target.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/rng.h"

namespace restir {

// out[k * copies + r] = RobertsCoordinate(shifts[r], k, alpha) for r < copies, k < count: the copies' points
// interleaved, point k of every copy together (a pixel's replicates then fill whole packets however few points
// each takes).
void RobertsCoordinates(const uint32_t* shifts, size_t copies, size_t count, uint32_t alpha, float* out);

// The scalar twin, callable directly (tests and benchmarks).
void RobertsCoordinatesScalar(const uint32_t* shifts, size_t copies, size_t count, uint32_t alpha, float* out);

// out[(4 g + i) * count + p] = word i of RandomWords4(key with pixels[p] as its pixel, first + g) for p < count,
// g < groups, i < 4: a block of pixels' words, a packet of pixels at a time.
void PixelRandomWords4(const RngKey& key, const uint32_t* pixels, size_t count, uint32_t first, size_t groups,
                       uint32_t* out);

// The scalar twin, callable directly (tests and benchmarks).
void PixelRandomWords4Scalar(const RngKey& key, const uint32_t* pixels, size_t count, uint32_t first, size_t groups,
                             uint32_t* out);

// Name of the Highway target RobertsCoordinates runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* QmcKernelDispatchedTargetName();

}  // namespace restir
