// Randomised-QMC point kernel (issue 16): the coordinates of independently shifted copies of a Roberts
// sequence (core/sampling.h RobertsCoordinate), which the converged reference draws for every pixel
// (sim/reference.cpp), a packet of points per register.
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin. Same bits on every target.
#pragma once

#include <cstddef>

namespace restir {

// out[r * count + k] = RobertsCoordinate(shifts[r], k, alpha) for r < copies, k < count. Shifts in [0, 1),
// alpha > 0.
void RobertsCoordinates(const float* shifts, size_t copies, size_t count, double alpha, float* out);

// The scalar twin, callable directly (tests and benchmarks).
void RobertsCoordinatesScalar(const float* shifts, size_t copies, size_t count, double alpha, float* out);

// Name of the Highway target RobertsCoordinates runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* QmcKernelDispatchedTargetName();

}  // namespace restir
