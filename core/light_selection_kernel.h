// Light-selection kernel (issue 16): the converged reference's per-pixel light distributions
// (sim/reference/reference.cpp),
// built for a block of receivers at once, one receiver per SIMD lane and one light at a time (broadcast), so
// that every lane runs the scalar equation below and each receiver's sums keep their order on every target.
//
// A receiver selects light group l (core/light.h LightGroups: a triangle, or a quad of two) with probability
// P(l) = (1 - δ) w_l / Σ w + δ Φ_l / Σ Φ (δ = kDefensivePowerShare): w_l is the group's unshadowed contribution
// there, up to a constant (LightSelectionWeight), the defensive share by power keeps every light with power at
// P > 0, so the estimate stays unbiased whatever w is; w only decides how much noise is left. Where the sum of w
// is 0 or not finite, selection is by power alone.
//
// Two implementations beside each other, as core/target_kernel.h: a Highway kernel (dynamic dispatch) and its
// scalar twin built from the functions below. Same bits on every target.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/bsdf.h"
#include "core/light.h"
#include "core/math.h"
#include "core/shading.h"

namespace restir {

// Receivers per block.
inline constexpr size_t kSelectionBlock = 16;
// δ, the power share of every distribution.
inline constexpr float kDefensivePowerShare = 0.1f;
// Squared distance, in squared longest edges, beyond which a light counts as a point at its centroid.
inline constexpr float kPointLightDistance2 = 9.0f;
// A receiver within 1e-4 sizes of a light's plane (in it, up to rounding: a ceiling pixel beside a lamp flush
// with the ceiling) sees it edge-on and gets nothing from it: Lambert's formula has no digits left there, and what
// a light gives so close to its own plane is nearly nothing (the defensive share still reaches it).
inline constexpr float kEdgeOn2 = 1e-8f;  // (1e-4)², against squared sizes
// Weight of the Lambertian estimate beside the centroid's BSDF value at a receiver that is not diffuse.
inline constexpr float kGlossyDiffuseShare = 0.1f;

// A light group (core/light.h LightGroups: a light triangle, or a quad of two) as the selection weighs it: once,
// by Lambert's formula on the triangle or quadrilateral (or its point estimate).
struct SelectionLight {
  Vec3 v[4];                // vertices in order: a triangle's three (v[3] = v[2]), or the quad's four
  uint32_t vertices = 3;    // 3 or 4
  Vec3 normal;              // emitting side
  float offset = 0;         // normal · v[0]: the light faces x when normal · x > offset
  Vec3 centroid;            // area centroid
  float size2 = 0;          // squared longest edge (a quad's: longest diagonal)
  float lumRadiance = 0;    // luminance of the radiance
  float lumArea = 0;        // lumRadiance × area where positive, else 0
  Vec3 radiance;            // the radiance, for the BSDF at the centroid
  float area = 0;           // its area
  float powerPmf = 0;       // its triangles' power shares, Φ / Σ Φ
};

// The frame's groups as the selection weighs them, from the triangles, their groups and each triangle's power
// share.
std::vector<SelectionLight> MakeSelectionLights(const std::vector<LightTriangle>& triangles, const LightGroups& groups,
                                                const std::vector<float>& powerPmf);

// The light's unshadowed irradiance at x (shading normal n) in luminance, E = ∫ L cos θx cos θy / d² dA over the
// part of it above x's horizon: 0 where the light faces away (or is seen edge-on, kEdgeOn2), is dark or lies
// wholly below the horizon; wholly above it and far away compared with its size, the point estimate L A cos θx cos θy
// / d² at the centroid (off by O(size / d)); otherwise Lambert's formula on the clipped polygon
// (core/polygon_irradiance.h).
float LightIrradianceEstimate(const Vec3& x, const Vec3& n, const SelectionLight& light);

// Above the reference's per-pixel light limit, one weight per light group for a whole screen tile, at one surface
// point x of it whatever the tile's normals: the light's radiance (luminance) times the solid angle it subtends
// from x, A cos θy / d², d² no smaller than the light's squared size (so a point beside a light does not give it
// all the weight). 0 where the light faces away from x or is dark. Only shapes a distribution that keeps the
// defensive power share.
float TileLightWeight(const Vec3& x, const SelectionLight& light);

// w at a receiver: LightIrradianceEstimate × albedo / π at a diffuse receiver (the reflected radiance, exact
// but for the point estimates); at any other, kGlossyDiffuseShare of that plus the BSDF's value towards the
// centroid times the area (TargetFunction(UnshadowedContribution) of the centroid), which follows a narrow lobe.
// 0 where the result is not finite.
float LightSelectionWeight(const ShadingPoint& sp, const SelectionLight& light);

// A block of receivers, structure of arrays; lanes at or beyond `count` are ignored (the SIMD kernel still writes
// their outputs, whole packets at a time, but nothing reads them), and every lane's materialId must index the
// BsdfSoa.
struct SelectionReceivers {
  alignas(64) float x[3][kSelectionBlock];   // position
  alignas(64) float ng[3][kSelectionBlock];  // geometric normal, facing the viewer
  alignas(64) float n[3][kSelectionBlock];   // shading normal, facing the viewer
  alignas(64) float wo[3][kSelectionBlock];  // unit, towards the viewer
  alignas(64) int32_t materialId[kSelectionBlock];
  size_t count = 0;  // receivers in the block, at most kSelectionBlock
};

// The frame's lights as the kernel reads them.
struct SelectionLights {
  const SelectionLight* lights = nullptr;  // MakeSelectionLights' list
  size_t count = 0;                        // its entries: the cdfs' length
};

// For every receiver r < count, its cdf over the light groups, light-major: entry l at columns[l × kSelectionBlock +
// r] is Σ_{j <= l} P(j) × c (c > 0: the last entry is the total, as core/sampling.h SampleCdf reads it); and
// estimate[r] = Σ w, the luminance of the reflected radiance the lights give unshadowed (the sky's light mixture
// weighs the local lights by it). columns holds n × kSelectionBlock floats (n = lights.count; a block's whole, so
// that it is written in full cache lines: lanes at or beyond count hold no cdf), `work` (scratch) as many,
// estimate kSelectionBlock; n > 0, and some light has power.
void BuildLightSelection(const SelectionReceivers& receivers, const BsdfSoa& materials, const SelectionLights& lights,
                         float* work, float* columns, float* estimate);

// The scalar twin, callable directly (tests and benchmarks).
void BuildLightSelectionScalar(const SelectionReceivers& receivers, const BsdfSoa& materials,
                               const SelectionLights& lights, float* work, float* columns, float* estimate);

// Each receiver's cdf as one row, rows[r × n + t] = columns[t × kSelectionBlock + r] for r < count, t < n (the
// light-draw kernel gathers within one receiver's cdf: a row keeps them within a few cache lines).
void SelectionRows(const float* columns, size_t n, size_t count, float* rows);

// Name of the Highway target BuildLightSelection runs on now, e.g. "AVX3", or "scalar" for the twin (tests).
const char* LightSelectionKernelDispatchedTargetName();

}  // namespace restir
