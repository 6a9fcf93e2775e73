// The converged reference's samples (sim/reference/reference.h): what RenderReference draws at its receivers once their
// light distributions are built and their points chosen. Frames without a sky sample a block of receivers at once
// through the light-draw and BSDF-draw kernels (core/light_draw_kernel.h, core/bsdf_draw_kernel.h), their shadow
// rays traced as one batch; frames with one sample a receiver at a time with the sky's strategies
// (sim/reference/reference_sky.h). Internal to sim/reference/reference.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/light.h"
#include "core/light_draw_kernel.h"
#include "core/light_selection_kernel.h"  // kSelectionBlock
#include "core/math.h"
#include "core/polygon_light_sampling.h"
#include "core/sampling.h"
#include "sim/scene/embree_scene.h"
#include "sim/reference/reference_learning.h"
#include "sim/reference/reference_sky.h"
#include "sim/scene/shading_point.h"

namespace restir {

// Randomised quasi-Monte Carlo: each pixel's samples are kReplicates independent randomly shifted copies of
// the additive-recurrence (Roberts "R_d") low-discrepancy sequence in kSampleDims dimensions. Each sample is
// still uniformly distributed (so every replicate mean is unbiased), the points are stratified across light
// selection and area (so the error falls much faster than with independent samples), and the spread of the
// independent replicate means gives an honest standard error (Owen 2013, "Monte Carlo theory, methods and
// examples", ch. 17: randomized QMC).
inline constexpr int kSampleDims = 5;  // light selection, two area coordinates, two BSDF coordinates
// Under a sky: the same five (light selection doubling as the environment's texel selection, the two area
// coordinates as the direction's in the sun's cone or the texel), then the strategy choice and the environment's
// alias-table coin. A skyless frame reads only kSampleDims of them.
inline constexpr int kStrategyDim = 5;
inline constexpr int kCoinDim = 6;
inline constexpr int kSkySampleDims = 7;
inline constexpr int kReplicates = 16;

// One receiver's light distribution, as the samplers read it: a view of its cdf over the frame's light groups
// (core/light.h LightGroups) and what its build estimated the lights give the receiver.
class PixelLightDistribution {
 public:
  PixelLightDistribution() = default;
  PixelLightDistribution(const float* cdf, const LightGroups* groups, float estimate)
      : cdf_(cdf), groups_(groups), estimate_(estimate) {}
  // Light triangle for u in [0, 1), by inverting the cumulative distribution over the groups, then the group's
  // split by area (stratified u stays stratified). Only when rounding puts the target at the total is the last
  // group returned whatever its Pmf; a zero density then gives the sample no light term.
  uint32_t Sample(float u) const {
    return SampleSplitCdf(cdf_, groups_->first.size(), groups_->first.data(), groups_->split.data(), u);
  }
  // The area density of a point that Sample's triangle l and a uniform point on it give: the group's probability
  // as the cdf it inverts sees it (CdfPmf), times 1 / the group's area, as the light-draw kernel computes it.
  float AreaDensity(uint32_t l) const {
    return CdfPmf(cdf_, groups_->first.size(), groups_->groupOf[l]) * groups_->invArea[l];
  }
  const float* Cdf() const { return cdf_; }
  // The group light triangle l belongs to.
  uint32_t GroupOf(uint32_t l) const { return groups_->groupOf[l]; }
  // What the build estimated the lights give the receiver together (the luminance of the reflected radiance,
  // unshadowed; core/light_selection_kernel.h), or -1 where it did not estimate it (above kMaxPerPixelLights).
  // Sets the local lights' share of the light mixture under a sky (sim/reference/reference_sky.h).
  float Estimate() const { return estimate_; }

 private:
  const float* cdf_ = nullptr;
  const LightGroups* groups_ = nullptr;
  float estimate_ = -1.0f;
};

// The frame's light triangles as the light-draw kernel reads them (core/light_draw_kernel.h).
struct LightDrawSoa {
  struct alignas(64) Record {
    float v[kLightDrawRecordFloats];  // WriteLightDrawRecord's layout
  };
  std::vector<Record> records;    // one per light triangle, in the frame's order
  std::vector<float> errorScale;  // LightTriangle::errorScale, likewise
  LightDrawLights view;           // what the kernel reads: the two above and the groups
  LightDrawSoa(const std::vector<LightTriangle>& lights, const LightGroups& groups) : records(lights.size()) {
    for (size_t l = 0; l < lights.size(); ++l) {
      WriteLightDrawRecord(lights[l], groups.invArea[l], records[l].v);
      errorScale.push_back(lights[l].errorScale);
    }
    view.records = records.empty() ? nullptr : records.data()->v;
    view.errorScale = errorScale.data();
    view.count = lights.size();
    view.groupFirst = groups.first.data();
    view.groupSplit = groups.split.data();
    view.groups = groups.first.size();
  }
};

// The sky of a frame (null in a skyless one) and one receiver's light mixture, as SkySamples needs them.
struct SkySampling {
  const Sky* sky = nullptr;  // null: a skyless frame, sampled exactly as before the sky existed
  LightMixture mixture;      // the receiver's strategy probabilities ({1, 0, 0} in a skyless frame)
  // The sun under the difference estimator (SkySamples): its exact unshadowed contribution (reference_sky.h
  // SunDifferenceConstant) is the receiver's ReceiverBlock::differenceConstant, and its samples estimate only what
  // shadows take from it.
  bool differenceSun = false;
};

// Per-thread scratch of one pixel's samples: the light-sampling terms wait for their shadow rays, which go to
// Embree as one batch (packets, EmbreeScene::OccludedBatch) instead of one rtcOccluded1 per sample.
struct SampleBatch {
  std::vector<Vec3> lightTerm;   // per sample: the light-sampling term if its shadow ray is unoccluded
  std::vector<Vec3> occludedTerm;  // per sample: what its light term is where its shadow ray is occluded (0 but
                                  // under the sun's difference estimator)
  std::vector<float> lightSunPart;  // per sample, while recording: the sun's part of its light term (luminance)
  std::vector<Vec3> bsdfTerm;    // per sample: the BSDF-sampling term, visibility already resolved
  std::vector<ShadowRay> rays;   // the shadow rays of the samples whose light term is nonzero
  std::vector<uint32_t> rayOf;   // the sample each ray belongs to
  std::vector<uint8_t> occluded;
  // An indirect path's vertex: its light distribution's cdf over the groups, then its weights
  // (sim/reference/reference_paths.h PathScene).
  std::vector<float> vertexCdf;
};

// A block of receivers of one row, as the samplers take them.
struct ReceiverBlock {
  size_t count = 0;                                // receivers, at most kSelectionBlock
  size_t index[kSelectionBlock] = {};              // their pixels
  ShadingPoint points[kSelectionBlock];            // what each sees
  int32_t materialId[kSelectionBlock] = {};        // its entry in the frame's BsdfSoa
  PixelLightDistribution dists[kSelectionBlock];   // its light distribution
  SkySampling sky[kSelectionBlock];                // its sky and light mixture
  // Under the difference estimator (sim/reference/reference_learning.h): the groups differenced at each receiver
  // (none elsewhere), whose samples keep their light term's negative where its shadow ray is occluded and 0 where it
  // is not; and their exact unshadowed contribution Σ U_l, which the receiver's estimate adds to its samples' mean.
  DifferencedGroups differenced[kSelectionBlock];
  glm::dvec3 differenceConstant[kSelectionBlock];
  // Receiver r's differenced groups' projected-solid-angle samplers, the j-th group's at [r × kMaxDifferencedGroups
  // + j]: a differenced group's draws take their points from it instead of uniformly by area.
  std::vector<ProjectedSolidAngleSampler> differencedSamplers;
  bool projectedSolidAngleDraws = false;  // false: they keep the kernel's (ReferenceParams::projectedSolidAngleDraws)
  ProjectedSolidAngleSampler* DifferencedSamplers(size_t r) {
    if (differencedSamplers.empty()) differencedSamplers.resize(kSelectionBlock * kMaxDifferencedGroups);
    return differencedSamplers.data() + r * kMaxDifferencedGroups;
  }
  const ProjectedSolidAngleSampler* DifferencedSamplers(size_t r) const {
    return differencedSamplers.data() + r * kMaxDifferencedGroups;
  }
};

// What the pilot keeps of each sample's light-sampling draw, for the visibility-aware selection
// (sim/reference/reference_learning.h): the samplers write one entry per sample where these point somewhere.
struct LightTermRecord {
  float* unshadowed = nullptr;  // luminance of the light term (its MIS weight included) before visibility; 0: none
  uint8_t* visible = nullptr;   // 1 where its shadow ray was unoccluded
  uint32_t* light = nullptr;    // the light triangle drawn (a local-light draw), else kNoRecordedLight
  uint8_t* strategy = nullptr;  // the LightStrategy drawn (kLocal in a skyless frame)
  // Under a sky: the luminance of the part of the sample's value the sun's radiance gave (light and BSDF terms, as
  // they arrived), for the relative variance the sun's difference estimator will leave (null: not recorded).
  float* sunPart = nullptr;
};
inline constexpr uint32_t kNoRecordedLight = 0xFFFFFFFFu;

// Per-thread scratch of a block's samples.
struct BlockScratch {
  std::vector<uint32_t> words;    // random words (PixelRandomWords4's layout)
  std::vector<float> u;           // the points: receiver p's coordinate j of sample k at u[uFirst[p] + j × n_p + k]
  std::vector<float> values[3];   // the samples, r g b: receiver p's sample k at values[c][first[p] + k]
  std::vector<float> drawn[7];    // the light-draw kernel's rays: origin, direction, length
  std::vector<uint32_t> drawOf;   // the block sample each of its rays belongs to
  std::vector<uint8_t> occluded;  // each ray's answer
  std::vector<float> bsdfDrawn[10];  // the BSDF-draw kernel's outputs: origin, direction, throughput r g b, density
  std::vector<uint32_t> bsdfOf;      // the block sample each of its rays belongs to
  SampleBatch batch;              // SkySamples' scratch
  // The block's LightTermRecord arrays (receiver p's sample k at first[p] + k), written where `record` is set.
  bool record = false;
  std::vector<float> recordUnshadowed;
  std::vector<uint8_t> recordVisible;
  std::vector<uint32_t> recordLight;
  std::vector<uint8_t> recordStrategy;
  std::vector<float> recordSunPart;  // under a sky only
  LightTermRecord RecordAt(size_t first) {
    if (!record) return {};
    return {recordUnshadowed.data() + first, recordVisible.data() + first, recordLight.data() + first,
            recordStrategy.data() + first, recordSunPart.empty() ? nullptr : recordSunPart.data() + first};
  }
};

// `count` direct-lighting samples at a receiver in a frame with a sky, from the points whose coordinate j is
// u[j * count + k] (kSkySampleDims coordinates): light sampling (a strategy from the receiver's mixture, then a
// light point or a sky direction from it) plus BSDF sampling, combined by the power heuristic (pbrt-v4
// PathIntegrator::SampleLd style, restricted to direct light); BSDF sampling on every surface, as a BSDF ray that
// escapes is the only way to reach the sky's directions the light mixture samples rarely. Sample k's value is
// (out[0][k], out[1][k], out[2][k]). Frames without a sky take SkylessBlockSamples.
// With record.unshadowed set, each sample's light-sampling draw is recorded there too (and with record.sunPart, the
// sun's part of its value). With sky.differenceSun, the sun's part of a sample is −(its light term's sun part) where
// the ray is occluded and 0 where not, and the BSDF term leaves the sun out: the receiver's estimate adds the sun's
// exact unshadowed contribution (the difference estimator, as SkylessBlockSamples' for local lights).
void SkySamples(const ShadingPoint& sp, const EmbreeScene& scene, const std::vector<LightTriangle>& lights,
                const PixelLightDistribution& dist, const SkySampling& sky, const float* u, size_t count,
                SampleBatch& b, float* const (&out)[3], uint64_t& rays, const LightTermRecord& record = {});

// The direct-lighting samples of a block of receivers in a frame without a sky: receiver p's counts[p] samples
// from the points at u + uFirst[p] (SkySamples' layout, kSampleDims coordinates), into out + first[p]. Light
// sampling from each receiver's distribution, plus, at a receiver that is not diffuse, BSDF sampling with the power
// heuristic. The light half is the light-draw kernel (a packet of draws per register, its MIS weight included),
// every receiver's shadow rays then traced as one batch; the BSDF half the BSDF-draw kernel, each of its rays asking
// EmbreeScene::FirstEmitter. Reads coordinates 0-2 at a diffuse receiver, 0-4 at others; out[c] is the block's
// samples' channel c. Where s.record is set, every sample's light draw is recorded in s's record arrays. At a
// receiver with differenced groups (ReceiverBlock::differenced), a sample of such a group is −(its light term) where
// its ray is occluded and 0 where not: the estimate of what the shadows take from the group's exact contribution;
// with ReceiverBlock::projectedSolidAngleDraws, its point is drawn by the group's projected-solid-angle sampler
// (ReceiverBlock::differencedSamplers), so that the term is nearly the same at every draw.
void SkylessBlockSamples(const ReceiverBlock& block, const size_t* counts, const size_t* uFirst, const size_t* first,
                         const EmbreeScene& scene, const BsdfSoa& materials,
                         const std::vector<LightTriangle>& lightList, const LightDrawLights& lights, BlockScratch& s,
                         float* const (&out)[3], uint64_t& rays);

}  // namespace restir
