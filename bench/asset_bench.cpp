// Assets at scale (issue 17): how long an asset takes to import, how long the scene and the light structures take
// to build from it, and what they cost in memory per scene triangle and per light triangle.
//
//   BM_ImportAsset       ImportAsset (Assimp in a child process, the result piped back and validated) and the same
//                        work in this process, so the isolation's cost shows as the difference.
//   BM_LoadSequence      LoadSequence: import + expansion into objects, materials and lights (what `validate` does).
//   BM_SceneBuild        EmbreeScene construction + the first Update (the BVHs), with the resident-memory growth
//                        per scene triangle (objects and emitters together).
//   BM_LightStructures   one frame's light list (BuildLightTriangles) and power sampler (LightSampler: alias table
//                        and the kernels' SoA), rebuilt every frame by the frame loop, with their bytes per light.
//
// Environment: RESTIR_BENCH_SEQUENCE (default sequences/asset_table.json) and RESTIR_BENCH_ASSET (default
// data/assets/lamp_panel.gltf). For issue 17's million-triangle scene: scripts/make_assets.py scale DIR, then
// RESTIR_BENCH_SEQUENCE=DIR/scale.json RESTIR_BENCH_ASSET=DIR/scale.glb build/release/asset_bench.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/light_sampler.h"
#include "sim/scene/animation.h"
#include "sim/assets/asset_import.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

std::string Env(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v && *v ? v : std::string(RESTIR_SOURCE_DIR) + "/" + fallback;
}
std::string SequencePath() { return Env("RESTIR_BENCH_SEQUENCE", "sequences/asset_table.json"); }
std::string AssetPath() { return Env("RESTIR_BENCH_ASSET", "data/assets/lamp_panel.gltf"); }

double ResidentMb() {  // current resident set (not the peak): /proc/self/statm's second field, in pages
  long pages = 0, resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return double(resident) * 4096.0 / (1024.0 * 1024.0);
}

template <typename F>
double TimeMs(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

uint64_t Triangles(const ImportedAsset& a) {
  uint64_t n = 0;
  for (const AssetMesh& m : a.meshes) n += m.triangles.size();
  return n;
}

void BM_ImportAsset(benchmark::State& state, bool isolated) {
  const std::string path = AssetPath();
  uint64_t triangles = 0;
  for (auto _ : state) {
    ImportedAsset a;
    state.SetIterationTime(
        TimeMs([&] { a = isolated ? ImportAsset(path) : ImportAssetInProcess(path); }) / 1000.0);
    triangles = Triangles(a);
  }
  state.counters["triangles"] = double(triangles);
  state.SetLabel(path);
}

void BM_LoadSequence(benchmark::State& state) {
  size_t objects = 0, lights = 0;
  for (auto _ : state) {
    Sequence s;
    state.SetIterationTime(TimeMs([&] { s = LoadSequence(SequencePath()); }) / 1000.0);
    objects = s.objects.size();
    lights = 0;
    for (const Light& l : s.lights) lights += l.vertices.size() / 3;
  }
  state.counters["objects"] = double(objects);
  state.counters["light_triangles"] = double(lights);
}

void BM_SceneBuild(benchmark::State& state) {
  const Sequence seq = LoadSequence(SequencePath());
  const FrameState frame = Evaluate(seq, 0, seq.width, seq.height);
  size_t triangles = 0, emitters = 0;
  for (const Object& o : seq.objects) triangles += o.mesh.triangles.size();
  for (const Light& l : seq.lights) emitters += l.vertices.size() / 3;
  double growth = 0.0;
  for (auto _ : state) {
    const double before = ResidentMb();
    double ms = 0.0;
    {
      std::unique_ptr<EmbreeScene> scene;
      ms = TimeMs([&] {
        scene = std::make_unique<EmbreeScene>(seq);
        scene->Update(frame);
      });
      growth = ResidentMb() - before;
    }
    state.SetIterationTime(ms / 1000.0);
  }
  state.counters["scene_triangles"] = double(triangles);
  state.counters["light_triangles"] = double(emitters);
  state.counters["resident_growth_mb"] = growth;
  state.counters["bytes_per_triangle"] = growth * 1024.0 * 1024.0 / double(triangles + emitters);
}

template <typename T>
double Bytes(const std::vector<T>& v) {
  return double(v.capacity() * sizeof(T));
}

void BM_LightStructures(benchmark::State& state) {
  const Sequence seq = LoadSequence(SequencePath());
  const FrameState frame = Evaluate(seq, 0, seq.width, seq.height);
  double bytes = 0.0;
  size_t n = 0;
  for (auto _ : state) {
    std::vector<LightTriangle> lights;
    std::unique_ptr<LightSampler> sampler;
    state.SetIterationTime(TimeMs([&] {
                             lights = BuildLightTriangles(seq, frame);
                             sampler = std::make_unique<LightSampler>(lights, LightSelection::kPower);
                           }) /
                           1000.0);
    n = lights.size();
    const LightSamplerSoa& soa = sampler->Soa();
    bytes = Bytes(lights) + Bytes(soa.aliasQ) + Bytes(soa.aliasIndex) + Bytes(soa.pdfArea) +
            Bytes(soa.aliasPairs) + Bytes(soa.records);
    for (int c = 0; c < 3; ++c)
      bytes += Bytes(soa.p0[c]) + Bytes(soa.e1[c]) + Bytes(soa.e2[c]) + Bytes(soa.normal[c]) + Bytes(soa.radiance[c]);
  }
  state.counters["light_triangles"] = double(n);
  state.counters["bytes_per_light"] = n ? bytes / double(n) : 0.0;
}

}  // namespace
}  // namespace restir

int main(int argc, char** argv) {
  using namespace restir;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (bool isolated : {true, false})
    benchmark::RegisterBenchmark(isolated ? "BM_ImportAsset/child_process" : "BM_ImportAsset/in_process",
                                 BM_ImportAsset, isolated)
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond)
        ->Iterations(3);
  benchmark::RegisterBenchmark("BM_LoadSequence", BM_LoadSequence)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(3);
  benchmark::RegisterBenchmark("BM_SceneBuild", BM_SceneBuild)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(2);
  benchmark::RegisterBenchmark("BM_LightStructures", BM_LightStructures)
      ->UseManualTime()
      ->Unit(benchmark::kMillisecond)
      ->Iterations(5);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
