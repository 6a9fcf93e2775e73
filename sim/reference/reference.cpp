#include "sim/reference/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <sys/mman.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <filesystem>
#include <array>

#include "core/light_sampler.h"
#include "core/light_selection_kernel.h"
#include "core/polygon_irradiance.h"
#include "core/qmc_kernel.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/shadow_ray.h"
#include "sim/util/atomic_file.h"
#include "sim/util/clock.h"
#include "sim/util/hash.h"
#include "sim/util/input_file.h"
#include "sim/reference/reference_cache.h"
#include "sim/reference/reference_learning.h"
#include "sim/reference/reference_paths.h"
#include "sim/reference/reference_samples.h"
#include "sim/reference/reference_sky.h"
#include "sim/scene/shading_point.h"
#include "sim/scene/sky_frame.h"

namespace restir {

namespace {

// Bump when the renderer changes what it computes: old cache entries then stop matching (8: issue 16's redesign,
// light groups, the selection and BSDF-draw kernels, fixed-point points; 9: a BSDF draw's emitter distance from
// the triangle in double, not Embree's vendor-dependent reciprocal; 10: issue 40's visibility-aware selection; 11: the
// error target's floor at a quarter of the mean variance and its sample cap, five tile anchors; 12: per-pixel probes;
// 13: the difference estimator at diffuse receivers; 14: the sun under it, Lambert's arctangents from
// core/portable_math.h; 15: per-pixel distributions up to 32768 light triangles, many_rooms' and many_lights'; 16:
// the pilot's relative variances spread to their neighbourhood before the allocation).
constexpr uint32_t kReferenceVersion = 16;
// The version of the indirect paths (sim/reference/reference_paths.h), in the key of references that have them.
// 2: the secondary vertices weigh their lights; 3: a step is weighed in area measure from the ray's true origin;
// 4: the first direction guided by what the pilot's paths found (sim/reference/reference_guide.h).
constexpr uint32_t kPathsVersion = 4;
// The reference has its own seed so that runs with different --seed share one reference.
constexpr uint32_t kReferenceSeed = 0x5EFE12ECu;

// Light selection for one receiver (core/light_selection_kernel.h): power alone spends most samples on lights
// that barely reach the pixel (the flagship's facade is lit through a window by a few of 72 lights), so the
// reference mixes, per pixel, selection proportional to each light's unshadowed contribution there with a
// defensive share by power. Every light with power keeps P > 0, so the estimator stays unbiased; only visibility
// and the variation across a light remain as noise. The distributions of a block of receivers are built at once,
// one receiver per SIMD lane. Above kMaxPerPixelLights, one distribution per learning tile instead (TileCdf). A
// pixel's table costs time in proportion to the groups, and one per tile loses what varies within the tile: the
// distance and angle to each light, which in a many-light scene is most of what sets a pixel's distribution. With
// the limit at 4096, many_rooms (5280 triangles) took tables per tile: frame 0 at its defaults, 640 × 360, mean
// relative standard error 5.16%, 99th percentile 16.8%, in 4.5 s; per pixel, 1.84% and 10.5% in 8.5 s (relative
// variance per ray 0.438 → 0.082). many_lights (20,002 triangles, 320 × 180, 256 samples a pixel): 6.46% in 1.5 s
// per tile, 3.10% in 2.6 s per pixel (docs/metrics.md). The limit keeps tiles for scenes of tens of thousands of
// emitters, where the tables' time grows past the rays'. The main pass reshapes either by the visibility the pilot
// found (sim/reference/reference_learning.h).
constexpr size_t kMaxPerPixelLights = 32768;
// Memory the pilot's per-pixel light distributions may take to be kept for the main pass (beyond it, the main pass
// builds them again: the same bits).
constexpr size_t kKeptDistributionBytes = size_t{512} << 20;

// An uninitialised float array in transparent huge pages where the system offers them (Linux, THP in "madvise"
// mode as Debian ships it): a large array first touched page by page otherwise takes a page fault per 4 KiB.
class HugePageFloats {
 public:
  explicit HugePageFloats(size_t count) {
    if (count == 0) return;
    constexpr size_t kHuge = size_t{2} << 20;
    const size_t bytes = (count * sizeof(float) + kHuge - 1) / kHuge * kHuge;
    data_ = static_cast<float*>(std::aligned_alloc(kHuge, bytes));
    if (!data_) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
    madvise(data_, bytes, MADV_HUGEPAGE);  // advice only: where it is refused, 4 KiB pages
#endif
  }
  ~HugePageFloats() { std::free(data_); }
  HugePageFloats(const HugePageFloats&) = delete;
  HugePageFloats& operator=(const HugePageFloats&) = delete;
  float* get() const { return data_; }

 private:
  float* data_ = nullptr;
};

// The pilot's kept distributions: one buffer per process, lent to one render at a time and kept between frames (a
// frame of fresh pages paid about 3% of its render in the kernel's zeroing of them at the first touches, measured
// at 640x360); a render that finds it lent or too small allocates its own, and the larger of the two stays.
class KeptDistributions {
 public:
  explicit KeptDistributions(size_t floats) {
    if (floats == 0) return;
    {
      std::lock_guard<std::mutex> lock(Mutex());
      if (Spare().buffer && Spare().floats >= floats) {
        held_ = std::move(Spare());
        Spare() = Held{};
        return;
      }
    }
    held_.buffer = std::make_unique<HugePageFloats>(floats);
    held_.floats = floats;
  }
  ~KeptDistributions() {
    if (!held_.buffer) return;
    std::lock_guard<std::mutex> lock(Mutex());
    if (held_.floats >= Spare().floats) Spare() = std::move(held_);
  }
  KeptDistributions(const KeptDistributions&) = delete;
  KeptDistributions& operator=(const KeptDistributions&) = delete;
  float* get() const { return held_.buffer ? held_.buffer->get() : nullptr; }

 private:
  struct Held {
    std::unique_ptr<HugePageFloats> buffer;
    size_t floats = 0;
  };
  static std::mutex& Mutex() {
    static std::mutex m;
    return m;
  }
  static Held& Spare() {
    static Held spare;
    return spare;
  }
  Held held_;
};

// Two-stage allocation (issue 16; docs/metrics.md, "How the reference is sampled"): kPilotSamples points per pixel,
// one randomly shifted copy of the Roberts sequence, estimate the per-sample relative variance v = Var[f] / E[f]²
// (each point is uniform; stratification only lowers the spread of their mean, so their sample variance errs high
// by at most n / (n - 1)); the main pass then spends samples in proportion to v (every pixel reaching about the
// same relative standard error), with samples independent of the pilot's. The pilot's samples are not part of the
// estimate: the allocation is then a function of independent randomness only, so each pixel's estimate and its
// replicate standard error stay unbiased given its sample count (no stopping on the sample's own values).
constexpr int kPilotSamples = 16;
// In budget mode, this share of the main budget goes to every pixel uniformly; in error mode, no pixel is planned
// below this share of the mean v: the pilot's 16 samples can miss a rare light (v estimated 0), and a floor keeps
// such pixels from being starved (door_ajar at a 2% target: 16.4% mean relative standard error with it, 41% without).
constexpr double kUniformShare = 0.25;
// No pixel gets more than this multiple of the mean per-replicate count (budget mode), or more than
// kMaxSamplesPerPixel (error mode).
constexpr int kMaxAllocationScale = 16;
constexpr int kMaxSamplesPerPixel = 1 << 16;

// Budget mode's mean per-replicate count of the main pass: the budget after the pilot's samples, in replicates.
double MeanPerReplicate(int samplesPerPixel) {
  return std::max(1.0, std::ceil(double(std::max(1, samplesPerPixel) - kPilotSamples) / kReplicates));
}

// The mean of the pilot's relative variances over every active pixel, those where it saw no light counted as 0 (so
// that budget mode's allocation averages its budget).
double MeanRelativeVariance(const std::vector<float>& relVar, const std::vector<uint8_t>& active) {
  double sum = 0.0;
  size_t activeCount = 0;
  for (size_t i = 0; i < relVar.size(); ++i) {
    activeCount += active[i];
    if (active[i] && relVar[i] > 0.0f) sum += relVar[i];
  }
  return activeCount ? sum / double(activeCount) : 0.0;
}

// Error mode's per-replicate count: the relative standard error of a mean of n samples is sqrt(v / n) = E, so
// n = v / E² samples (at most kMaxSamplesPerPixel), as whole replicates, at least one each.
uint32_t TargetPerReplicate(float relVar, double e2) {
  const double n = relVar > 0.0f ? std::min(std::ceil(double(relVar) / e2), double(kMaxSamplesPerPixel)) : 0.0;
  return static_cast<uint32_t>(std::max(1.0, std::ceil(n / kReplicates)));
}

// Budget mode's counts: a uniform share of the mean per-replicate count for every active pixel, the rest in
// proportion to v, none above kMaxAllocationScale times the mean. What that cap cuts off is shared out among the
// pixels below it in proportion to their shares (again where that takes more of them to the cap), so that the counts
// spend the budget: with the difference estimator most pixels' v is about 0 and a few penumbra pixels' large, and
// the cap alone left 11% of a 256-sample budget unspent beside a thin occluder
// (tests/sim/reference/independent_visibility_test.cpp). Where nothing reaches the cap the counts are as before.
std::vector<uint32_t> BudgetPerReplicate(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                         int samplesPerPixel) {
  std::vector<uint32_t> m(relVar.size(), 0);
  const double meanPerReplicate = MeanPerReplicate(samplesPerPixel);
  const double meanV = MeanRelativeVariance(relVar, active);
  const double cap = meanPerReplicate * kMaxAllocationScale;
  std::vector<double> want(relVar.size(), 0.0);
  size_t activeCount = 0;
  for (size_t i = 0; i < relVar.size(); ++i) {
    if (!active[i]) continue;
    const double share = meanV > 0.0 ? kUniformShare + (1.0 - kUniformShare) * std::max(0.0f, relVar[i]) / meanV
                                     : 1.0;
    want[i] = meanPerReplicate * share;
    ++activeCount;
  }
  const double budget = meanPerReplicate * double(activeCount);
  for (int round = 0; round < 16; ++round) {
    double atCap = 0.0, below = 0.0;
    for (size_t i = 0; i < relVar.size(); ++i)
      if (active[i]) (want[i] >= cap ? atCap : below) += want[i] >= cap ? cap : want[i];
    const double left = budget - atCap;
    if (!(below > 0.0) || !(left > below * (1.0 + 1e-9))) break;  // nothing was cut off, or nothing can take it
    const double scale = left / below;
    for (size_t i = 0; i < relVar.size(); ++i)
      if (active[i] && want[i] < cap) want[i] *= scale;
  }
  for (size_t i = 0; i < relVar.size(); ++i)
    if (active[i]) m[i] = static_cast<uint32_t>(std::max(1.0, std::min(std::round(want[i]), cap)));
  return m;
}

// Error mode's counts: each pixel the samples its v needs for the target, v floored at a share of the mean. When
// their mean (the pilot's included) passes the cap, the frame spends the cap as a fixed budget instead: at equal
// samples budget mode's allocation measured lower mean and 99th-percentile error than the target's scaled down
// (window_bars_pan at 48: 5.28% / 13.7% against 5.45% / 14.1%; moving_occluder at 256: 0.98% / 2.3% against 1.17% /
// 2.6%), and the capped frame is then the `--reference-spp cap` frame, bit for bit. `scale`: the cap over the
// target's mean (1 when affordable).
std::vector<uint32_t> TargetPerReplicateCounts(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                               const ReferenceParams& params, double& scale) {
  const float floor = static_cast<float>(kUniformShare * MeanRelativeVariance(relVar, active));
  const double e2 = params.targetRelativeError * params.targetRelativeError;
  std::vector<uint32_t> m(relVar.size(), 0);
  double sum = 0.0;
  size_t activeCount = 0;
  for (size_t i = 0; i < relVar.size(); ++i) {
    if (!active[i]) continue;
    m[i] = TargetPerReplicate(std::max(relVar[i], floor), e2);
    sum += kPilotSamples + double(m[i]) * kReplicates;
    ++activeCount;
  }
  const double meanSamples = activeCount ? sum / double(activeCount) : 0.0;
  scale = 1.0;
  if (params.maxMeanSamplesPerPixel > 0 && meanSamples > params.maxMeanSamplesPerPixel) {
    scale = double(params.maxMeanSamplesPerPixel) / meanSamples;
    return BudgetPerReplicate(relVar, active, params.maxMeanSamplesPerPixel);
  }
  return m;
}

// Per-replicate sample counts from the pilot's relative variances (negative: the pilot saw no light), and in
// error mode the scale the cap imposed (ReferenceAllocation::scale).
std::vector<uint32_t> AllocateSamples(const std::vector<float>& relVar, const std::vector<uint8_t>& active,
                                      const ReferenceParams& params, double& scale) {
  scale = 1.0;
  if (params.targetRelativeError > 0.0) return TargetPerReplicateCounts(relVar, active, params, scale);
  return BudgetPerReplicate(relVar, active, params.samplesPerPixel);
}

// A cached reference, or false when there is none. An entry that exists but is not a valid answer for this key
// (damaged, truncated, another frame's, not a regular file) is reported in one line and rendered again; the new
// entry then replaces it.
bool ReadCache(const std::string& path, const std::string& key, int w, int h, ReferenceImage& out,
               bool quiet = false) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, ReferenceCacheEntrySize(key, w, h), bytes, problem)) {
    if (problem == "no such file") return false;
  } else if (DecodeReferenceCacheEntry(bytes, key, w, h, out.mean, out.standardError, out.lumaStandardError,
                                       problem, &out.allocation)) {
    return true;
  }
  if (quiet) return false;  // read again under the lock: the first reading already said what is wrong with it
  std::fprintf(stderr, "restir-sim: warning: %s: unusable reference cache entry (%s); rendering it again\n",
               path.c_str(), problem.c_str());
  return false;
}

}  // namespace

uint64_t HashFrameState(const FrameState& state) {
  const Camera& c = state.camera;
  const float camera[13] = {c.position.x, c.position.y, c.position.z, c.forward.x, c.forward.y, c.forward.z,
                            c.up.x,       c.up.y,       c.up.z,       c.right.x,   c.right.y,   c.right.z,
                            c.vfovDegrees};
  const int32_t size[2] = {c.width, c.height};
  uint64_t h = Fnv1a(camera, sizeof(camera));
  h = Fnv1a(size, sizeof(size), h);
  for (const Mat4& m : state.objectToWorld) h = Fnv1a(&m, sizeof(Mat4), h);
  h = Fnv1a(state.lightOn.data(), state.lightOn.size(), h);
  // The sky's state only where the frame has a sky: a skyless frame's hash, hence its reference's random numbers
  // and cache key, stay what they were before the sky existed.
  if (state.environmentIntensity > 0.0f || state.sunIntensity > 0.0f) {
    const float sky[6] = {state.environmentIntensity, state.environmentRotationDegrees, state.sunDirection.x,
                          state.sunDirection.y,       state.sunDirection.z,             state.sunIntensity};
    h = Fnv1a(sky, sizeof(sky), h);
  }
  return h;
}

std::string ReferenceCacheKey(const Sequence& sequence, const FrameState& state, const ReferenceParams& params) {
  // The error target, when set, replaces the budget: two runs with different spp share its entry.
  const bool target = params.targetRelativeError > 0.0;
  const int32_t fields[4] = {target ? 0 : params.samplesPerPixel, target ? params.maxMeanSamplesPerPixel : 0,
                             static_cast<int32_t>(kReferenceVersion) | (params.learnVisibility ? 0 : 1 << 30) |
                                 (params.differenceShadows ? 0 : 1 << 29) |
                                 (params.projectedSolidAngleDraws ? 1 << 28 : 0) |
                                 (params.spreadRelativeVariance ? 0 : 1 << 27),
                             static_cast<int32_t>(kReferenceSeed + params.seed)};
  const double error = target ? params.targetRelativeError : 0.0;
  uint64_t h = Fnv1a(sequence.contentHash.data(), sequence.contentHash.size());
  h = Fnv1a(fields, sizeof(fields), h);
  h = Fnv1a(&error, sizeof(error), h);
  // Hashed only where there is indirect light, so that direct-light entries keep their keys.
  if (params.indirectBounces > 0) {
    const int32_t bounces[2] = {params.indirectBounces,
                                static_cast<int32_t>(kPathsVersion) | (params.guidePaths ? 0 : 1 << 30)};
    h = Fnv1a(bounces, sizeof(bounces), h);
  }
  const uint64_t s = HashFrameState(state);
  return HexHash(Fnv1a(&s, sizeof(s), h));
}

namespace {

// Where the frame's reference is cached (no path: no cache), and the lock on that entry, held until it is
// written.
struct CacheEntry {
  std::string path, key;
  std::optional<FileLock> lock;
};

// The frame's cached reference, or none: then `entry` names where to write it and holds its lock where one
// was taken.
std::optional<ReferenceImage> LookUpCache(const Sequence& sequence, const FrameState& state, int w, int h,
                                          const ReferenceParams& params, CacheEntry& entry) {
  if (params.cacheDir.empty()) return std::nullopt;
  entry.key = ReferenceCacheKey(sequence, state, params);
  entry.path = (std::filesystem::path(params.cacheDir) / ("ref-" + entry.key + ".bin")).string();
  ReferenceImage cached;
  if (ReadCache(entry.path, entry.key, w, h, cached)) {
    cached.fromCache = true;
    return cached;
  }
  // Many processes (a sweep's jobs, on one machine or a cluster's shared file system) may want this entry at
  // once: the first to lock it renders it, the others wait and read its entry instead of rendering it again.
  // Without the lock (a file system that cannot lock) they render concurrently; each entry's bytes are the same
  // and reach the file by an atomic rename, so any one of them is whole.
  entry.lock.emplace((std::filesystem::path(params.cacheDir) / ("ref-" + entry.key + ".lock")).string());
  if (entry.lock->Held() && ReadCache(entry.path, entry.key, w, h, cached, /*quiet=*/true)) {
    cached.fromCache = true;
    return cached;
  }
  return std::nullopt;
}

// Writes a rendered reference to its cache entry, where it has one.
void WriteCache(const CacheEntry& entry, const ReferenceImage& ref) {
  if (!entry.path.empty())
    WriteFileAtomic(entry.path,
                    EncodeReferenceCacheEntry(entry.key, ref.mean, ref.standardError, ref.lumaStandardError,
                                              ref.allocation));
}

// Keyed by the scene state, not the frame index: frames that show the same state (a static camera and scene)
// get the same reference, bit for bit, and share one cache entry.
uint32_t StateKey(const FrameState& state) {
  const uint64_t stateHash = HashFrameState(state);
  return static_cast<uint32_t>(stateHash ^ (stateHash >> 32));
}

// One frame as both passes see it: its pixels, lights, materials and sky, the pixels that take samples and
// the key of their random numbers. The passes write only the light mixtures and their counts of rays and
// samples.
struct ReferenceFrame {
  ReferenceFrame(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                 const GBuffer& g);

  const Sequence* sequence;
  const FrameState& state;
  const EmbreeScene& scene;
  const GBuffer& g;
  const int w, h;
  const size_t pixels;
  const std::vector<LightTriangle>& lightList;
  const LightSampler lights;
  const BsdfSoa bsdfs;
  // The sky (issue 18): light sampling becomes a per-pixel mixture of the local lights, the sun and the
  // environment (sim/reference/reference_sky.h), and every surface gets BSDF sampling. A skyless frame takes none
  // of it.
  const Sky sky;
  const bool hasSky;
  const SkySummary skySummary;
  const int dims;
  const bool hasLocal;
  const uint32_t stateKey;
  uint32_t seed = kReferenceSeed;  // kReferenceSeed + ReferenceParams::seed
  std::vector<uint8_t> active;  // the pixels that take samples: surfaces, where the frame has light to sample
  // Under a sky, each pixel's light mixture: the pilot's from its unshadowed estimates (kept in skyEstimates:
  // local, sun, environment), then reshaped by what the pilot's samples delivered (sim/reference/reference_learning.h)
  // for the main pass.
  std::vector<LightMixture> mixtures;
  std::vector<std::array<float, 3>> skyEstimates;
  // The learning tiles (kLearningTile pixels a side, row-major): what each tile's pilot learned of the light groups'
  // visibility, which reshapes the main pass's light distributions there.
  const int tilesX, tilesY;
  std::vector<TileLightLearning> learning;
  // Each pixel's probes of the light groups (PixelProbes), where the frame has few enough groups; else empty.
  std::vector<PixelProbes> probes;
  // The difference estimator (ReferenceParams::differenceShadows) where it applies: a frame without a sky whose
  // main pass reshapes its distributions by what the pilot learned; then at its diffuse receivers with per-pixel
  // distributions.
  bool difference = false;
  // Under it, whether differenced groups draw their points by projected solid angle
  // (ReferenceParams::projectedSolidAngleDraws).
  bool projectedSolidAngleDraws = false;
  // The same for the sun under a sky (ReferenceParams::differenceShadows; SkySampling::differenceSun), and the
  // pixels whose sun it differences: diffuse ones whose whole disc is in front of both normals and whose pilot drew
  // the sun at least kDifferenceLeastDraws times, every draw arriving.
  bool sunDifference = false;
  std::vector<uint8_t> sunDifferenced;
  // Under it, each diffuse receiver's groups its pilot drew at least kDifferenceLeastDraws times, every draw
  // unoccluded (DifferencedGroups::eligible).
  std::vector<PilotVisibleGroups> eligible;
  size_t TileOf(size_t pixel) const {
    const size_t x = pixel % static_cast<size_t>(w), y = pixel / static_cast<size_t>(w);
    return (y / kLearningTile) * static_cast<size_t>(tilesX) + x / kLearningTile;
  }
  tbb::combinable<uint64_t> rays{[] { return uint64_t{0}; }};
  tbb::combinable<uint64_t> samples{[] { return uint64_t{0}; }};
};

ReferenceFrame::ReferenceFrame(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& g)
    : sequence(&sequence),
      state(state),
      scene(scene),
      g(g),
      w(g.width),
      h(g.height),
      pixels(static_cast<size_t>(w) * h),
      lightList(scene.LightTriangles()),
      lights(lightList, LightSelection::kPower),
      bsdfs(FrameBsdfTable(MaterialBsdfs(sequence), sequence.materials, g, nullptr)),
      sky(MakeSky(sequence, state)),
      hasSky(!sky.Empty()),
      skySummary(hasSky ? SummarizeSky(sky) : SkySummary{}),
      dims(hasSky ? kSkySampleDims : kSampleDims),
      hasLocal(!lights.Empty()),
      stateKey(StateKey(state)),
      active(pixels, 0),
      mixtures(hasSky ? pixels : 0),
      skyEstimates(hasSky ? pixels : 0),
      tilesX((w + kLearningTile - 1) / kLearningTile),
      tilesY((h + kLearningTile - 1) / kLearningTile),
      learning(static_cast<size_t>(tilesX) * tilesY) {
  for (size_t i = 0; i < pixels; ++i) active[i] = g.IsSurface(i) && (hasLocal || hasSky);
}

// The image before its samples: what each pixel's primary ray sees emitted; where it escaped, the sky it sees
// (zero in a skyless frame).
ReferenceImage StartImage(const ReferenceFrame& frame) {
  ReferenceImage ref;
  ref.mean = ImageRgb(frame.w, frame.h);
  ref.standardError = ImageRgb(frame.w, frame.h);
  ref.lumaStandardError.assign(frame.pixels, 0.0f);
  for (size_t i = 0; i < frame.pixels; ++i)
    ref.mean.pixels[i] = DirectEmission(frame.g, i, frame.lightList, frame.sky, frame.state.camera);
  return ref;
}

// How the passes build their blocks' light distributions. Per-pixel distributions
// (core/light_selection_kernel.h) up to kMaxPerPixelLights; above, one per learning tile (TileCdf), made by
// each worker as it meets the tile. Without local lights (none, or all switched off) under a sky, no pixel has a
// light distribution.
struct BlockPlan {
  explicit BlockPlan(const ReferenceFrame& frame);

  const LightGroups groups;
  const size_t nGroups;
  const LightDrawSoa drawLights;
  const bool perPixelLights;
  std::vector<SelectionLight> selectionLights;
  SelectionLights selection;
  std::vector<float> groupPowerPmf;  // per group, its triangles' Φ / Σ Φ (the reshaping's defensive share)
  // The pilot's distributions, kept for the main pass where they fit in kKeptDistributionBytes: each row's blocks
  // in order (both passes form the same blocks), row y's from keptRow[y] on, kSelectionBlock × nGroups floats a
  // block, light-major as the selection kernel writes them (whole cache lines); each pass copies a block's to rows
  // in its own scratch to draw from. Not value-initialised: the pilot writes every entry the main pass reads. In
  // huge pages: first touches of 4 KiB pages would cost a page fault each.
  const std::vector<size_t> keptRow;
  const bool keep;
  const KeptDistributions kept;
};

// BlockPlan::keptRow: each row's active pixels in whole blocks of kSelectionBlock distributions.
std::vector<size_t> KeptRows(const ReferenceFrame& frame, bool perPixelLights, size_t nGroups) {
  const int w = frame.w, h = frame.h;
  std::vector<size_t> keptRow(static_cast<size_t>(h) + 1, 0);
  if (perPixelLights)
    for (int y = 0; y < h; ++y) {
      size_t rowActive = 0;
      for (int x = 0; x < w; ++x) rowActive += frame.active[static_cast<size_t>(y) * w + x];
      const size_t blocks = (rowActive + kSelectionBlock - 1) / kSelectionBlock;
      keptRow[y + 1] = keptRow[y] + blocks * kSelectionBlock * nGroups;
    }
  return keptRow;
}

BlockPlan::BlockPlan(const ReferenceFrame& frame)
    : groups(MakeLightGroups(frame.lightList)),
      nGroups(groups.first.size()),
      drawLights(frame.lightList, groups),
      perPixelLights(frame.hasLocal && frame.lightList.size() <= kMaxPerPixelLights),
      keptRow(KeptRows(frame, perPixelLights, nGroups)),
      keep(perPixelLights && keptRow[frame.h] * sizeof(float) <= kKeptDistributionBytes),
      kept(keep ? keptRow[frame.h] : 0) {
  const size_t nLights = frame.lightList.size();
  std::vector<float> powerPmf;
  for (uint32_t l = 0; frame.hasLocal && l < nLights; ++l) powerPmf.push_back(frame.lights.SelectionPmf(l));
  if (frame.hasLocal) selectionLights = MakeSelectionLights(frame.lightList, groups, powerPmf);
  if (frame.hasLocal) groupPowerPmf = GroupShares(powerPmf, groups);
  selection = SelectionLights{perPixelLights ? selectionLights.data() : nullptr,
                              perPixelLights ? selectionLights.size() : 0};
}

// One pilot draw of a diffuse receiver without a sky: its light group, the luminance of its light term before
// visibility, and whether its shadow ray was unoccluded.
struct PilotDraw {
  uint32_t group = 0;
  float unshadowed = 0.0f;
  bool visible = false;
};

// What one band of learning tiles' pilot carried, accumulated by the thread that runs the band: per tile, per light
// group and per sky strategy; per pixel, per sky strategy.
struct BandLearning {
  int band = -1;
  std::vector<TileLightSums> tiles;
  std::vector<StrategySums> tileStrategies;
  std::vector<StrategySums> pixelStrategies;  // the band's pixels, row-major from its first row
  // Under the difference estimator, each differencing receiver's pilot draws (the band's pixels row-major,
  // kPilotSamples each): its relative variance under differencing needs the band's learning, so it is taken at the
  // band's end (DifferencedRelativeVariances).
  std::vector<PilotDraw> draws;
  std::vector<uint8_t> drawn;  // per band pixel: 1 where draws holds its samples

  void Start(const ReferenceFrame& frame, int b) {
    band = b;
    const bool difference = frame.difference;
    draws.resize(difference ? static_cast<size_t>(kLearningTile) * frame.w * kPilotSamples : 0);
    drawn.assign(difference ? static_cast<size_t>(kLearningTile) * frame.w : 0, 0);
    tiles.resize(static_cast<size_t>(frame.tilesX));
    for (TileLightSums& t : tiles) t.Clear();
    tileStrategies.assign(static_cast<size_t>(frame.tilesX), StrategySums{});
    pixelStrategies.assign(frame.hasSky ? static_cast<size_t>(kLearningTile) * frame.w : 0, StrategySums{});
  }
};

// One worker's scratch over a range of rows: a block's receivers, light distributions and samples at a time.
struct BlockWorker {
  BlockWorker(const ReferenceFrame& frame, const BlockPlan& plan, bool pilot)
      : columns(plan.perPixelLights && !plan.keep ? plan.nGroups * kSelectionBlock : 0),
        cdfs(plan.perPixelLights ? plan.nGroups * kSelectionBlock : 0),
        work(plan.perPixelLights && (pilot || !plan.keep) ? plan.nGroups * kSelectionBlock : 0),
        tileCdfs(frame.hasLocal && !plan.perPixelLights ? plan.nGroups * frame.tilesX : 0),
        tileCdfOf(tileCdfs.empty() ? 0 : frame.tilesX, -1) {}

  std::vector<float> columns;
  std::vector<float> cdfs;
  std::vector<float> work;
  // Above kMaxPerPixelLights: each tile column's distribution (TileCdf), for the tile row tileCdfOf[column] (-1:
  // none yet).
  std::vector<float> tileCdfs;
  std::vector<int> tileCdfOf;
  float estimates[kSelectionBlock] = {};
  SelectionReceivers receivers{};
  ReceiverBlock block;
  BlockScratch scratch;
  std::vector<size_t> rowPixels;
  uint64_t rays = 0, samples = 0;
  BandLearning learning;  // the pilot's sums over the band this worker runs
};

// The row's active pixels, diffuse receivers first: a block of one kind skips the other's work (the
// BSDF towards every light's centroid, BSDF sampling).
void RowReceivers(const ReferenceFrame& frame, int y, std::vector<size_t>& rowPixels) {
  rowPixels.clear();
  for (int pass = 0; pass < 2; ++pass)
    for (int x = 0; x < frame.w; ++x) {
      const size_t i = static_cast<size_t>(y) * frame.w + x;
      // An inactive pixel (background, an emitter without a material) has none: bsdfId is -1 there.
      if (!frame.active[i]) continue;
      const bool diffuse = frame.bsdfs.type[static_cast<size_t>(frame.g.bsdfId[i])] ==
                           static_cast<int32_t>(BsdfType::kDiffuse);
      if (diffuse == (pass == 0)) rowPixels.push_back(i);
    }
}

// The receivers at pixels[0, count): what each sees, as the samplers and the selection kernel read them.
void GatherBlock(const ReferenceFrame& frame, const size_t* pixels, size_t count, ReceiverBlock& block,
                 SelectionReceivers& receivers) {
  const GBuffer& g = frame.g;
  block.count = count;
  for (size_t r = 0; r < count; ++r) {
    const size_t i = pixels[r];
    block.index[r] = i;
    block.materialId[r] = g.bsdfId[i];
    const ShadingPoint& sp = block.points[r] = ShadingPointAt(g, i, frame.state.camera.position, frame.bsdfs);
    for (int c = 0; c < 3; ++c) {
      receivers.x[c][r] = sp.position[c];
      receivers.ng[c][r] = sp.geometricNormal[c];
      receivers.n[c][r] = sp.shadingNormal[c];
      receivers.wo[c][r] = sp.wo[c];
    }
    receivers.materialId[r] = g.bsdfId[i];
  }
  receivers.count = count;
}

// The pilot's estimates of what each strategy gives a receiver under a sky, unshadowed (local, sun, environment;
// -1: cannot contribute): the local lights' from the distribution where it has one; where it has none (above
// kMaxPerPixelLights), as much as the sky's, so that the local lights get about half the pilot's draws.
std::array<float, 3> PilotEstimates(const ReferenceFrame& frame, const ShadingPoint& sp,
                                    const PixelLightDistribution& dist) {
  const float sunEstimate = SunEstimate(sp, frame.sky, frame.skySummary);
  const float environmentEstimate = EnvironmentEstimate(sp, frame.sky, frame.skySummary);
  const float skyEstimate = std::max(0.0f, sunEstimate) + std::max(0.0f, environmentEstimate);
  const float localEstimate = !frame.hasLocal           ? -1.0f
                              : dist.Estimate() >= 0.0f ? dist.Estimate()
                                                        : skyEstimate;
  return {localEstimate, sunEstimate, environmentEstimate};
}

// The tile's anchors: for its centre and each quadrant's centre, the active pixel nearest it (the first in row order
// among equals); none when the tile has no active pixel. One anchor was not enough: a tile whose centre pixel lay
// just above a room's ceiling panels gave them no weight, and the wall below them, lit by them, drew them only
// through the defensive share (many_rooms at 96×54: a wall pixel at 0.0221 ± 0.0007 whose light is 0.0406,
// tests/sim/reference/brute_force_reference_test.cpp).
std::vector<size_t> TileAnchors(const ReferenceFrame& frame, size_t tile) {
  const int tx = static_cast<int>(tile % static_cast<size_t>(frame.tilesX)) * kLearningTile;
  const int ty = static_cast<int>(tile / static_cast<size_t>(frame.tilesX)) * kLearningTile;
  // Centres in units of half a pixel from the tile's corner: the tile's, then its four quadrants'.
  const int q = kLearningTile / 2;
  const int centres[5][2] = {{kLearningTile, kLearningTile}, {q, q}, {3 * q, q}, {q, 3 * q}, {3 * q, 3 * q}};
  std::vector<size_t> anchors;
  for (const auto& c : centres) {
    std::optional<size_t> best;
    int bestDistance = 0;
    for (int y = ty; y < std::min(frame.h, ty + kLearningTile); ++y)
      for (int x = tx; x < std::min(frame.w, tx + kLearningTile); ++x) {
        const size_t i = static_cast<size_t>(y) * frame.w + x;
        const int dx = 2 * (x - tx) + 1 - c[0], dy = 2 * (y - ty) + 1 - c[1];
        if (frame.active[i] && (!best || dx * dx + dy * dy < bestDistance)) {
          best = i;
          bestDistance = dx * dx + dy * dy;
        }
      }
    if (best) anchors.push_back(*best);
  }
  return anchors;
}

// Above kMaxPerPixelLights, pixel i's light distribution: one per tile, P(l) = (1 − δ) w_l / Σ w + δ Φ_l with w_l
// the largest of the light's TileLightWeight at the tile's anchors (per-pixel distributions over so many lights
// would cost more than the rays they save; one per tile costs a 64th), then, in the main pass, reshaped by what the
// tile's pilot learned. Made once per tile row and column by each worker.
const float* TileCdf(const ReferenceFrame& frame, const BlockPlan& plan, bool pilot, size_t i, BlockWorker& worker) {
  const size_t tile = frame.TileOf(i);
  const int tileRow = static_cast<int>(tile / static_cast<size_t>(frame.tilesX));
  const size_t column = tile % static_cast<size_t>(frame.tilesX);
  float* const cdf = worker.tileCdfs.data() + column * plan.nGroups;
  if (worker.tileCdfOf[column] == tileRow) return cdf;
  worker.tileCdfOf[column] = tileRow;
  std::vector<Vec3> anchors;  // i is active: the tile has anchors
  for (size_t a : TileAnchors(frame, tile)) anchors.push_back(frame.g.Position(a));
  double total = 0.0;
  for (size_t l = 0; l < plan.nGroups; ++l) {
    float w = 0.0f;
    for (const Vec3& x : anchors) w = std::max(w, TileLightWeight(x, plan.selectionLights[l]));
    total += cdf[l] = w;
  }
  const bool weighted = total > 0.0 && std::isfinite(total);
  const double share = weighted ? (1.0 - kDefensivePowerShare) / total : 0.0;
  const double power = weighted ? kDefensivePowerShare : 1.0;
  double running = 0.0;
  for (size_t l = 0; l < plan.nGroups; ++l) {
    running += double(cdf[l]) * share + power * double(plan.groupPowerPmf[l]);
    cdf[l] = static_cast<float>(running);
  }
  if (!pilot) ReshapeLightRow(frame.learning[tile], plan.groupPowerPmf.data(), plan.nGroups, cdf);
  return cdf;
}

// Whether a receiver takes the difference estimator: a diffuse one, with a per-pixel distribution, in a frame where
// it applies (ReferenceFrame::difference).
bool Differences(const ReferenceFrame& frame, const BlockPlan& plan, const ShadingPoint& sp) {
  return frame.difference && plan.perPixelLights && sp.bsdf.type == BsdfType::kDiffuse;
}

// Σ U_l over a receiver's differenced groups: each group's radiance times the cosine-weighted solid angle the
// light-sampling integrand covers (core/polygon_irradiance.h ClippedPolygonProjectedSolidAngle), times albedo / π
// (core/bsdf.cpp EvalBsdf's diffuse value, which is 0 where the viewer is below the shading normal). With samplers
// (ReferenceParams::projectedSolidAngleDraws), builds each group's projected-solid-angle sampler on the way, in
// samplers[j] for the j-th differenced group, and takes U_l from it (the same polygon and the same bits).
glm::dvec3 DifferenceConstant(const ReferenceFrame& frame, const BlockPlan& plan, const ShadingPoint& sp,
                              const DifferencedGroups& d, ProjectedSolidAngleSampler* samplers) {
  glm::dvec3 sum(0.0);
  for (uint32_t j = 0; j < d.count; ++j) {
    const uint32_t l = d.group[j];
    const LightTriangle& t = frame.lightList[plan.groups.first[l]];
    // A quad's two triangles as one polygon p0, p0 + e1, p0 + e2, p0 + e2' (core/light.h FormsQuad: the second
    // shares p0 and continues the first across its e2), a lone triangle as itself.
    const bool quad = plan.groups.split[l] < 2.0f;
    const Vec3 edges[3] = {t.e1, t.e2, quad ? frame.lightList[plan.groups.first[l] + 1].e2 : Vec3(0.0f)};
    const size_t k = quad ? 3 : 2;
    if (samplers) {
      samplers[j] = MakeProjectedSolidAngleSampler(sp.position, sp.shadingNormal, sp.geometricNormal, t.p0, edges, k,
                                                   t.normal);
      sum += glm::dvec3(t.radiance) * samplers[j].projectedSolidAngle;
    } else {
      sum += glm::dvec3(t.radiance) * ClippedPolygonProjectedSolidAngle(sp.position, sp.shadingNormal,
                                                                        sp.geometricNormal, t.p0, edges, k, t.normal);
    }
  }
  if (!(glm::dot(sp.shadingNormal, sp.wo) > 0.0f)) return glm::dvec3(0.0);
  return sum * glm::dvec3(sp.bsdf.albedo) * (1.0 / 3.14159265358979323846);
}

// The light distributions of the block in worker.block, whose first pixel is the row's firstPixel-th: built
// by the selection kernel (the pilot; the main pass where they are not kept) or read from the pilot's, and,
// under a sky, each receiver's light mixture (set by the pilot).
void SetBlockLights(ReferenceFrame& frame, const BlockPlan& plan, bool pilot, int y, size_t firstPixel,
                    BlockWorker& worker) {
  ReceiverBlock& block = worker.block;
  const size_t count = block.count, nGroups = plan.nGroups;
  float* const blockColumns =
      plan.keep ? plan.kept.get() + plan.keptRow[y] + firstPixel * nGroups : worker.columns.data();
  float* const blockCdfs = worker.cdfs.data();
  // (The main pass reads no estimate: the pilot set the sky's light mixtures from them.)
  if (plan.perPixelLights && (pilot || !plan.keep))
    BuildLightSelection(worker.receivers, frame.bsdfs, plan.selection, worker.work.data(), blockColumns,
                        worker.estimates);
  if (plan.perPixelLights) SelectionRows(blockColumns, nGroups, count, blockCdfs);
  block.projectedSolidAngleDraws = frame.projectedSolidAngleDraws;
  for (size_t r = 0; r < count; ++r) {
    const size_t i = block.index[r];
    PixelLightDistribution& dist = block.dists[r];
    block.differenced[r].count = 0;
    block.differenceConstant[r] = glm::dvec3(0.0);
    if (plan.perPixelLights) {
      float* const row = blockCdfs + r * nGroups;
      // The main pass draws from the distribution reshaped by what the pixel's tile learned.
      if (!pilot) {
        const bool difference = Differences(frame, plan, block.points[r]);
        block.differenced[r].eligible = difference ? &frame.eligible[i] : nullptr;
        ReshapeLightRow(frame.learning[frame.TileOf(i)], plan.groupPowerPmf.data(), nGroups, row,
                        frame.probes.empty() ? nullptr : &frame.probes[i],
                        difference ? &block.differenced[r] : nullptr);
        if (difference)
          block.differenceConstant[r] =
              DifferenceConstant(frame, plan, block.points[r], block.differenced[r],
                                 frame.projectedSolidAngleDraws ? block.DifferencedSamplers(r) : nullptr);
      }
      dist = PixelLightDistribution(row, &plan.groups, worker.estimates[r]);
    } else if (frame.hasLocal) {
      dist = PixelLightDistribution(TileCdf(frame, plan, pilot, i, worker), &plan.groups, -1.0f);
    }
    SkySampling& skySampling = block.sky[r];
    if (frame.hasSky) {
      skySampling.sky = &frame.sky;
      if (pilot) {
        const std::array<float, 3>& e = frame.skyEstimates[i] = PilotEstimates(frame, block.points[r], dist);
        frame.mixtures[i] = MixLightStrategies(e[0], e[1], e[2]);
      }
      skySampling.mixture = frame.mixtures[i];
      skySampling.differenceSun = !pilot && frame.sunDifference && frame.sunDifferenced[i] &&
                                  SunDifferenceConstant(block.points[r], frame.sky, block.differenceConstant[r]);
    }
  }
}

// Runs sampleBlock on every active pixel, bands of bandRows rows in parallel, each band's rows in order by one
// thread (then endBand(band)), each row's active pixels in blocks of kSelectionBlock whose light distributions are
// built together by the pilot (and again by the main pass where they are not kept).
template <typename SampleBlock, typename EndBand>
void ForEachBlock(ReferenceFrame& frame, const BlockPlan& plan, bool pilot, int bandRows, SampleBlock&& sampleBlock,
                  EndBand&& endBand) {
  const int bands = (frame.h + bandRows - 1) / bandRows;
  tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& range) {
    BlockWorker worker(frame, plan, pilot);
    for (int band = range.begin(); band < range.end(); ++band) {
      for (int y = band * bandRows; y < std::min(frame.h, (band + 1) * bandRows); ++y) {
        RowReceivers(frame, y, worker.rowPixels);
        for (size_t firstPixel = 0; firstPixel < worker.rowPixels.size(); firstPixel += kSelectionBlock) {
          const size_t count = std::min(kSelectionBlock, worker.rowPixels.size() - firstPixel);
          GatherBlock(frame, worker.rowPixels.data() + firstPixel, count, worker.block, worker.receivers);
          SetBlockLights(frame, plan, pilot, y, firstPixel, worker);
          sampleBlock(worker.block, worker.scratch, worker.rays, worker.samples, worker.learning);
        }
      }
      endBand(band, worker.learning);
    }
    frame.rays.local() += worker.rays;
    frame.samples.local() += worker.samples;
  });
}

// The coordinates a receiver's samples read: three at a diffuse receiver without a sky, else every one.
int UsedDims(const ReferenceFrame& frame, const ShadingPoint& sp) {
  return !frame.hasSky && sp.bsdf.type == BsdfType::kDiffuse ? 3 : frame.dims;
}

// The Roberts sequence's step in coordinate j (kSampleDims coordinates without a sky, kSkySampleDims with
// one).
uint32_t RobertsAlpha(const ReferenceFrame& frame, int j) {
  static const RobertsSequence<kSampleDims> rd;
  static const RobertsSequence<kSkySampleDims> rdSky;
  return frame.hasSky ? rdSky.alpha[j] : rd.alpha[j];
}

// A block's samples, once its points are in scratch.u: every receiver's at once without a sky (one batch of
// shadow rays), one receiver at a time with one.
void BlockSamples(const ReferenceFrame& frame, const BlockPlan& plan, const ReceiverBlock& block,
                  const size_t* counts, const size_t* uFirst, const size_t* first, BlockScratch& scratch,
                  uint64_t& rayCount) {
  const size_t total = first[block.count - 1] + counts[block.count - 1];
  for (std::vector<float>& v : scratch.values) v.resize(total);
  float* const values[3] = {scratch.values[0].data(), scratch.values[1].data(), scratch.values[2].data()};
  if (!frame.hasSky) {
    SkylessBlockSamples(block, counts, uFirst, first, frame.scene, frame.bsdfs, frame.lightList,
                        plan.drawLights.view, scratch, values, rayCount);
    return;
  }
  for (size_t p = 0; p < block.count; ++p) {
    float* const out[3] = {values[0] + first[p], values[1] + first[p], values[2] + first[p]};
    SkySamples(block.points[p], frame.scene, frame.lightList, block.dists[p], block.sky[p],
               scratch.u.data() + uFirst[p], counts[p], scratch.batch, out, rayCount, scratch.RecordAt(first[p]));
  }
}

// The block's recorded light draws into its band's sums, in the block's sample order.
void LearnFromBlock(const ReferenceFrame& frame, const BlockPlan& plan, const ReceiverBlock& block,
                    const BlockScratch& scratch, const size_t* first, BandLearning& band) {
  for (size_t p = 0; p < block.count; ++p) {
    const size_t i = block.index[p];
    const size_t x = i % static_cast<size_t>(frame.w), y = i / static_cast<size_t>(frame.w);
    const size_t column = x / kLearningTile;
    StrategySums* const pixel =
        frame.hasSky ? &band.pixelStrategies[(y % kLearningTile) * static_cast<size_t>(frame.w) + x] : nullptr;
    for (size_t k = 0; k < kPilotSamples; ++k) {
      const size_t e = first[p] + k;
      const float unshadowed = scratch.recordUnshadowed[e];
      const bool visible = scratch.recordVisible[e] != 0;
      const uint8_t strategy = scratch.recordStrategy[e];
      if (scratch.recordLight[e] != kNoRecordedLight)
        band.tiles[column].Add(plan.groups.groupOf[scratch.recordLight[e]], unshadowed, visible);
      band.tileStrategies[column].s[strategy].Add(unshadowed, visible);
      if (pixel) pixel->s[strategy].Add(unshadowed, visible);
    }
  }
}

// The band's tiles learned: their light factors, and, under a sky, each pixel's reshaped light mixture.
void FinishBand(ReferenceFrame& frame, const BandLearning& band) {
  for (int column = 0; column < frame.tilesX; ++column)
    frame.learning[static_cast<size_t>(band.band) * frame.tilesX + column] = band.tiles[column].Learn();
  if (!frame.hasSky) return;
  for (int y = band.band * kLearningTile; y < std::min(frame.h, (band.band + 1) * kLearningTile); ++y)
    for (int x = 0; x < frame.w; ++x) {
      const size_t i = static_cast<size_t>(y) * frame.w + x;
      if (!frame.active[i]) continue;
      // A differenced sun is drawn by what is left to estimate, as a differenced light group is (kDifferenceFloor of
      // it: the pilot saw it arrive at every draw).
      const float sunShare = frame.sunDifference && frame.sunDifferenced[i] ? kDifferenceFloor : 1.0f;
      const float e[3] = {frame.skyEstimates[i][0], frame.skyEstimates[i][1] * sunShare, frame.skyEstimates[i][2]};
      frame.mixtures[i] = ReshapeMixture(e, band.pixelStrategies[static_cast<size_t>(y % kLearningTile) * frame.w + x],
                                         band.tileStrategies[static_cast<size_t>(x / kLearningTile)]);
    }
}

// The block's probes (PixelProbes): one shadow ray from each receiver to a point drawn uniformly on each group its
// distribution weighs (the point from the pixel's own probe stream, independent of the main pass's), traced as one
// batch in the pilot's SampleBatch. A point its receiver or its emitter faces away from is no probe.
void ProbeBlock(ReferenceFrame& frame, const BlockPlan& plan, const ReceiverBlock& block, SampleBatch& batch,
                uint64_t& rayCount) {
  batch.rays.clear();
  batch.rayOf.clear();
  for (size_t p = 0; p < block.count; ++p) {
    const size_t i = block.index[p];
    PixelProbes& probe = frame.probes[i] = PixelProbes{};
    const ShadingPoint& sp = block.points[p];
    const uint32_t weighed = WeighedGroups(block.dists[p].Cdf(), plan.groupPowerPmf.data(), plan.nGroups);
    const RngKey key{frame.seed, frame.stateKey, static_cast<uint32_t>(i),
                     static_cast<uint32_t>(RngPass::kReferenceProbe)};
    for (uint32_t l = 0; l < plan.nGroups; ++l) {
      if (!(weighed >> l & 1u)) continue;
      uint32_t u[4];
      RandomWords4(key, l, u);
      const uint32_t first = plan.groups.first[l];
      const LightTriangle& t = frame.lightList[BitsToUnitFloat(u[0]) < plan.groups.split[l] ? first : first + 1];
      const Vec3 y = SampleTrianglePoint(t, BitsToUnitFloat(u[1]), BitsToUnitFloat(u[2]));
      const Vec3 d = y - sp.position;
      if (!(glm::dot(d, sp.geometricNormal) > 0.0f) || !(glm::dot(d, t.normal) < 0.0f)) continue;
      const ShadowRaySegment s =
          ShadowRaySetup(sp.position, sp.geometricNormal, sp.errorScale, y, t.normal, t.errorScale);
      batch.rays.push_back(ShadowRay{s.org, s.dir, s.tmax});
      batch.rayOf.push_back(static_cast<uint32_t>(p * kMaxProbedGroups + l));
      probe.probed |= 1u << l;
    }
  }
  batch.occluded.resize(batch.rays.size());
  frame.scene.OccludedBatch(batch.rays.data(), batch.occluded.data(), batch.rays.size());
  rayCount += batch.rays.size();
  for (size_t r = 0; r < batch.rays.size(); ++r)
    if (!batch.occluded[r])
      frame.probes[block.index[batch.rayOf[r] / kMaxProbedGroups]].visible |= 1u << (batch.rayOf[r] % kMaxProbedGroups);
}

// A differencing receiver's pilot draws into its band's (BandLearning::draws).
void KeepPilotDraws(ReferenceFrame& frame, const BlockPlan& plan, size_t i, const BlockScratch& scratch,
                    size_t first, BandLearning& band) {
  const size_t b = i - static_cast<size_t>(band.band) * kLearningTile * static_cast<size_t>(frame.w);
  band.drawn[b] = 1;
  uint32_t seen[kPilotSamples], blocked[kPilotSamples];
  size_t nSeen = 0, nBlocked = 0;
  for (size_t k = 0; k < kPilotSamples; ++k) {
    const size_t e = first + k;
    const PilotDraw d{plan.groups.groupOf[scratch.recordLight[e]], scratch.recordUnshadowed[e],
                      scratch.recordVisible[e] != 0};
    band.draws[b * kPilotSamples + k] = d;
    if (d.unshadowed > 0.0f) (d.visible ? seen[nSeen++] : blocked[nBlocked++]) = d.group;
  }
  // The groups drawn at least kDifferenceLeastDraws times and never blocked, ascending, the first
  // kMaxDifferencedGroups of them.
  std::sort(seen, seen + nSeen);
  PilotVisibleGroups& eligible = frame.eligible[i] = PilotVisibleGroups{};
  for (size_t k = 0; k < nSeen && eligible.count < kMaxDifferencedGroups; ++k) {
    if (k > 0 && seen[k] == seen[k - 1]) continue;
    if (std::find(blocked, blocked + nBlocked, seen[k]) != blocked + nBlocked) continue;
    if (std::count(seen + k, seen + nSeen, seen[k]) < static_cast<std::ptrdiff_t>(kDifferenceLeastDraws)) continue;
    eligible.group[eligible.count++] = static_cast<uint16_t>(seen[k]);
  }
}

// A differencing receiver's relative variance from the sums over its kPilotSamples pilot samples, plain (as drawn)
// and differenced: the differenced samples' variance over the square of the plain mean (the same expectation),
// floored at the plain estimate's over n + 1, since 16 draws that all arrived do not show a shadow that takes less
// than about a 17th of the light, whose noise the plain variance bounds. Negative where the pilot saw no light.
float DifferencedRelativeVariance(double plain, double plainSq, double sum, double sumSq) {
  const double mean = plain / kPilotSamples;
  const double var = std::max(0.0, (sumSq - sum * (sum / kPilotSamples)) / (kPilotSamples - 1));
  const double plainVar = std::max(0.0, (plainSq - plain * mean) / (kPilotSamples - 1));
  const double v = std::max(var, plainVar / (kPilotSamples + 1));
  return mean > 0.0 ? static_cast<float>(std::min(v / (mean * mean), 1e30)) : -1.0f;
}

// The relative variance the main pass will see at the band's differencing receivers, from their pilot draws once
// the band has learned: a draw of an eligible group whose learned factor passes kDifferenceVisibility counts −(its
// term) where occluded and 0 where not, any other its term where unoccluded (the pilot's own distribution, not the reshaped
// one, and without the main pass's cap on differenced groups: it only apportions the samples). Relative to the
// pilot's mean, whose expectation is the same; negative where the pilot saw no light, as elsewhere.
void DifferencedRelativeVariances(const ReferenceFrame& frame, const BandLearning& band, std::vector<float>& relVar) {
  const size_t firstPixel = static_cast<size_t>(band.band) * kLearningTile * static_cast<size_t>(frame.w);
  for (size_t b = 0; b < band.drawn.size(); ++b) {
    if (!band.drawn[b]) continue;
    const size_t i = firstPixel + b;
    const TileLightLearning& tile = frame.learning[frame.TileOf(i)];
    const PixelProbes* probes = frame.probes.empty() ? nullptr : &frame.probes[i];
    const bool learned = tile.reshape || (probes && probes->visible != 0);
    double plain = 0.0, plainSq = 0.0, sum = 0.0, sumSq = 0.0;
    for (size_t k = 0; k < kPilotSamples; ++k) {
      const PilotDraw& d = band.draws[b * kPilotSamples + k];
      const double term = d.unshadowed;
      if (d.visible) plain += term, plainSq += term * term;
      const PilotVisibleGroups& e = frame.eligible[i];
      const bool differenced = learned && term > 0.0 &&
                               std::binary_search(e.group, e.group + e.count, static_cast<uint16_t>(d.group)) &&
                               LearnedFactor(tile, d.group, probes) > kDifferenceVisibility;
      const double x = differenced ? (d.visible ? 0.0 : -term) : (d.visible ? term : 0.0);
      sum += x;
      sumSq += x * x;
    }
    relVar[i] = DifferencedRelativeVariance(plain, plainSq, sum, sumSq);
  }
}

// Whether a receiver's sun is differenced (ReferenceFrame::sunDifferenced): a diffuse receiver whose sun disc lies
// wholly in front of both normals (SunDifferenceConstant), whose pilot drew the sun at least kDifferenceLeastDraws
// times and saw every such draw arrive.
bool SunDifferencedByPilot(const ReferenceFrame& frame, const ShadingPoint& sp, const BlockScratch& scratch,
                           size_t first) {
  glm::dvec3 unused;
  if (!SunDifferenceConstant(sp, frame.sky, unused)) return false;
  size_t draws = 0;
  for (size_t k = 0; k < kPilotSamples; ++k) {
    const size_t e = first + k;
    if (scratch.recordStrategy[e] != static_cast<uint8_t>(LightStrategy::kSun)) continue;
    if (!scratch.recordVisible[e]) return false;
    ++draws;
  }
  return draws >= kDifferenceLeastDraws;
}

// The relative variance the main pass will see at a receiver whose sun it differences, from its pilot samples: each
// less the sun's part (the differenced estimate of a sun that arrived at every draw is its exact contribution, a
// constant).
float SunDifferencedRelativeVariance(const BlockScratch& scratch, size_t first) {
  double plain = 0.0, plainSq = 0.0, sum = 0.0, sumSq = 0.0;
  for (size_t k = 0; k < kPilotSamples; ++k) {
    const size_t e = first + k;
    const double yv = Luminance(Vec3(scratch.values[0][e], scratch.values[1][e], scratch.values[2][e]));
    const double x = yv - scratch.recordSunPart[e];
    plain += yv, plainSq += yv * yv;
    sum += x, sumSq += x * x;
  }
  return DifferencedRelativeVariance(plain, plainSq, sum, sumSq);
}

// Pilot: kPilotSamples points of one randomly shifted Roberts sequence per pixel (their own RNG pass). Kept: their
// relative variance (negative where the pilot saw no light), and what their light draws delivered, learned per tile
// (sim/reference/reference_learning.h). Bands of kLearningTile rows run in parallel, each band's rows in order by
// one thread: the tiles' sums see their samples in the same order on any thread count.
std::vector<float> Pilot(ReferenceFrame& frame, const BlockPlan& plan, bool learn) {
  const int dims = frame.dims;
  std::vector<float> relVar(frame.pixels, -1.0f);
  const bool probe = learn && frame.hasLocal && plan.perPixelLights && plan.nGroups <= kMaxProbedGroups;
  if (probe) frame.probes.assign(frame.pixels, PixelProbes{});
  if (frame.difference && plan.perPixelLights) frame.eligible.assign(frame.pixels, PilotVisibleGroups{});
  if (frame.sunDifference) frame.sunDifferenced.assign(frame.pixels, 0);
  const auto bandOf = [&](const ReceiverBlock& block) {
    return static_cast<int>(block.index[0] / static_cast<size_t>(frame.w)) / kLearningTile;
  };
  ForEachBlock(frame, plan, /*pilot=*/true, kLearningTile, [&](const ReceiverBlock& block, BlockScratch& scratch,
                                                               uint64_t& rayCount, uint64_t& sampleCount,
                                                               BandLearning& band) {
    const RngKey key{frame.seed, frame.stateKey, 0, static_cast<uint32_t>(RngPass::kReferencePilot)};
    uint32_t ids[kSelectionBlock];
    size_t counts[kSelectionBlock], uFirst[kSelectionBlock], first[kSelectionBlock];
    for (size_t p = 0; p < block.count; ++p) {
      ids[p] = static_cast<uint32_t>(block.index[p]);
      counts[p] = kPilotSamples;
      uFirst[p] = p * kPilotSamples * dims;
      first[p] = p * kPilotSamples;
    }
    // Word j of a pixel (core/rng.h RandomWords4's stream) shifts its coordinate j: at words[j × count + p].
    scratch.words.resize(static_cast<size_t>(kSkySampleDims + 1) * block.count);
    PixelRandomWords4(key, ids, block.count, 0, (static_cast<size_t>(dims) + 3) / 4, scratch.words.data());
    scratch.u.resize(block.count * kPilotSamples * dims);
    for (size_t p = 0; p < block.count; ++p)
      for (int j = 0; j < UsedDims(frame, block.points[p]); ++j)
        RobertsCoordinates(&scratch.words[static_cast<size_t>(j) * block.count + p], 1, kPilotSamples,
                           RobertsAlpha(frame, j),
                           scratch.u.data() + uFirst[p] + static_cast<size_t>(j) * kPilotSamples);
    scratch.record = true;
    scratch.recordUnshadowed.resize(block.count * kPilotSamples);
    scratch.recordVisible.resize(block.count * kPilotSamples);
    scratch.recordLight.resize(block.count * kPilotSamples);
    scratch.recordStrategy.resize(block.count * kPilotSamples);
    if (frame.sunDifference) scratch.recordSunPart.resize(block.count * kPilotSamples);
    BlockSamples(frame, plan, block, counts, uFirst, first, scratch, rayCount);
    scratch.record = false;
    if (probe) ProbeBlock(frame, plan, block, scratch.batch, rayCount);
    if (band.band != bandOf(block)) band.Start(frame, bandOf(block));
    LearnFromBlock(frame, plan, block, scratch, first, band);
    sampleCount += block.count * kPilotSamples;
    for (size_t p = 0; p < block.count; ++p) {
      if (Differences(frame, plan, block.points[p])) {  // its relative variance waits for the band's learning
        KeepPilotDraws(frame, plan, block.index[p], scratch, first[p], band);
        continue;
      }
      if (frame.sunDifference && SunDifferencedByPilot(frame, block.points[p], scratch, first[p])) {
        frame.sunDifferenced[block.index[p]] = 1;
        relVar[block.index[p]] = SunDifferencedRelativeVariance(scratch, first[p]);
        continue;
      }
      double sum = 0.0, sumSq = 0.0;
      for (size_t k = 0; k < kPilotSamples; ++k) {
        const size_t e = first[p] + k;
        const double yv = Luminance(Vec3(scratch.values[0][e], scratch.values[1][e], scratch.values[2][e]));
        sum += yv;
        sumSq += yv * yv;
      }
      const double mean = sum / kPilotSamples;
      const double var = std::max(0.0, (sumSq - sum * mean) / (kPilotSamples - 1));
      if (mean > 0.0) relVar[block.index[p]] = static_cast<float>(std::min(var / (mean * mean), 1e30));
    }
  }, [&](int band, BandLearning& learned) {
    if (learned.band != band) learned.Start(frame, band);  // a band without an active pixel learns nothing
    if (learn) FinishBand(frame, learned);
    if (frame.difference) DifferencedRelativeVariances(frame, learned, relVar);
    learned.band = -1;
  });
  return relVar;
}

// The mean of the per-pixel sample counts over the pixels that took samples (0 when none did).
double MeanOverSampled(const std::vector<uint32_t>& pixelSamples) {
  double sum = 0.0;
  size_t count = 0;
  for (uint32_t n : pixelSamples)
    if (n > 0) sum += n, ++count;
  return count ? sum / double(count) : 0.0;
}

// Each pixel's samples, the pilot's included (0 at an inactive pixel).
std::vector<uint32_t> PixelSamples(const std::vector<uint8_t>& active,
                                   const std::vector<uint32_t>& perReplicate) {
  std::vector<uint32_t> pixelSamples(active.size(), 0);
  for (size_t i = 0; i < active.size(); ++i)
    if (active[i]) pixelSamples[i] = kPilotSamples + perReplicate[i] * kReplicates;
  return pixelSamples;
}

// The main pass's points of a block in scratch.u, receiver p's counts[p] from uFirst[p] on (uTotal in all).
void ReplicatePoints(const ReferenceFrame& frame, const ReceiverBlock& block, const size_t* counts,
                     const size_t* uFirst, size_t uTotal, BlockScratch& scratch) {
  const RngKey key{frame.seed, frame.stateKey, 0, static_cast<uint32_t>(RngPass::kReference)};
  uint32_t ids[kSelectionBlock];
  for (size_t p = 0; p < block.count; ++p) ids[p] = static_cast<uint32_t>(block.index[p]);
  // Replicate rep's shift of coordinate j is the pixel's word j × kReplicates + rep (core/rng.h RandomWords4's
  // stream): at words[(j × kReplicates + rep) × count + p], for the coordinates the block reads.
  int used = 0;
  for (size_t p = 0; p < block.count; ++p) used = std::max(used, UsedDims(frame, block.points[p]));
  const size_t wordRow = kReplicates * block.count;
  scratch.words.resize(static_cast<size_t>(used) * wordRow);
  PixelRandomWords4(key, ids, block.count, 0, static_cast<size_t>(used) * kReplicates / 4,
                    scratch.words.data());
  // Coordinate j of point k of replicate rep is u[uFirst + j × n + k × kReplicates + rep] (sample
  // k × kReplicates + rep).
  scratch.u.resize(uTotal);
  for (size_t p = 0; p < block.count; ++p) {
    const size_t m = counts[p] / kReplicates;
    for (int j = 0; j < UsedDims(frame, block.points[p]); ++j) {
      uint32_t shifts[kReplicates];
      for (int rep = 0; rep < kReplicates; ++rep)
        shifts[rep] = scratch.words[j * wordRow + static_cast<size_t>(rep) * block.count + p];
      RobertsCoordinates(shifts, kReplicates, m, RobertsAlpha(frame, j),
                         scratch.u.data() + uFirst[p] + j * counts[p]);
    }
  }
}

// Pixel i's estimate from its m points a replicate (sample k × kReplicates + rep at values[c][first + ...]):
// the mean of the replicate means plus `constant` (the difference estimator's exact part, 0 elsewhere), added to
// what the pixel sees emitted, and the standard errors of its channels and of its luminance from the replicates'
// spread.
// A pixel's estimate from its kReplicates independent replicate means: their mean, and the variance of that mean
// per channel and of its luminance (the replicates' unbiased variance / kReplicates).
struct ReplicateEstimate {
  glm::dvec3 mean{0.0};
  glm::dvec3 variance{0.0};
  double lumaVariance = 0.0;
};
ReplicateEstimate CombineReplicates(const glm::dvec3 (&replicateMean)[kReplicates]) {
  ReplicateEstimate e;
  for (const glm::dvec3& r : replicateMean) e.mean += r;
  e.mean /= double(kReplicates);
  glm::dvec3 var(0.0);
  for (const glm::dvec3& r : replicateMean) var += (r - e.mean) * (r - e.mean);
  var /= double(kReplicates - 1);
  const double meanY = Luminance(e.mean);
  double varY = 0.0;
  for (const glm::dvec3& r : replicateMean) varY += (Luminance(r) - meanY) * (Luminance(r) - meanY);
  varY /= double(kReplicates - 1);
  e.variance = var / double(kReplicates);
  e.lumaVariance = varY / double(kReplicates);
  return e;
}

void AddPixelEstimate(const BlockScratch& scratch, size_t first, size_t m, size_t i, const glm::dvec3& constant,
                      ReferenceImage& ref) {
  // Replicate sums channel by channel over the SoA samples (the same double additions in the same order as a
  // sum of glm::dvec3).
  double sums[3][kReplicates] = {};
  for (int c = 0; c < 3; ++c) {
    const float* v = scratch.values[c].data() + first;
    for (size_t k = 0; k < m; ++k)
      for (int rep = 0; rep < kReplicates; ++rep) sums[c][rep] += double(v[k * kReplicates + rep]);
  }
  glm::dvec3 replicateMean[kReplicates];
  const double perPoint = 1.0 / double(m);  // one division, not one per replicate and channel
  for (int rep = 0; rep < kReplicates; ++rep)
    replicateMean[rep] = glm::dvec3(sums[0][rep], sums[1][rep], sums[2][rep]) * perPoint;
  const ReplicateEstimate e = CombineReplicates(replicateMean);
  ref.mean.pixels[i] += Vec3(e.mean + constant);
  ref.standardError.pixels[i] = Vec3(glm::sqrt(e.variance));
  ref.lumaStandardError[i] = static_cast<float>(std::sqrt(e.lumaVariance));
}

// Main pass: per pixel, kReplicates independently shifted copies of the Roberts sequence, perReplicate[i]
// points each.
void MainPass(ReferenceFrame& frame, const BlockPlan& plan, const std::vector<uint32_t>& perReplicate,
              ReferenceImage& ref) {
  const int dims = frame.dims;
  ForEachBlock(frame, plan, /*pilot=*/false, 1, [&](const ReceiverBlock& block, BlockScratch& scratch,
                                                    uint64_t& rayCount, uint64_t& sampleCount, BandLearning&) {
    size_t counts[kSelectionBlock], uFirst[kSelectionBlock], first[kSelectionBlock];
    size_t uTotal = 0, total = 0;
    for (size_t p = 0; p < block.count; ++p) {
      counts[p] = static_cast<size_t>(perReplicate[block.index[p]]) * kReplicates;
      uFirst[p] = uTotal;
      first[p] = total;
      uTotal += counts[p] * dims;
      total += counts[p];
    }
    ReplicatePoints(frame, block, counts, uFirst, uTotal, scratch);
    BlockSamples(frame, plan, block, counts, uFirst, first, scratch, rayCount);
    sampleCount += total;
    for (size_t p = 0; p < block.count; ++p)
      AddPixelEstimate(scratch, first[p], counts[p] / kReplicates, block.index[p], block.differenceConstant[p], ref);
  }, [](int, BandLearning&) {});
}

// The allocation's parameters for one part of the estimate: with indirect light, each of the two parts (direct and
// indirect) is held to the error target / √2, so that their independent errors together reach the target.
ReferenceParams PartParams(const ReferenceParams& params) {
  ReferenceParams part = params;
  if (params.indirectBounces > 0) part.targetRelativeError = params.targetRelativeError / std::sqrt(2.0);
  return part;
}

// Each guide tile's distribution from what the pilot's paths carried back: its own tile's sums and its eight
// neighbours' (a tile whose pilot paths all missed a small bright patch hears it from the tiles around).
std::vector<DirectionGuide> GuideTiles(const std::vector<double>& learned, int tilesX, int tilesY) {
  std::vector<DirectionGuide> guides(static_cast<size_t>(tilesX) * tilesY);
  tbb::parallel_for(0, tilesY, [&](int ty) {
    std::vector<double> weights(kGuideBins);
    for (int tx = 0; tx < tilesX; ++tx) {
      std::fill(weights.begin(), weights.end(), 0.0);
      for (int ny = std::max(0, ty - 1); ny <= std::min(tilesY - 1, ty + 1); ++ny)
        for (int nx = std::max(0, tx - 1); nx <= std::min(tilesX - 1, tx + 1); ++nx) {
          const double* bins = learned.data() + (static_cast<size_t>(ny) * tilesX + nx) * kGuideBins;
          for (int b = 0; b < kGuideBins; ++b) weights[static_cast<size_t>(b)] += bins[b];
        }
      guides[static_cast<size_t>(ty) * tilesX + tx] = DirectionGuide(weights.data());
    }
  });
  return guides;
}

// The indirect light (ReferenceParams::indirectBounces; sim/reference/reference_paths.h), added to the direct
// light's estimate: a pilot of kPilotSamples paths a pixel (not part of the estimate) gives each pixel its relative
// variance per path against its whole light (direct, as the main pass found it, plus the pilot's indirect mean), and
// the direct light's allocation (AllocateSamples: the budget, or the target and its cap) turns it into paths, in
// kReplicates independent replicates. The two parts' random numbers are independent, so their variances add.
void AddIndirectLight(ReferenceFrame& frame, const ReferenceParams& params,
                      ReferenceImage& ref) {
  const int bounces = std::clamp(params.indirectBounces, 0, kMaxIndirectBounces);
  const PathScene paths(*frame.sequence, frame.scene, frame.sky);
  const Vec3 eye = frame.state.camera.position;
  tbb::combinable<uint64_t> pathCount{[] { return uint64_t{0}; }};
  // Runs fn(pixel, sp, u, scratch, rays) over the active pixels, rows in parallel.
  const auto forEachPixel = [&](auto&& fn) {
    tbb::parallel_for(tbb::blocked_range<int>(0, frame.h), [&](const tbb::blocked_range<int>& rows) {
      SampleBatch scratch;
      std::vector<float> u(static_cast<size_t>(bounces) * kBounceDims);
      uint64_t& rays = frame.rays.local();
      for (int y = rows.begin(); y < rows.end(); ++y)
        for (int x = 0; x < frame.w; ++x) {
          const size_t i = static_cast<size_t>(y) * frame.w + x;
          if (!frame.active[i]) continue;
          fn(i, ShadingPointAt(frame.g, i, eye, frame.bsdfs), u.data(), scratch, rays);
        }
    });
  };
  // The pilot: kPilotSamples paths a pixel, drawn by the BSDF. Each gives its pixel's relative variance, and each
  // guide tile learns from its paths' first directions what they carried back (sim/reference/reference_guide.h).
  // A guide tile's rows are run by one task, in order: the same sums on any thread count.
  const int tilesX = (frame.w + kGuideTile - 1) / kGuideTile, tilesY = (frame.h + kGuideTile - 1) / kGuideTile;
  std::vector<double> learned(params.guidePaths ? static_cast<size_t>(tilesX) * tilesY * kGuideBins : 0, 0.0);
  std::vector<float> relVar(frame.pixels, 0.0f);
  tbb::parallel_for(0, tilesY, [&](int ty) {
    SampleBatch scratch;
    std::vector<float> u(static_cast<size_t>(bounces) * kBounceDims);
    uint64_t& rays = frame.rays.local();
    for (int y = ty * kGuideTile; y < std::min(frame.h, (ty + 1) * kGuideTile); ++y)
      for (int x = 0; x < frame.w; ++x) {
        const size_t i = static_cast<size_t>(y) * frame.w + x;
        if (!frame.active[i]) continue;
        const ShadingPoint sp = ShadingPointAt(frame.g, i, eye, frame.bsdfs);
        double* bins = params.guidePaths
                           ? learned.data() + (static_cast<size_t>(ty) * tilesX + x / kGuideTile) * kGuideBins
                           : nullptr;
        double sum = 0.0, sumSq = 0.0;
        for (uint32_t k = 0; k < static_cast<uint32_t>(kPilotSamples); ++k) {
          PathRandomNumbers(frame.seed, frame.stateKey, static_cast<uint32_t>(i), k, RngPass::kReferencePathsPilot,
                            bounces, u.data());
          Vec3 direction(0.0f);
          const double v = Luminance(paths.IndirectSample(sp, bounces, u.data(), scratch, rays, nullptr, &direction));
          sum += v;
          sumSq += v * v;
          if (bins && v > 0.0 && std::isfinite(v)) bins[GuideBin(direction)] += v;
        }
        pathCount.local() += kPilotSamples;
        const double mean = sum / kPilotSamples;
        const double var = std::max(0.0, sumSq / kPilotSamples - mean * mean) * kPilotSamples / (kPilotSamples - 1);
        const double total = double(Luminance(ref.mean.pixels[i])) + mean;
        relVar[i] = total > 0.0 ? static_cast<float>(var / (total * total)) : 0.0f;
      }
  });
  const std::vector<DirectionGuide> guides =
      params.guidePaths ? GuideTiles(learned, tilesX, tilesY) : std::vector<DirectionGuide>();
  // Indirect light often reaches a pixel through a few of its paths' directions, which 16 pilot paths can all miss:
  // its neighbours' pilots hear it, as for direct light (SpreadRelativeVariance).
  if (params.spreadRelativeVariance) relVar = SpreadRelativeVariance(relVar, frame.active, frame.w, frame.h);
  double scale = 1.0;
  const std::vector<uint32_t> perReplicate = AllocateSamples(relVar, frame.active, PartParams(params), scale);
  // The frame is capped where either part was.
  ref.allocation.scale = std::min(ref.allocation.scale, scale);
  forEachPixel([&](size_t i, const ShadingPoint& sp, float* u, SampleBatch& scratch, uint64_t& rays) {
    const uint32_t m = perReplicate[i];
    const size_t x = i % static_cast<size_t>(frame.w), y = i / static_cast<size_t>(frame.w);
    const DirectionGuide* guide =
        guides.empty() ? nullptr : &guides[(y / kGuideTile) * static_cast<size_t>(tilesX) + x / kGuideTile];
    glm::dvec3 replicateMean[kReplicates];
    for (uint32_t rep = 0; rep < kReplicates; ++rep) {
      glm::dvec3 sum(0.0);
      for (uint32_t k = 0; k < m; ++k) {
        PathRandomNumbers(frame.seed, frame.stateKey, static_cast<uint32_t>(i), rep * m + k,
                          RngPass::kReferencePaths, bounces, u);
        sum += glm::dvec3(paths.IndirectSample(sp, bounces, u, scratch, rays, guide));
      }
      replicateMean[rep] = sum / double(m);
    }
    pathCount.local() += uint64_t(m) * kReplicates;
    const ReplicateEstimate e = CombineReplicates(replicateMean);
    ref.mean.pixels[i] += Vec3(e.mean);
    const glm::dvec3 se(ref.standardError.pixels[i]);
    ref.standardError.pixels[i] = Vec3(glm::sqrt(se * se + e.variance));
    const double seY = ref.lumaStandardError[i];
    ref.lumaStandardError[i] = static_cast<float>(std::sqrt(seY * seY + e.lumaVariance));
  });
  ref.paths = pathCount.combine(std::plus<uint64_t>());
}

}  // namespace

ReferenceImage RenderReference(const Sequence& sequence, const FrameState& state, const EmbreeScene& scene,
                               const GBuffer& g, const ReferenceParams& params) {
  const auto t0 = Clock::now();
  CacheEntry cache;  // its lock held until the entry is written
  if (std::optional<ReferenceImage> cached = LookUpCache(sequence, state, g.width, g.height, params, cache)) {
    cached->ms = MsSince(t0);
    return std::move(*cached);
  }
  ReferenceFrame frame(sequence, state, scene, g);
  frame.difference = params.differenceShadows && params.learnVisibility && !frame.hasSky && frame.hasLocal;
  frame.projectedSolidAngleDraws = params.projectedSolidAngleDraws;
  frame.seed = kReferenceSeed + params.seed;
  frame.sunDifference = params.differenceShadows && params.learnVisibility && frame.hasSky && frame.sky.hasSun;
  ReferenceImage ref = StartImage(frame);
  const BlockPlan plan(frame);
  std::vector<float> relVar = Pilot(frame, plan, params.learnVisibility);
  if (params.spreadRelativeVariance) relVar = SpreadRelativeVariance(relVar, frame.active, frame.w, frame.h);
  const std::vector<uint32_t> perReplicate =
      AllocateSamples(relVar, frame.active, PartParams(params), ref.allocation.scale);
  ref.pixelSamples = PixelSamples(frame.active, perReplicate);
  ref.allocation.meanSamplesPerPixel = MeanOverSampled(ref.pixelSamples);
  MainPass(frame, plan, perReplicate, ref);
  if (params.indirectBounces > 0) AddIndirectLight(frame, params, ref);
  ref.rays = frame.rays.combine(std::plus<uint64_t>());
  ref.samples = frame.samples.combine(std::plus<uint64_t>());
  WriteCache(cache, ref);
  ref.ms = MsSince(t0);
  return ref;
}

double ReferenceMaxSamplesPerPixel(const ReferenceParams& params) {
  if (params.targetRelativeError > 0.0) return double(kMaxSamplesPerPixel);
  return std::max(double(kPilotSamples), MeanPerReplicate(params.samplesPerPixel) * kMaxAllocationScale * kReplicates);
}

double ReferenceScratchBytes(double pixels, double lights, double groups, double maxSamplesPerPixel, bool sky,
                             double width) {
  // Per worker thread (as many as TBB runs here), a block's light distributions (rows and columns), its selection
  // weights and its samples: BlockScratch holds every sample of a block at once (its points, values, the two draw
  // kernels' rays and their answers; under a sky SampleBatch's per-sample terms too), in vectors that may reserve
  // up to twice what the largest block asked for.
  const double threads = double(tbb::this_task_arena::max_concurrency());
  const double perFrame = groups * sizeof(SelectionLight) + lights * (kLightDrawRecordFloats + 4.0) * sizeof(float);
  const double perSample = (kSkySampleDims + 3.0 + 7.0 + 10.0) * sizeof(float) + 2.0 * sizeof(uint32_t) + 1.0 + 10.0 +
                           (sky ? 2.0 * sizeof(Vec3) + sizeof(ShadowRay) + sizeof(uint32_t) + 1.0 : 0.0);
  const double blockSamples = double(kSelectionBlock) * std::max(maxSamplesPerPixel, double(kPilotSamples));
  // The learning (sim/reference/reference_learning.h): per thread, a band's sums (a tile meets at most its pilot's
  // samples' worth of groups, each an entry and a hash node; under a sky each pixel's strategy sums) and, above
  // kMaxPerPixelLights, a distribution per tile column; per frame, each tile's learned groups and factors.
  const double tilesPerRow = std::ceil((width > 0.0 ? width : std::sqrt(pixels)) / kLearningTile);
  const double tiles = std::ceil(pixels / (kLearningTile * kLearningTile));
  const double tileGroups = std::min(groups, double(kLearningTile * kLearningTile * kPilotSamples));
  const double bandBytes =
      tilesPerRow * (tileGroups * 64.0 + sizeof(StrategySums)) +
      (sky ? kLearningTile * tilesPerRow * kLearningTile * double(sizeof(StrategySums)) : 0.0) +
      (lights > double(kMaxPerPixelLights) ? tilesPerRow * groups * sizeof(float) : 0.0) +
      (!sky && lights <= double(kMaxPerPixelLights)
           ? kLearningTile * tilesPerRow * kLearningTile * (kPilotSamples * double(sizeof(PilotDraw)) + 1.0)
           : 0.0);
  const double perThread =
      3.0 * groups * kSelectionBlock * sizeof(float) + 2.0 * blockSamples * perSample + bandBytes;
  const double learned = tiles * (sizeof(TileLightLearning) + tileGroups * 8.0);
  // active flag, relative variance, per-replicate count, samples per pixel; under a sky, the light mixture and the
  // pilot's three estimates, without one the difference estimator's blocked groups; with few enough groups, the
  // probes
  const double perPixel = 1.0 + sizeof(float) + 2.0 * sizeof(uint32_t) + (sky ? 0.0 : sizeof(PilotVisibleGroups)) +
                          (sky ? sizeof(LightMixture) + 3.0 * sizeof(float) : 0.0) +
                          (groups <= double(kMaxProbedGroups) ? sizeof(PixelProbes) : 0.0);
  return perFrame + threads * perThread + pixels * perPixel + learned;
}

double ReferenceKeptBytes(double width, double height, double groups) {
  // Each row's active pixels in whole blocks; in whole 2 MiB pages.
  const double floats = std::ceil(width / kSelectionBlock) * kSelectionBlock * height * groups;
  if (floats * sizeof(float) > double(kKeptDistributionBytes)) return 0.0;
  const double huge = double(size_t{2} << 20);
  return std::ceil(floats * sizeof(float) / huge) * huge;
}

double MeanRelativeStandardError(const ReferenceImage& ref) {
  double sum = 0.0;
  size_t count = 0;
  for (size_t i = 0; i < ref.mean.Size(); ++i) {
    const double y = Luminance(ref.mean.pixels[i]);
    if (y > 1e-4) {
      sum += ref.lumaStandardError[i] / y;
      ++count;
    }
  }
  return count ? sum / double(count) : 0.0;
}

ReferenceConvergence MeasureReferenceConvergence(const ReferenceImage& ref) {
  ReferenceConvergence n;
  std::vector<double> relative;
  for (size_t i = 0; i < ref.mean.Size(); ++i) {
    const double y = Luminance(ref.mean.pixels[i]);
    if (y > 1e-4) relative.push_back(ref.lumaStandardError[i] / y);
    if (i < ref.pixelSamples.size() && ref.pixelSamples[i] > 0 && y == 0.0 && ref.lumaStandardError[i] == 0.0f)
      ++n.darkSampled;
  }
  n.litPixels = relative.size();
  if (relative.empty()) return n;
  double sum = 0.0;
  for (double r : relative) sum += r;
  n.meanRelative = sum / double(relative.size());
  const size_t rank = NearestRankIndex(relative.size(), 0.99);
  std::nth_element(relative.begin(), relative.begin() + static_cast<std::ptrdiff_t>(rank), relative.end());
  n.p99Relative = relative[rank];
  return n;
}

}  // namespace restir
