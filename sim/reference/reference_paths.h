// The reference's indirect light (issue 41; DESIGN §7): light that reaches a pixel's primary hit x₁ after
// reflecting at one or more further surfaces, estimated by paths traced from x₁ (pbrt-v4's PathIntegrator,
// less its first vertex's direct light, which the direct-light reference already takes). A path draws a
// direction by the BSDF at x₁, finds the surface x₂ it hits, and takes x₂'s direct light there by next-event
// estimation, with the reference's own samplers (sim/reference/reference_samples.h SkySamples: a light
// strategy, a point on a light or a sky direction, combined with BSDF sampling by the power heuristic, so an
// emitter or the sky a BSDF ray meets is counted once); then from x₂ onwards the same, up to `bounces`
// surfaces after x₁. An emitter without a material (Light::material) and a ray that escapes have no surface:
// either ends the path; an emitter with one reflects and the path goes on. What an emitter or the sky sends along
// a path's ray is x₁'s direct light or the previous vertex's, taken there, never by the step that met it. Pure
// functions of their arguments and random numbers. The reference adds them to its direct light
// (sim/reference/reference.cpp); a preset's frame adds one path a pixel (IndirectImage; sim/run/frame_loop.h
// FrameLoop::RenderPreset).
#pragma once

#include <cstdint>
#include <vector>

#include "core/light.h"
#include "core/light_selection_kernel.h"
#include "core/reconnection_shift.h"
#include "core/rng.h"
#include "core/sky.h"
#include "sim/reference/reference_guide.h"
#include "sim/reference/reference_samples.h"
#include "sim/reference/reference_sky.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/sequence.h"
#include "sim/util/image.h"

namespace restir {

// The most surfaces after the primary hit a path may reflect at (ReferenceParams::indirectBounces).
inline constexpr int kMaxIndirectBounces = 8;
// Random numbers one bounce reads: two for the direction from the BSDF, kSkySampleDims for the next-event
// sample.
inline constexpr int kBounceDims = 2 + kSkySampleDims;

// The most light groups for which a secondary vertex weighs every group itself (PathScene); above, power
// alone: the weights cost one pass over the groups a vertex.
inline constexpr size_t kMaxVertexSelectionGroups = 256;

// What a path's vertices need of a frame, built once for it. At a secondary vertex (the per-pixel
// distributions are the primary hits') a light group's probability is 0.9 w_g / Σ w + 0.1 Φ_g / Σ Φ, w_g =
// TileLightWeight (its radiance times the solid angle it subtends, d² floored by its size) times the cosine
// at the vertex towards its centroid: measured on window_bars_pan's frame 0 at 64 paths a pixel, the
// reference's mean relative standard error with one bounce fell from 24.3% (power alone) to 15.7%, and the
// frames' relmse from 1.9-10 to about 0.5 (docs/metrics.md "Indirect light"); Lambert's formula in place of
// the point estimate gave 15.5% for more time. Above kMaxVertexSelectionGroups groups, power alone. The sky's
// strategies are mixed by the vertex's own estimates (reference_sky.h), the local lights weighed as much as
// the sky.
class PathScene {
 public:
  // `sequence`, `scene` and `sky` must outlive it.
  PathScene(const Sequence& sequence, const EmbreeScene& scene, const Sky& sky);
  PathScene(const Sequence& sequence, const EmbreeScene& scene, Sky&& sky) = delete;
  PathScene(const PathScene&) = delete;
  PathScene& operator=(const PathScene&) = delete;

  // The surface a path's ray hit, as a receiver seen from along -dir: its material's BSDF, times the texel at
  // the hit where the material is textured. Only for a hit with a material (materialId >= 0: an object, or an emitter
  // that reflects).
  ShadingPoint Vertex(const SurfaceHit& hit, const Vec3& dir) const;

  // The radiance reflected at x₁ towards x₁.wo by light that reflected at 1 to `bounces` further surfaces
  // first, estimated by one path from the random numbers `u` (kBounceDims × bounces of them, bounce k's at
  // u[k × kBounceDims ...]). Counts its rays. With a `guide` (not Empty), the first direction is drawn from the
  // mixture of x₁'s BSDF and the guide (sim/reference/reference_guide.h); `firstDirection`, when given, receives
  // the first ray's direction (unchanged where the path found no direction).
  Vec3 IndirectSample(const ShadingPoint& x1, int bounces, const float* u, SampleBatch& scratch, uint64_t& rays,
                      const DirectionGuide* guide = nullptr, Vec3* firstDirection = nullptr) const;

  // The same path split at its first vertex after x₁, for ReSTIR GI: IndirectSample is throughput × the
  // vertex's radiance (up to rounding). No vertex (pdfArea 0, throughput 0) where the path ends at x₁.
  struct FirstVertex {
    SecondaryVertex vertex;   // x₂ and L_o(x₂ → x₁) from the rest of the path (bounces 2 to `bounces`)
    Vec3 throughput{0.0f};    // the first step's integrand over its density (Step): f_r(x₁) cos θ₁ / p_ω(ω) but for the offset
    bool reconnectable = false;  // core/reconnection_shift.h Reconnectable(x₂'s BSDF)
  };
  FirstVertex SecondaryVertexSample(const ShadingPoint& x1, int bounces, const float* u, SampleBatch& scratch,
                                    uint64_t& rays) const;

 private:
  const Sequence& sequence_;                  // its materials and textures, for the BSDF at a hit
  const EmbreeScene& scene_;                  // the rays
  const std::vector<LightTriangle>& lights_;  // the scene's light triangles
  const Sky& sky_;                            // empty in a skyless frame
  const SkySummary summary_;                  // what the sky strategies' estimates need of it
  std::vector<Bsdf> materialBsdfs_;           // one per material, untextured
  LightGroups groups_;                        // the light triangles' groups (a quad's two are one)
  std::vector<float> powerCdf_;               // per light group, the cumulative of its share of the power
  PixelLightDistribution powerDistribution_;
  // The groups as the vertices weigh them (core/light_selection_kernel.h); empty above
  // kMaxVertexSelectionGroups.
  std::vector<SelectionLight> selection_;

  // One step of a path: a direction by x's BSDF from ub[0], ub[1], traced from x's spawn offset; x becomes the
  // surface y the ray hits and the throughput is multiplied by the step's integrand over its density, both in
  // area measure at y (f_r(x, ω_xy) cos θ_x |cos θ_y| / ‖y − x‖² over p_ω |cos θ_y,ray| / ‖y − org‖²; the density
  // into *pdfArea when asked); false where the path ends (a failed or absorbed sample, an escape, an emitter).
  // With a `guide`, the direction is drawn from the one-sample mixture kGuideBsdfShare × BSDF + the rest × guide
  // (ub[0] chooses, rescaled for the chosen strategy) and weighed by the mixture's density; `direction`, when
  // given, receives the ray's direction.
  bool Step(ShadingPoint& x, const float* ub, Vec3& throughput, float* pdfArea, uint64_t& rays,
            const DirectionGuide* guide = nullptr, Vec3* direction = nullptr) const;
  // x's direct light by one next-event sample (kSkySampleDims numbers at u) into `value`; false where the
  // frame has no light at all.
  bool NextEvent(const ShadingPoint& x, const float* u, SampleBatch& scratch, Vec3& value, uint64_t& rays) const;
  // The light distribution at vertex x: its own weights where selection_ holds the groups (the cdf in `cdf`),
  // else the power distribution.
  PixelLightDistribution VertexDistribution(const ShadingPoint& x, std::vector<float>& cdf) const;
};

// One frame's indirect light as a preset adds it (issue 41; PipelineSettings::indirect): one path a pixel
// from each primary hit of `g`, an unbiased estimate at every surface pixel (0 elsewhere), from the random
// numbers of RngPass::kIndirect keyed by (seed, frame, pixel). Counts its rays.
ImageRgb IndirectImage(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                       const GBuffer& g, int bounces, uint32_t seed, uint32_t frame, uint64_t& rays);

// One frame's paths as ReSTIR GI takes them (issue 41; sim/estimator/pipeline.h Pipeline::RenderIndirect): the
// paths of IndirectImage (the same random numbers), split at their first vertex x₂. Where x₂ can be
// reconnected, vertices[i] holds it (pdfArea > 0) for the reservoirs; elsewhere the path's whole estimate is in
// `unshifted`, added to the pixel as it is.
struct IndirectVertices {
  std::vector<SecondaryVertex> vertices;  // per pixel; pdfArea 0: none
  ImageRgb unshifted;                     // per pixel: the paths through a vertex that is not reconnected
};
IndirectVertices SecondaryVertices(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                                   const GBuffer& g, int bounces, uint32_t seed, uint32_t frame, uint64_t& rays);

// The random numbers of path `path` of a pixel (RngPass::kReferencePaths, or kReferencePathsPilot for the
// allocation's pilot paths): kBounceDims × bounces of them into u. Each path has its own key, so a pixel's
// paths are independent whatever their count.
void PathRandomNumbers(uint32_t seed, uint32_t stateKey, uint32_t pixel, uint32_t path, RngPass pass,
                       int bounces, float* u);

}  // namespace restir
