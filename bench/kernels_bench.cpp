// Microbenchmarks of the resampling kernels (DESIGN §9), one BM_<kernel>/<target> per SIMD target this machine
// supports plus the scalar twin: items are pixels (BM_TargetKernel: pairs; BM_GrisKernel and
// BM_StochasticPairwiseKernel: combinations; BM_ShadowRayKernel: rays; BM_LightDrawKernel: draws).
#include <benchmark/benchmark.h>

#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/gris.h"
#include "core/gris_kernel.h"
#include "core/bsdf_draw_kernel.h"
#include "core/light_draw_kernel.h"
#include "core/light_selection_kernel.h"
#include "core/light_sampler.h"
#include "core/reservoir.h"
#include "core/ris_kernel.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/shading.h"
#include "core/shadow_ray_kernel.h"
#include "core/spmis_kernel.h"
#include "core/target_kernel.h"

namespace restir {
namespace {

std::vector<LightTriangle> GridLights(int count) {
  std::vector<LightTriangle> lights;
  for (int i = 0; i < count; ++i) {
    const float x = float(i % 12) - 6.0f, z = float(i / 12) - 3.0f;
    LightTriangle t{};
    MakeLightTriangle(Vec3(x, 3, z), Vec3(x + 0.3f, 3, z), Vec3(x, 3, z + 0.3f),
                      Vec3(1.0f + float(i % 3), 2.0f, 1.0f + float(i % 5)), t);
    if (glm::dot(t.normal, Vec3(0, -1, 0)) < 0) MakeLightTriangle(Vec3(x, 3, z), Vec3(x, 3, z + 0.3f),
                                                                Vec3(x + 0.3f, 3, z), t.radiance, t);
    lights.push_back(t);
  }
  return lights;
}

// Two diffuse materials and a GGX one (alpha 0.09), the kernel benchmarks' receivers run through them.
BsdfSoa BenchMaterials() {
  std::vector<Bsdf> bsdfs(3);
  bsdfs[0].albedo = Vec3(0.6f);
  bsdfs[1].albedo = Vec3(0.3f, 0.5f, 0.7f);
  bsdfs[2].type = BsdfType::kGgx;
  bsdfs[2].albedo = Vec3(0.9f, 0.8f, 0.6f);
  bsdfs[2].alpha = 0.09f;
  return MakeBsdfSoa(bsdfs);
}

// Query k of the per-pair benchmarks: a floor receiver along the BM_RisKernel row and a random point on one of
// the grid lights.
struct FloorQuery {
  Vec3 receiver;
  const LightTriangle* light;
  Vec3 lightPoint;
};
FloorQuery MakeFloorQuery(const std::vector<LightTriangle>& lights, size_t k) {
  const RngKey key{1, 0, static_cast<uint32_t>(k), 2};
  const LightTriangle& t = lights[static_cast<size_t>(UniformFloat(key, 0) * float(lights.size())) % lights.size()];
  return {Vec3(float(k % 1920) / 1920.0f * 12.0f - 6.0f, 0.0f, 1.0f - float(k % 7) * 0.3f), &t,
          SampleTrianglePoint(t, UniformFloat(key, 1), UniformFloat(key, 2))};
}

// Times `body` once per iteration with the kernels forced onto `target` (a kernel benchmark per target, scalar
// twin included); `items` per call.
template <typename F>
void TimeOnTarget(benchmark::State& state, SimdTarget target, int64_t items, F&& body) {
  if (!SetSimdTarget(target)) {
    state.SkipWithError("target not supported");
    return;
  }
  for (auto _ : state) {
    body();
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * items);
  state.SetLabel(ActiveSimdTargetName());
  SetSimdTarget(SimdTarget::kAuto);
}

// Registers `name`/<target> for every target this machine supports, in this one binary.
bool RegisterPerTarget(const std::string& name, const std::function<void(benchmark::State&, SimdTarget)>& fn) {
  for (SimdTarget t : SupportedSimdTargets())
    benchmark::RegisterBenchmark((name + "/" + SimdTargetName(t)).c_str(), [fn, t](benchmark::State& s) { fn(s, t); });
  return true;
}

// Streaming RIS over M = 32 candidates for one receiver per item (the initial-sampling pass without rays).
void BM_InitialRis(benchmark::State& state) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const LightSampler sampler(lights, LightSelection::kPower);
  ShadingPoint sp;
  sp.geometricNormal = sp.shadingNormal = Vec3(0, 1, 0);
  sp.wo = glm::normalize(Vec3(0.2f, 1, 0.3f));
  uint32_t pixel = 0;
  for (auto _ : state) {
    sp.position = Vec3(float(pixel % 64) * 0.05f, 0, float(pixel / 64 % 64) * 0.05f);
    Sampler s(RngKey{1, 0, pixel++, 1});
    Reservoir r;
    for (int j = 0; j < 32; ++j) {
      const float u0 = s.Next(), u1 = s.Next(), u2 = s.Next(), u3 = s.Next(), uSel = s.Next();
      const LightSample y = sampler.Sample(u0, u1, u2, u3);
      const float t = TargetFunction(UnshadowedContribution(sp, y));
      StreamCandidate(r, y, t, RisWeight(t, y.pdfArea), uSel);
    }
    FinalizeRis(r, 32.0f);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_InitialRis);

// The initial-sampling kernel (core/ris_kernel.h) on one SIMD target per benchmark, scalar twin included: a row
// of 1920 receivers on a floor under the 72 grid lights, M = 32, materials in runs of 40 pixels (two diffuse
// runs, then a GGX one), every pixel active. Items are pixels.
void BM_RisKernel(benchmark::State& state, SimdTarget target) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const LightSampler sampler(lights, LightSelection::kPower);
  const BsdfSoa materials = BenchMaterials();
  const size_t n = 1920;
  std::vector<float> in[12];
  for (auto& v : in) v.resize(n);
  std::vector<int32_t> material(n);
  std::vector<uint8_t> active(n, 1);
  const Vec3 camera(0.0f, 1.5f, 6.0f);
  for (size_t k = 0; k < n; ++k) {
    const Vec3 p(float(k) / float(n) * 12.0f - 6.0f, 0.0f, 1.0f - float(k % 7) * 0.3f);
    const Vec3 wo = glm::normalize(camera - p);
    for (int c = 0; c < 3; ++c) {
      in[c][k] = p[c];
      in[3 + c][k] = in[6 + c][k] = c == 1 ? 1.0f : 0.0f;
      in[9 + c][k] = wo[c];
    }
    material[k] = static_cast<int32_t>(k / 40 % 3);
  }
  RisPixels px;
  for (int c = 0; c < 3; ++c) {
    px.position[c] = in[c].data();
    px.geometricNormal[c] = in[3 + c].data();
    px.shadingNormal[c] = in[6 + c].data();
    px.wo[c] = in[9 + c].data();
  }
  px.materialId = material.data();
  px.active = active.data();
  px.count = n;
  std::vector<int32_t> outId(n);
  std::vector<float> outF[12];
  for (auto& v : outF) v.resize(n);
  RisOutput out;
  out.lightId = outId.data();
  for (int c = 0; c < 3; ++c) {
    out.position[c] = outF[c].data();
    out.normal[c] = outF[3 + c].data();
    out.radiance[c] = outF[6 + c].data();
  }
  out.pdfArea = outF[9].data();
  out.weightSum = outF[10].data();
  out.targetPdf = outF[11].data();
  const RisParams params{1, 0, static_cast<uint32_t>(RngPass::kInitial), 32};
  uint32_t row = 0;
  TimeOnTarget(state, target, static_cast<int64_t>(n), [&] {
    px.pixelBase = (row++ % 1080) * static_cast<uint32_t>(n);
    RisInitialSampling(px, sampler.Soa(), materials, params, out);
    benchmark::DoNotOptimize(outF[10].data());
  });
}
[[maybe_unused]] const bool kRisKernelRegistered = RegisterPerTarget("BM_RisKernel", BM_RisKernel);

// The target-evaluation kernel (core/target_kernel.h) on one SIMD target per benchmark, scalar twin included:
// 4096 pairs of a floor receiver (the BM_RisKernel row and camera, materials in the same runs of 40) and a
// random point on one of the 72 grid lights, as a reuse pass gathers them. p̂ and the RGB contribution are both
// written. Items are pairs.
void BM_TargetKernel(benchmark::State& state, SimdTarget target) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const BsdfSoa materials = BenchMaterials();
  const size_t n = 4096;
  std::vector<float> in[21];  // eye, position, geometric normal, shading normal, light position, normal, radiance
  for (auto& v : in) v.resize(n);
  std::vector<int32_t> material(n);
  const Vec3 camera(0.0f, 1.5f, 6.0f);
  for (size_t k = 0; k < n; ++k) {
    const FloorQuery q = MakeFloorQuery(lights, k);
    const Vec3& p = q.receiver;
    const Vec3& y = q.lightPoint;
    const LightTriangle& t = *q.light;
    for (int c = 0; c < 3; ++c) {
      in[c][k] = camera[c];
      in[3 + c][k] = p[c];
      in[6 + c][k] = in[9 + c][k] = c == 1 ? 1.0f : 0.0f;
      in[12 + c][k] = y[c];
      in[15 + c][k] = t.normal[c];
      in[18 + c][k] = t.radiance[c];
    }
    material[k] = static_cast<int32_t>(k / 40 % 3);
  }
  const float* fields[kTargetPairFields];
  for (int f = 0; f < kTargetPairFields; ++f) fields[f] = in[f].data();
  const TargetPairs pairs = MakeTargetPairs(fields, material.data(), n);
  std::vector<float> outF[4];
  for (auto& v : outF) v.resize(n);
  TargetResults out;
  out.target = outF[0].data();
  for (int c = 0; c < 3; ++c) out.contribution[c] = outF[1 + c].data();
  TimeOnTarget(state, target, static_cast<int64_t>(n), [&] {
    EvaluateTargets(pairs, materials, out);
    benchmark::DoNotOptimize(outF[0].data());
  });
}
[[maybe_unused]] const bool kTargetKernelRegistered = RegisterPerTarget("BM_TargetKernel", BM_TargetKernel);

// The shadow-ray setup kernel (core/shadow_ray_kernel.h) on one SIMD target per benchmark, scalar twin
// included: the BM_TargetKernel queries (floor receivers of the BM_RisKernel row, a random point on one of the 72
// grid lights), as a pass batches its visibility queries. Items are rays.
void BM_ShadowRayKernel(benchmark::State& state, SimdTarget target) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const size_t n = 4096;
  std::vector<float> in[14];  // position, geometric normal, light position, light normal, the two error scales
  for (auto& v : in) v.resize(n);
  for (size_t k = 0; k < n; ++k) {
    const FloorQuery q = MakeFloorQuery(lights, k);
    const Vec3& p = q.receiver;
    const Vec3& y = q.lightPoint;
    for (int c = 0; c < 3; ++c) {
      in[c][k] = p[c];
      in[3 + c][k] = c == 1 ? 1.0f : 0.0f;
      in[6 + c][k] = y[c];
      in[9 + c][k] = c == 1 ? -1.0f : 0.0f;  // ceiling lights face down
    }
    in[12][k] = 4.0f, in[13][k] = 4.0f;
  }
  ShadowRayInputs queries;
  for (int c = 0; c < 3; ++c) {
    queries.position[c] = in[c].data();
    queries.geometricNormal[c] = in[3 + c].data();
    queries.lightPosition[c] = in[6 + c].data();
    queries.lightNormal[c] = in[9 + c].data();
  }
  queries.errorScale = in[12].data();
  queries.lightErrorScale = in[13].data();
  queries.count = n;
  std::vector<float> outF[7];
  for (auto& v : outF) v.resize(n);
  ShadowRayOutputs out;
  for (int c = 0; c < 3; ++c) {
    out.org[c] = outF[c].data();
    out.dir[c] = outF[3 + c].data();
  }
  out.tmax = outF[6].data();
  TimeOnTarget(state, target, static_cast<int64_t>(n), [&] {
    SetupShadowRays(queries, out);
    benchmark::DoNotOptimize(outF[6].data());
  });
}
[[maybe_unused]] const bool kShadowRayKernelRegistered = RegisterPerTarget("BM_ShadowRayKernel", BM_ShadowRayKernel);

// The reference's light-draw kernel (core/light_draw_kernel.h): BM_LightDrawKernel/<target>. Items are draws.
// 768 draws per call (the budget issue 16 measured the reference at) at floor receivers of the BM_RisKernel row
// under the 72 grid lights, each receiver with its own cdf over the lights' groups (weights by the lights'
// unshadowed contribution there plus a defensive share, as the reference's distribution), cycled over 64
// receivers; diffuse and GGX receivers.
void BM_LightDrawKernel(benchmark::State& state, SimdTarget target) {
  const std::vector<LightTriangle> lights = GridLights(72);
  const BsdfSoa materials = BenchMaterials();
  struct alignas(64) Record {
    float v[kLightDrawRecordFloats];
  };
  std::vector<Record> records(lights.size());
  std::vector<float> errorScale;
  // The reference's groups (core/light.h): the grid's quads, each weighed once.
  const LightGroups groups = MakeLightGroups(lights);
  for (size_t l = 0; l < lights.size(); ++l) {
    WriteLightDrawRecord(lights[l], groups.invArea[l], records[l].v);
    errorScale.push_back(lights[l].errorScale);
  }
  const LightDrawLights view{records.data()->v, errorScale.data(), lights.size(), groups.first.data(),
                             groups.split.data(), groups.first.size()};
  constexpr size_t kReceivers = 64, kDraws = 768;
  std::vector<LightDrawReceiver> receivers(kReceivers);
  std::vector<std::vector<float>> cdfs(kReceivers);
  for (size_t r = 0; r < kReceivers; ++r) {
    LightDrawReceiver& rc = receivers[r];
    rc.position = Vec3(float(r % 16) * 0.7f - 5.0f, 0.0f, float(r / 16) * 0.9f - 2.0f);
    rc.geometricNormal = rc.shadingNormal = Vec3(0, 1, 0);
    rc.wo = glm::normalize(Vec3(0.2f, 1, 0.3f));
    rc.errorScale = 4.0f;
    rc.materialId = r % 4 == 3 ? 2 : static_cast<int32_t>(r % 2);
    rc.bsdfMis = rc.materialId == 2;
    ShadingPoint sp;
    sp.position = rc.position;
    sp.geometricNormal = sp.shadingNormal = rc.geometricNormal;
    sp.wo = rc.wo;
    sp.bsdf.albedo = Vec3(1.0f);
    double running = 0.0, total = 0.0;
    std::vector<double> w(groups.first.size(), 0.0);
    for (size_t l = 0; l < lights.size(); ++l) {
      LightSample y;
      y.position = SampleTrianglePoint(lights[l], 1.0f / 3.0f, 1.0f / 3.0f);
      y.normal = lights[l].normal;
      y.radiance = lights[l].radiance;
      const double v = TargetFunction(UnshadowedContribution(sp, y)) * lights[l].area + 1e-3;
      w[groups.groupOf[l]] += v;
      total += v;
    }
    for (double v : w) cdfs[r].push_back(static_cast<float>((running += v) / total));
  }
  std::vector<float> u[3];
  for (int j = 0; j < 3; ++j)
    for (size_t k = 0; k < kDraws; ++k) u[j].push_back(UniformFloat(RngKey{3, 0, static_cast<uint32_t>(k), 0}, j));
  const LightDraws draws{u[0].data(), u[1].data(), u[2].data(), kDraws};
  std::vector<float> outF[10];
  for (auto& v : outF) v.resize(kDraws);
  std::vector<uint32_t> drawOf(kDraws);
  LightDrawOutputs out;
  for (int c = 0; c < 3; ++c) {
    out.term[c] = outF[c].data();
    out.org[c] = outF[3 + c].data();
    out.dir[c] = outF[6 + c].data();
  }
  out.tmax = outF[9].data();
  out.draw = drawOf.data();
  size_t next = 0;
  TimeOnTarget(state, target, static_cast<int64_t>(kDraws), [&] {
    benchmark::DoNotOptimize(DrawLightSamples(receivers[next], materials, view, cdfs[next].data(), draws, out));
    next = (next + 1) % kReceivers;
    benchmark::DoNotOptimize(outF[9].data());
  });
}
[[maybe_unused]] const bool kLightDrawKernelRegistered = RegisterPerTarget("BM_LightDrawKernel", BM_LightDrawKernel);

// The reference's light distributions (core/light_selection_kernel.h): BM_LightSelectionKernel/<target>. Items are
// receivers: a block of 16 floor receivers per call (kSelectionBlock) under 72 quad lights cut in two (the
// flagship's lights: 72 groups of 144 triangles) up to 4 m away, diffuse, the cdfs then copied to rows
// (SelectionRows) as the reference draws from them; cycled over 8 blocks along the row.
void BM_LightSelectionKernel(benchmark::State& state, SimdTarget target) {
  std::vector<LightTriangle> triangles;
  for (int i = 0; i < 72; ++i) {
    const float x = float(i % 12) * 0.8f - 4.8f, z = float(i / 12) * 0.8f - 2.4f;
    const Vec3 q[4] = {Vec3(x, 3, z), Vec3(x, 3, z + 0.4f), Vec3(x + 0.4f, 3, z + 0.4f), Vec3(x + 0.4f, 3, z)};
    LightTriangle t0{}, t1{};
    MakeLightTriangle(q[0], q[1], q[2], Vec3(1.0f + float(i % 3), 2.0f, 1.0f + float(i % 5)), t0);
    MakeLightTriangle(q[0], q[2], q[3], t0.radiance, t1);
    triangles.push_back(t0);
    triangles.push_back(t1);
  }
  const LightGroups groups = MakeLightGroups(triangles);
  std::vector<float> powerPmf(triangles.size(), 1.0f / float(triangles.size()));
  const std::vector<SelectionLight> selection = MakeSelectionLights(triangles, groups, powerPmf);
  const SelectionLights lights{selection.data(), selection.size()};
  const BsdfSoa materials = BenchMaterials();
  constexpr size_t kBlocks = 8;
  std::vector<SelectionReceivers> blocks(kBlocks);
  for (size_t b = 0; b < kBlocks; ++b) {
    SelectionReceivers& r = blocks[b];
    r = SelectionReceivers{};
    r.count = kSelectionBlock;
    for (size_t k = 0; k < kSelectionBlock; ++k) {
      const float x = float(b * kSelectionBlock + k) * 0.07f - 4.5f;
      r.x[0][k] = x, r.x[1][k] = 0.0f, r.x[2][k] = 0.3f * float(b) - 1.0f;
      r.ng[1][k] = r.n[1][k] = 1.0f;
      r.wo[1][k] = 0.8f, r.wo[2][k] = 0.6f;
      r.materialId[k] = static_cast<int32_t>(k % 2);
    }
  }
  std::vector<float> work(selection.size() * kSelectionBlock), columns(work.size()), rows(work.size());
  float estimate[kSelectionBlock];
  size_t next = 0;
  TimeOnTarget(state, target, static_cast<int64_t>(kSelectionBlock), [&] {
    BuildLightSelection(blocks[next], materials, lights, work.data(), columns.data(), estimate);
    SelectionRows(columns.data(), selection.size(), kSelectionBlock, rows.data());
    next = (next + 1) % kBlocks;
    benchmark::DoNotOptimize(rows.data());
  });
}
[[maybe_unused]] const bool kLightSelectionKernelRegistered =
    RegisterPerTarget("BM_LightSelectionKernel", BM_LightSelectionKernel);

// The reference's BSDF samples (core/bsdf_draw_kernel.h): BM_BsdfDrawKernel/<target>. Items are draws: 768 per call
// at a GGX receiver (alpha 0.09) of the BM_RisKernel row, the draws that count packed with their rays.
void BM_BsdfDrawKernel(benchmark::State& state, SimdTarget target) {
  const BsdfSoa materials = BenchMaterials();
  LightDrawReceiver r;
  r.position = Vec3(1.0f, 0.0f, -0.5f);
  r.geometricNormal = r.shadingNormal = Vec3(0, 1, 0);
  r.wo = glm::normalize(Vec3(0.2f, 1, 0.3f));
  r.errorScale = 4.0f;
  r.materialId = 2;
  constexpr size_t kDraws = 768;
  std::vector<float> u[2];
  for (int j = 0; j < 2; ++j)
    for (size_t k = 0; k < kDraws; ++k) u[j].push_back(UniformFloat(RngKey{5, 0, static_cast<uint32_t>(k), 0}, j));
  std::vector<float> outF[10];
  for (auto& v : outF) v.resize(kDraws);
  std::vector<uint32_t> drawOf(kDraws);
  BsdfDrawOutputs out;
  for (int c = 0; c < 3; ++c) {
    out.org[c] = outF[c].data();
    out.dir[c] = outF[3 + c].data();
    out.weight[c] = outF[6 + c].data();
  }
  out.pdf = outF[9].data();
  out.draw = drawOf.data();
  TimeOnTarget(state, target, static_cast<int64_t>(kDraws), [&] {
    benchmark::DoNotOptimize(DrawBsdfSamples(r, materials, BsdfDraws{u[0].data(), u[1].data(), kDraws}, out));
    benchmark::DoNotOptimize(outF[9].data());
  });
}
[[maybe_unused]] const bool kBsdfDrawKernelRegistered = RegisterPerTarget("BM_BsdfDrawKernel", BM_BsdfDrawKernel);

// A 6-input GRIS combination (canonical + temporal-like + 4 neighbours) with analytic targets, per family.
void BM_GrisCombine(benchmark::State& state) {
  const MisFamily family = static_cast<MisFamily>(state.range(0));
  GrisInput in[6];
  for (int i = 0; i < 6; ++i) in[i] = GrisInput{true, 0.5f + 0.1f * i, 1.0f + i, 1.0f};
  uint32_t pixel = 0;
  for (auto _ : state) {
    const RngKey key{1, 0, pixel++, 3};
    float u[6];
    for (int i = 0; i < 6; ++i) u[i] = UniformFloat(key, i);
    auto target = [&](int j, int i) { return 1.0f + 0.25f * float((i * 7 + j * 3) % 5); };
    benchmark::DoNotOptimize(GrisCombine(family, in, 6, target, u, VisibilityCarry::kWeighted));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_GrisCombine)
    ->Arg(static_cast<int>(MisFamily::kUniform))
    ->Arg(static_cast<int>(MisFamily::kZ))
    ->Arg(static_cast<int>(MisFamily::kBalance))
    ->Arg(static_cast<int>(MisFamily::kPairwise));

// The GRIS-combination kernel (core/gris_kernel.h): BM_GrisKernel/<family>/<target>. Items are combinations.
//
// The workload is spatial reuse with 5 neighbours: batches of 64 combinations (a row segment of pixels) with 6
// inputs each. Values as a frame has them: confidences 1..20 (capped history), contribution weights spread over
// two decades, 5% empty reservoirs, visibility mostly 0 or 1, and p̂_j(Y_i) zero for 15% of the pairs (the
// sample is behind input j's surface or, ray traced, occluded from it). Several batches are cycled so the scalar
// code's branches see varied data rather than one memorised pattern.
constexpr size_t kCombinations = 64;  // per batch of the GRIS kernel benchmark
constexpr int kInputs = 6;            // canonical + 5 spatial neighbours
constexpr int kBatches = 16;          // cycled

GrisBatchArrays MakeBatch(std::mt19937& rng) {
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  std::lognormal_distribution<float> spread(0.0f, 1.0f);
  const size_t rows = kInputs * kCombinations;
  GrisBatchArrays b;
  b.count = b.stride = kCombinations;
  b.matrixSize = kInputs;
  b.inputs.assign(kCombinations, kInputs);
  b.hasSample.resize(rows);
  for (auto* v : {&b.W, &b.confidence, &b.visibility, &b.u, &b.mis, &b.canonicalTarget}) v->resize(rows);
  b.target.resize(rows * kInputs);
  for (size_t k = 0; k < kCombinations; ++k) {
    for (int i = 0; i < kInputs; ++i) {
      const size_t e = i * kCombinations + k;
      b.hasSample[e] = uni(rng) < 0.95f;
      b.W[e] = spread(rng);
      b.confidence[e] = static_cast<float>(1 + rng() % 20);
      const float v = uni(rng);
      b.visibility[e] = v < 0.6f ? 1.0f : (v < 0.85f ? 0.0f : uni(rng));
      b.u[e] = uni(rng);
      b.mis[e] = uni(rng) / static_cast<float>(kInputs);  // stochastic pairwise weights, roughly a partition
    }
    for (int j = 0; j < kInputs; ++j)
      for (int i = 0; i < kInputs; ++i)
        b.target[(j * kInputs + i) * kCombinations + k] = uni(rng) < 0.15f ? 0.0f : spread(rng);
    for (int i = 0; i < kInputs; ++i)
      b.canonicalTarget[i * kCombinations + k] = b.target[i * kCombinations + k];  // row 0: p̂_c(Y_i)
  }
  return b;
}

// family < 0: GrisResampleBatch (given weights, as stochastic pairwise uses it).
void BM_GrisKernel(benchmark::State& state, int family, SimdTarget target) {
  std::mt19937 rng(7);
  std::vector<GrisBatchArrays> batches;
  for (int i = 0; i < kBatches; ++i) batches.push_back(MakeBatch(rng));
  std::vector<GrisBatch> views;
  for (const GrisBatchArrays& b : batches) views.push_back(b.View());
  std::vector<int32_t> selected(kCombinations), guarded(kCombinations);
  std::vector<float> weightSum(kCombinations), W(kCombinations), confidence(kCombinations),
      visibility(kCombinations);
  const GrisBatchOutput out{selected.data(), weightSum.data(), W.data(),
                            confidence.data(), visibility.data(), guarded.data()};
  size_t next = 0;
  TimeOnTarget(state, target, static_cast<int64_t>(kCombinations), [&] {
    const GrisBatch& b = views[next];
    next = (next + 1) % views.size();
    if (family < 0) GrisResampleBatch(VisibilityCarry::kWeighted, b, out);
    else GrisCombineBatch(static_cast<MisFamily>(family), VisibilityCarry::kWeighted, b, out);
    benchmark::DoNotOptimize(selected.data());
    benchmark::DoNotOptimize(W.data());
  });
}

[[maybe_unused]] const bool kGrisKernelRegistered = [] {
  const std::pair<const char*, int> families[] = {{"uniform", static_cast<int>(MisFamily::kUniform)},
                                                  {"z", static_cast<int>(MisFamily::kZ)},
                                                  {"balance", static_cast<int>(MisFamily::kBalance)},
                                                  {"pairwise", static_cast<int>(MisFamily::kPairwise)},
                                                  {"resample", -1}};
  for (const auto& [name, family] : families)
    RegisterPerTarget(std::string("BM_GrisKernel/") + name,
                      [family = family](benchmark::State& s, SimdTarget t) { BM_GrisKernel(s, family, t); });
  return true;
}();


// The stochastic pairwise weights kernel (core/spmis_kernel.h): BM_StochasticPairwiseKernel/<target>. Items are
// combinations.
//
// The workload is the spatial pass with seed 004's defaults (N = 4 draws, N_c = 5, seed 004 Eq. 15-19): batches
// of 64 combinations with 3..5 inputs (the canonical plus the distinct non-canonical draws) and 3..5 distinct
// canonical draws, cells of 20..60 candidates, confidences scaled by N/M, 5% empty reservoirs and p̂ zero for
// 15% of the pairs. Batches are cycled, as for BM_GrisKernel.
struct SpmisBenchBatch {
  GrisBatchArrays gris;
  StochasticPairwiseArrays sp;
};

SpmisBenchBatch MakeSpmisBatch(std::mt19937& rng) {
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  std::lognormal_distribution<float> spread(0.0f, 1.0f);
  constexpr int kRows = 5, kDraws = 5;
  const float bigN = 4.0f, nc = 5.0f;
  SpmisBenchBatch b;
  GrisBatchArrays& g = b.gris;
  g.count = g.stride = kCombinations;
  g.matrixSize = kRows;
  const size_t rows = kRows * kCombinations;
  g.inputs.resize(kCombinations);
  g.hasSample.resize(rows);
  g.confidence.resize(rows);
  g.mis.resize(rows);
  g.canonicalTarget.resize(rows);
  b.sp.Resize(g, kDraws);
  StochasticPairwiseArrays& s = b.sp;
  const auto target = [&] { return uni(rng) < 0.15f ? 0.0f : spread(rng); };
  for (size_t k = 0; k < kCombinations; ++k) {
    g.inputs[k] = 3 + static_cast<int32_t>(rng() % 3);
    s.distinct[k] = 3 + static_cast<int32_t>(rng() % 3);
    const float m = static_cast<float>(20 + rng() % 41), scale = bigN / m;
    s.cBar[k] = m * 10.0f * scale;  // Σ c over the cell, c ≈ 10, scaled (seed 004 §4.3)
    s.drawCount[k] = bigN;
    s.canonicalDrawCount[k] = nc;
    for (int t = 0; t < kRows; ++t) {
      const size_t e = s.At(t, k);
      g.hasSample[e] = uni(rng) < 0.95f;
      g.confidence[e] = static_cast<float>(1 + rng() % 20) * (t == 0 ? 1.0f : scale);
      s.multiplicity[e] = static_cast<float>(1 + rng() % 2);
      s.probability[e] = 0.02f + 0.2f * uni(rng);
      s.canonicalTarget[e] = target();
      s.ownTarget[e] = target();
    }
    for (int d = 0; d < kDraws; ++d) {
      const size_t e = s.DrawAt(d, k);
      s.drawnMultiplicity[e] = static_cast<float>(1 + rng() % 2);
      s.drawnProbability[e] = 1.0f / m;  // uniform canonical draws (P_c = 1/M)
      s.drawnConfidence[e] = static_cast<float>(1 + rng() % 20) * scale;
      s.drawnTarget[e] = target();
    }
  }
  return b;
}

void BM_StochasticPairwiseKernel(benchmark::State& state, SimdTarget target) {
  std::mt19937 rng(9);
  std::vector<SpmisBenchBatch> batches;
  for (int i = 0; i < kBatches; ++i) batches.push_back(MakeSpmisBatch(rng));
  std::vector<StochasticPairwiseBatch> views;
  std::vector<StochasticPairwiseOutput> outs;
  for (SpmisBenchBatch& b : batches) {
    views.push_back(b.sp.View(b.gris));
    outs.push_back(StochasticPairwiseOutputInto(b.gris));
  }
  size_t next = 0;
  TimeOnTarget(state, target, static_cast<int64_t>(kCombinations), [&] {
    StochasticPairwiseWeights(views[next], outs[next]);
    benchmark::DoNotOptimize(outs[next].mis);
    next = (next + 1) % views.size();
  });
}
[[maybe_unused]] const bool kStochasticPairwiseKernelRegistered =
    RegisterPerTarget("BM_StochasticPairwiseKernel", BM_StochasticPairwiseKernel);

}  // namespace
}  // namespace restir

BENCHMARK_MAIN();
