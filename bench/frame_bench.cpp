// Whole-frame benchmark (DESIGN §9; issue 6): every preset at 1920x1080 on sequences/window_bars_pan.json, a
// frame driven as sim/run/runner.cpp drives it (Evaluate -> scene.Update -> TracePrimary -> Reproject -> the passes
// with the previous frame's state), measured against its floors in the same run:
//
//   frame        scene update + primary (G-buffer) + reproject + initial + temporal + spatial + shade: the runner's
//                ms_frame. Frame 0 is rendered once for history; frame 1 (temporal input present) is re-rendered
//                `reps` times from the same history and the fastest repetition counts.
//   ray floor    the exact rays that frame traced (recorded through a RayHook, sim/scene/embree_probe.h, in a
//                capture render of the same frame, checked bit-identical by image hash) traced alone with
//                Embree, in the same batching as the passes (primary rays rtcIntersect1 one at a time, shadow
//                rays through EmbreeScene::OccludedBatch with the passes' entry point, in blocks of consecutive
//                captured rays), parallel over the rays in capture order, per pass.
//   kernel floor each pass re-rendered with every ray answered from memory (the RayHook replays the captured
//                answers), minus the cost of those lookups measured alone: the pass's kernels and data movement
//                with visibility precomputed. Scene update and reprojection trace no rays and count whole.
//   ratio        frame / (ray floor + kernel floor); also frame / ray floor and 1-thread frame / 2-thread frame.
//   cpu1_*       the frame and both floors once more at one thread, in the thread's CPU time: the same ratios,
//                robust to other processes sharing the cores (wall times on a loaded machine are not).
//
// BM_ShadowRayApi compares Embree's occlusion entry points on the captured shadow rays of restir-unbiased;
// BM_Memory reports the per-pixel state and peak resident memory of one preset's frame state.
//
// Environment (for quick runs): RESTIR_BENCH_WIDTH / _HEIGHT (default 1920x1080), RESTIR_BENCH_REPS (timed frame
// repetitions, default 2), RESTIR_BENCH_FLOOR_REPS (floor repetitions, default 2), RESTIR_BENCH_PROFILE=1 (only
// the timed repetitions, nothing else: for perf record) or 2 (the timed repetitions and the 1-thread frame only),
// RESTIR_BENCH_SEQUENCE (a sequence file to measure instead of the flagship).
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/light_sampler.h"
#include "sim/scene/embree_probe.h"
#include "sim/scene/embree_scene.h"
#include "sim/run/frame_loop.h"
#include "sim/scene/gbuffer.h"
#include "sim/util/image.h"
#include "sim/estimator/pipeline.h"
#include "sim/estimator/presets.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// CPU time of the calling thread. Under tbb::global_control(max_allowed_parallelism, 1) every task runs on the
// calling thread, so this is the work of a 1-thread measurement whatever else the machine is running.
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

int Width() { return EnvInt("RESTIR_BENCH_WIDTH", 1920); }
int Height() { return EnvInt("RESTIR_BENCH_HEIGHT", 1080); }
int Reps() { return std::max(1, EnvInt("RESTIR_BENCH_REPS", 2)); }
int FloorReps() { return std::max(1, EnvInt("RESTIR_BENCH_FLOOR_REPS", 2)); }

constexpr size_t kFloorBlock = 256;  // captured shadow rays per OccludedBatch call of the ray floor
constexpr int kHistoryFrame = 0;   // rendered once: gives the measured frame its temporal input
constexpr int kMeasuredFrame = 1;  // the steady-state frame that is timed, captured and replayed
constexpr const char* kSequence = RESTIR_SOURCE_DIR "/sequences/window_bars_pan.json";

// The measured sequence: the flagship, or RESTIR_BENCH_SEQUENCE (e.g. issue 17's scale scene, scripts/make_assets.py).
const Sequence& WindowBars() {
  static const Sequence seq = LoadSequence(std::getenv("RESTIR_BENCH_SEQUENCE") ? std::getenv("RESTIR_BENCH_SEQUENCE")
                                                                                 : kSequence);
  return seq;
}

double LoadAverage() {  // 1-minute load average: other processes competing for the 2 cores skew every timing
  double load = -1.0;
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &load) != 1) load = -1.0;
    std::fclose(f);
  }
  return load;
}

double PeakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: KiB
}

// ---- Capture and replay of a frame's rays ------------------------------------------------------------------

struct CapturedRay {  // 32 bytes
  Vec3 org;
  Vec3 dir;
  float tmax = 0.0f;
  uint8_t previous = 0;  // traced in the previous frame's scene
  uint8_t answer = 0;    // occluded (shadow rays) / hit (primary rays)
  uint8_t thread = 0;    // TBB slot of the thread that traced it
};

uint8_t ThreadSlot() {
  const int t = tbb::this_task_arena::current_thread_index();
  return static_cast<uint8_t>(t >= 0 && t < 255 ? t : 255);
}

// Records every query into preallocated arrays; the slot is a global ticket, so the rays of a pass (passes are
// separated by parallel_for joins) occupy one contiguous range in pass order.
class Recorder final : public RayHook {
 public:
  void Reset(size_t shadowCapacity, size_t primaryCapacity) {
    shadow_.assign(shadowCapacity, CapturedRay{});
    primary_.assign(primaryCapacity, CapturedRay{});
    hits_.assign(primaryCapacity, RawHit{});
    nextShadow_ = 0;
    nextPrimary_ = 0;
  }
  void TracedOccluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame, bool occluded) const override {
    const size_t k = nextShadow_.fetch_add(1, std::memory_order_relaxed);
    if (k < shadow_.size())
      shadow_[k] = CapturedRay{org, dir, tmax, uint8_t(frame == SceneFrame::kPrevious), uint8_t(occluded),
                               ThreadSlot()};
  }
  void TracedIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                       const RawHit& hit) const override {
    const size_t k = nextPrimary_.fetch_add(1, std::memory_order_relaxed);
    if (k < primary_.size()) {
      primary_[k] = CapturedRay{org, dir, tmax, uint8_t(frame == SceneFrame::kPrevious), uint8_t(hit.geomId != ~0u),
                                ThreadSlot()};
      hits_[k] = hit;
    }
  }
  size_t ShadowCount() const { return nextShadow_.load(); }
  size_t PrimaryCount() const { return nextPrimary_.load(); }
  std::vector<CapturedRay>& Shadow() { return shadow_; }
  std::vector<CapturedRay>& Primary() { return primary_; }
  std::vector<RawHit>& Hits() { return hits_; }

 private:
  mutable std::vector<CapturedRay> shadow_, primary_;
  mutable std::vector<RawHit> hits_;
  mutable std::atomic<size_t> nextShadow_{0}, nextPrimary_{0};
};

uint64_t Mix(uint64_t h) {  // splitmix64 finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  h ^= h >> 31;
  return h;
}

uint64_t RayKey(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) {
  uint32_t w[8];
  std::memcpy(&w[0], &org, 12);
  std::memcpy(&w[3], &dir, 12);
  std::memcpy(&w[6], &tmax, 4);
  w[7] = frame == SceneFrame::kPrevious ? 1u : 0u;
  uint64_t h = 0x2545f4914f6cdd1dull;
  for (int i = 0; i < 8; i += 2) h = Mix(h ^ (uint64_t(w[i]) | (uint64_t(w[i + 1]) << 32)));
  return h;
}

// Answers every captured query from memory. The captured rays are in stream order (pass, then the thread that
// traced them, then time), so the queries of one row follow each other: each thread keeps a cursor and first
// looks a few entries past it (a sequential, prefetched read); only the first query of a row (or a reordered one)
// goes through the hash table (open addressing over 63-bit fingerprints -> stream index). Lookups so cost a few
// ns instead of a cache miss, which keeps the subtraction that gives the kernel floor small.
class Replayer final : public RayHook {
 public:
  Replayer(const std::vector<CapturedRay>& shadow, size_t shadowCount, const std::vector<CapturedRay>& primary,
           const std::vector<RawHit>& hits, size_t primaryCount)
      : shadow_(shadow), shadowCount_(shadowCount), primary_(primary), hits_(hits), primaryCount_(primaryCount) {
    Build(shadow_, shadowCount_, shadowTable_);
    Build(primary_, primaryCount_, primaryTable_);
  }
  bool AnswerOccluded(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame,
                      bool& occluded) const override {
    const size_t k = Find(shadow_, shadowCount_, shadowTable_, shadowCursor_, org, dir, tmax, frame);
    if (k == kNone) return false;
    occluded = shadow_[k].answer != 0;
    return true;
  }
  bool AnswerIntersect(const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame, RawHit& hit) const override {
    const size_t k = Find(primary_, primaryCount_, primaryTable_, primaryCursor_, org, dir, tmax, frame);
    if (k == kNone) return false;
    hit = hits_[k];
    return true;
  }
  uint64_t Misses() const { return misses_.load(); }
  uint64_t HashLookups() const { return hashLookups_.load(); }
  size_t Bytes() const { return (shadowTable_.keys.size() + primaryTable_.keys.size()) * 12; }
  void ResetCursors() const {
    for (auto& c : shadowCursor_) c.next = 0;
    for (auto& c : primaryCursor_) c.next = 0;
  }

 private:
  static constexpr size_t kNone = ~size_t{0};
  static constexpr size_t kWindow = 4;
  struct Table {
    std::vector<uint64_t> keys;
    std::vector<uint32_t> index;     // first occurrence of the key
    std::vector<uint32_t> nextSame;  // per ray: the next occurrence of the same ray, or kEnd
    size_t mask = 0;
  };
  static constexpr uint32_t kEnd = ~uint32_t{0};
  struct alignas(64) Cursor {
    size_t next = 0;
  };
  static constexpr int kSlots = 256;

  static SceneFrame Frame(const CapturedRay& r) { return r.previous ? SceneFrame::kPrevious : SceneFrame::kCurrent; }
  static uint64_t Fingerprint(uint64_t h) { return h | 1u; }  // never 0 (the empty slot)
  static bool Same(const CapturedRay& r, const Vec3& org, const Vec3& dir, float tmax, SceneFrame frame) {
    return std::memcmp(&r.org, &org, sizeof(Vec3)) == 0 && std::memcmp(&r.dir, &dir, sizeof(Vec3)) == 0 &&
           std::memcmp(&r.tmax, &tmax, sizeof(float)) == 0 && Frame(r) == frame;
  }
  static void Build(const std::vector<CapturedRay>& rays, size_t count, Table& t) {
    size_t size = 1024;
    while (size < 2 * count) size *= 2;
    t.keys.assign(size, 0);
    t.index.assign(size, 0);
    t.mask = size - 1;
    t.nextSame.assign(count, kEnd);
    std::vector<uint32_t> last(size, kEnd);  // per slot: the latest occurrence so far
    for (size_t i = 0; i < count; ++i) {
      const CapturedRay& r = rays[i];
      const uint64_t fp = Fingerprint(RayKey(r.org, r.dir, r.tmax, Frame(r)));
      size_t s = fp & t.mask;
      while (t.keys[s] != 0 && t.keys[s] != fp) s = (s + 1) & t.mask;
      if (t.keys[s] == 0) {
        t.keys[s] = fp;
        t.index[s] = static_cast<uint32_t>(i);
      } else {
        t.nextSame[last[s]] = static_cast<uint32_t>(i);  // the same ray again (e.g. a shade ray repeating the
      }                                                  // initial visibility ray of the same sample)
      last[s] = static_cast<uint32_t>(i);
    }
  }
  size_t Find(const std::vector<CapturedRay>& rays, size_t count, const Table& t, Cursor* cursors, const Vec3& org,
              const Vec3& dir, float tmax, SceneFrame frame) const {
    Cursor& c = cursors[ThreadSlot() % kSlots];
    const size_t end = std::min(count, c.next + kWindow);
    for (size_t k = c.next; k < end; ++k) {
      if (Same(rays[k], org, dir, tmax, frame)) {
        c.next = k + 1;
        return k;
      }
    }
    hashLookups_.fetch_add(1, std::memory_order_relaxed);
    const uint64_t fp = Fingerprint(RayKey(org, dir, tmax, frame));
    for (size_t s = fp & t.mask; t.keys[s] != 0; s = (s + 1) & t.mask) {
      if (t.keys[s] == fp) {
        // Of the occurrences of this ray, the one nearest the thread's cursor (the same pass), so the
        // following queries are found by the window again.
        size_t k = t.index[s];
        const auto distance = [&](size_t i) { return i > c.next ? i - c.next : c.next - i; };
        for (uint32_t o = t.nextSame[k]; o != kEnd; o = t.nextSame[o])
          if (distance(o) < distance(k)) k = o;
        c.next = k + 1;
        return k;
      }
    }
    misses_.fetch_add(1, std::memory_order_relaxed);
    return kNone;
  }

  const std::vector<CapturedRay>& shadow_;
  size_t shadowCount_;
  const std::vector<CapturedRay>& primary_;
  const std::vector<RawHit>& hits_;
  size_t primaryCount_;
  Table shadowTable_, primaryTable_;
  mutable Cursor shadowCursor_[kSlots], primaryCursor_[kSlots];
  mutable std::atomic<uint64_t> misses_{0}, hashLookups_{0};
};

// Puts captured rays in stream order: within each pass range, grouped by the thread that traced them, in time
// order (a stable sort), so one thread's consecutive queries (a row of pixels) are consecutive entries. `hits`
// (primary rays) follow the same permutation.
void ToStreamOrder(std::vector<CapturedRay>& rays, size_t begin, size_t end, std::vector<RawHit>* hits = nullptr) {
  std::vector<uint32_t> order(end - begin);
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<uint32_t>(begin + i);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return rays[a].thread < rays[b].thread; });
  std::vector<CapturedRay> r(order.size());
  for (size_t i = 0; i < order.size(); ++i) r[i] = rays[order[i]];
  std::copy(r.begin(), r.end(), rays.begin() + static_cast<ptrdiff_t>(begin));
  if (hits) {
    std::vector<RawHit> h(order.size());
    for (size_t i = 0; i < order.size(); ++i) h[i] = (*hits)[order[i]];
    std::copy(h.begin(), h.end(), hits->begin() + static_cast<ptrdiff_t>(begin));
  }
}

// Runs f over [begin, end) in parallel like the passes (auto-partitioned), `reps` times; the fastest in ms.
template <typename F>
double TimeParallel(size_t begin, size_t end, int reps, F&& f) {
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = Clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(begin, end), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) f(i);
    });
    best = std::min(best, MsSince(t0));
  }
  return begin == end ? 0.0 : best;
}

// ---- One preset --------------------------------------------------------------------------------------------

struct StageTimes {
  double primary = 0, reproject = 0;
  std::map<std::string, double> pass;    // ms per pass
  std::map<std::string, uint64_t> rays;  // rays per pass
  std::map<std::string, PassStats> work;  // the pass's kernel work (RIS pixels, target pairs, combinations)
  uint64_t hash = 0;
  double cpu = 0;  // calling thread's CPU ms for primary + reproject + passes (meaningful at 1 thread)
  double Total(double sceneUpdate) const {
    double t = sceneUpdate + primary + reproject;
    for (const auto& [name, ms] : pass) t += ms;
    return t;
  }
};

// What a pipeline carries from the previous frame: its reservoirs and, under ReSTIR GI, the GI reservoirs and the
// vertices they hold.
struct History {
  std::vector<StoredReservoir> reservoirs, indirect;
  std::vector<HeldVertex> vertices;
  explicit History(Pipeline& p) : reservoirs(p.History()), indirect(p.IndirectHistory()), vertices(p.IndirectVertices()) {}
};

StageTimes RenderOnce(FrameLoop& d, Pipeline& p, const History& history) {
  p.History() = history.reservoirs;
  p.IndirectHistory() = history.indirect;
  p.IndirectVertices() = history.vertices;
  StageTimes s;
  const double cpu0 = ThreadCpuMs();
  s.primary = d.Primary();
  s.reproject = d.Reprojection();
  const FrameResult fr = d.Render(p, WindowBars().seed);
  s.cpu = ThreadCpuMs() - cpu0;
  for (const PassStats& ps : fr.passes) {
    s.pass[ps.name] = ps.ms;
    s.rays[ps.name] = ps.rays;
    s.work[ps.name] = ps;
  }
  s.hash = HashImage(fr.image);
  return s;
}

struct PresetResult {
  std::map<std::string, double> counters;
  // Kept for BM_ShadowRayApi: the driver (its scene holds both frames the rays were traced in) and the rays.
  std::unique_ptr<FrameLoop> driver;
  std::vector<CapturedRay> shadow;
};

PresetResult RunPreset(const Preset& preset, bool keepRays) {
  PresetResult out;
  auto& c = out.counters;
  c["loadavg_start"] = LoadAverage();
  const int w = Width(), h = Height();
  out.driver = std::make_unique<FrameLoop>(WindowBars(), w, h);
  FrameLoop& d = *out.driver;
  Pipeline pipeline(preset.settings);
  // The history, played as a run plays its frames; the measured frame is begun and never ended: it is rendered
  // again and again from the same history below.
  d.Play(kHistoryFrame, kMeasuredFrame, [&](int) { d.Render(pipeline, WindowBars().seed); });
  d.BeginFrame(kMeasuredFrame);
  const History history(pipeline);
  const double sceneUpdate = d.MsSceneUpdate();

  // Timed repetitions of the steady-state frame (2 threads, or whatever TBB is allowed), fastest counts.
  StageTimes best;
  double bestMs = 1e300;
  bool deterministic = true;
  for (int r = 0; r < Reps(); ++r) {
    const StageTimes s = RenderOnce(d, pipeline, history);
    if (r > 0 && s.hash != best.hash) deterministic = false;
    if (s.Total(sceneUpdate) < bestMs) bestMs = s.Total(sceneUpdate), best = s;
  }
  c["rss_after_frames_mb"] = PeakRssMb();
  const uint64_t frameHash = best.hash;
  const int only = EnvInt("RESTIR_BENCH_PROFILE", 0);
  c["ms_frame"] = bestMs;
  if (only == 1) {  // only the timed frames (for perf record)
    out.driver.reset();
    return out;
  }

  // One thread, same frame.
  double oneThreadMs = 0, oneThreadCpu = 0;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const StageTimes s = RenderOnce(d, pipeline, history);
    oneThreadMs = s.Total(sceneUpdate);
    oneThreadCpu = s.cpu + sceneUpdate;
    if (s.hash != frameHash) deterministic = false;
  }
  if (only == 2) {  // only the thread scaling
    c["ms_frame_1thread"] = oneThreadMs;
    c["cpu1_ms_frame"] = oneThreadCpu;
    c["thread_scaling"] = oneThreadMs / bestMs;
    c["loadavg_end"] = LoadAverage();
    out.driver.reset();
    return out;
  }

  // Capture render: the exact rays of this frame. The passes' rays are shadow rays but for the closest-hit rays
  // after the primary ones: the indirect pass's paths, and initial sampling's BSDF candidates where a preset draws
  // them (rtxdi-defaults and restir-gi), which are counted with the indirect pass here ("rays_paths"): the frame's
  // floors are exact, that pass's share of them approximate for those presets.
  uint64_t passRays = 0;
  for (const auto& [name, n] : best.rays) passRays += n;
  const size_t pixels = static_cast<size_t>(w) * h;
  Recorder rec;
  rec.Reset(passRays, pixels + (best.rays.count("indirect") ? best.rays.at("indirect") : 0));
  SetRayHook(d.Scene(), &rec);
  const StageTimes cap = RenderOnce(d, pipeline, history);
  SetRayHook(d.Scene(), nullptr);
  const size_t shadowCount = std::min(rec.ShadowCount(), rec.Shadow().size());
  const size_t intersectCount = std::min(rec.PrimaryCount(), rec.Primary().size());
  const size_t primaryCount = std::min(intersectCount, pixels);
  const size_t pathRays = intersectCount - primaryCount;  // the indirect pass's paths
  c["capture_hash_match"] = cap.hash == frameHash ? 1 : 0;
  c["capture_complete"] = rec.ShadowCount() + pathRays == passRays && rec.PrimaryCount() >= pixels ? 1 : 0;
  c["rays_paths"] = double(pathRays);

  // Ray floor per pass: the captured rays alone (primary rays rtcIntersect1 one at a time, shadow rays in
  // batches as the passes trace them), parallel.
  const EmbreeScene& scene = d.Scene();
  std::atomic<uint64_t> mismatches{0};
  const std::vector<CapturedRay>& prim = rec.Primary();
  const std::vector<CapturedRay>& shad = rec.Shadow();
  std::map<std::string, double> rayFloor, lookup, kernelFloor;
  std::map<std::string, std::pair<size_t, size_t>> range;  // pass -> [begin, end) in capture order
  {
    size_t at = 0;
    for (const char* name : kPassNames) {
      if (!best.rays.count(name)) continue;
      const size_t n = best.rays.at(name) - (std::string(name) == "indirect" ? pathRays : 0);
      range[name] = {std::min(at, shadowCount), std::min(at + n, shadowCount)};
      at += n;
    }
  }
  ToStreamOrder(rec.Primary(), 0, primaryCount, &rec.Hits());
  ToStreamOrder(rec.Primary(), primaryCount, intersectCount, &rec.Hits());
  for (const auto& [name, r] : range) ToStreamOrder(rec.Shadow(), r.first, r.second);
  auto intersect = [&](size_t i) {
    const RawHit hit = IntersectRaw(scene, prim[i].org, prim[i].dir, prim[i].tmax);
    if (uint8_t(hit.geomId != ~0u) != prim[i].answer) mismatches.fetch_add(1, std::memory_order_relaxed);
  };
  rayFloor["primary"] = TimeParallel(0, primaryCount, FloorReps(), intersect);
  const double pathFloor = pathRays ? TimeParallel(primaryCount, intersectCount, FloorReps(), intersect) : 0.0;
  // Shadow rays go through OccludedBatch with the passes' entry point, in blocks of consecutive captured rays
  // (one thread's rays of a few pixel batches), each block split by scene frame as the passes split theirs.
  auto traceBlock = [&](size_t begin, size_t end) {
    ShadowRay batch[2][kFloorBlock];
    size_t index[2][kFloorBlock], count[2] = {0, 0};
    for (size_t i = begin; i < end; ++i) {
      const int f = shad[i].previous ? 1 : 0;
      batch[f][count[f]] = ShadowRay{shad[i].org, shad[i].dir, shad[i].tmax};
      index[f][count[f]++] = i;
    }
    for (int f = 0; f < 2; ++f) {
      uint8_t occluded[kFloorBlock];
      if (count[f] == 0) continue;
      scene.OccludedBatch(batch[f], occluded, count[f], f ? SceneFrame::kPrevious : SceneFrame::kCurrent);
      for (size_t k = 0; k < count[f]; ++k)
        if (occluded[k] != shad[index[f][k]].answer) mismatches.fetch_add(1, std::memory_order_relaxed);
    }
  };
  for (const auto& [name, r] : range) {
    const size_t blocks = (r.second - r.first + kFloorBlock - 1) / kFloorBlock;
    rayFloor[name] = TimeParallel(0, blocks, FloorReps(), [&](size_t b) {
      const size_t begin = r.first + b * kFloorBlock;
      traceBlock(begin, std::min(r.second, begin + kFloorBlock));
    });
  }
  if (pathRays) rayFloor["indirect"] += pathFloor;

  // The same at one thread, in CPU time (robust to other processes sharing the cores): all rays, in order.
  double rayFloorCpu1 = 0;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const double cpu0 = ThreadCpuMs();
    for (size_t i = 0; i < intersectCount; ++i)
      benchmark::DoNotOptimize(IntersectRaw(scene, prim[i].org, prim[i].dir, prim[i].tmax));
    for (const auto& [name, r] : range)
      for (size_t begin = r.first; begin < r.second; begin += kFloorBlock)
        traceBlock(begin, std::min(r.second, begin + kFloorBlock));
    rayFloorCpu1 = ThreadCpuMs() - cpu0;
  }

  // Kernel floor: the same frame with every ray answered from memory, minus those lookups timed alone.
  double kernelFloorCpu1 = 0;
  {
    Replayer replay(shad, shadowCount, prim, rec.Hits(), intersectCount);
    c["replay_table_mb"] = double(replay.Bytes()) / 1048576.0;
    SetRayHook(d.Scene(), &replay);
    StageTimes rep;
    double repBest = 1e300;
    for (int r = 0; r < Reps(); ++r) {
      replay.ResetCursors();
      const StageTimes s = RenderOnce(d, pipeline, history);
      if (s.Total(sceneUpdate) < repBest) repBest = s.Total(sceneUpdate), rep = s;
    }
    SetRayHook(d.Scene(), nullptr);
    c["replay_hash_match"] = rep.hash == frameHash ? 1 : 0;
    c["replay_misses"] = double(replay.Misses());
    c["replay_hash_lookups"] = double(replay.HashLookups());
    const RayHook* hook = &replay;  // through the virtual call, as in the passes
    replay.ResetCursors();
    lookup["primary"] = TimeParallel(0, primaryCount, FloorReps(), [&](size_t i) {
      RawHit hit;
      hook->AnswerIntersect(prim[i].org, prim[i].dir, prim[i].tmax, SceneFrame::kCurrent, hit);
      benchmark::DoNotOptimize(hit);
    });
    for (const auto& [name, r] : range) {
      lookup[name] = TimeParallel(r.first, r.second, FloorReps(), [&](size_t i) {
        bool occ = false;
        hook->AnswerOccluded(shad[i].org, shad[i].dir, shad[i].tmax,
                             shad[i].previous ? SceneFrame::kPrevious : SceneFrame::kCurrent, occ);
        benchmark::DoNotOptimize(occ);
      });
    }
    if (pathRays)
      lookup["indirect"] += TimeParallel(primaryCount, intersectCount, FloorReps(), [&](size_t i) {
        RawHit hit;
        hook->AnswerIntersect(prim[i].org, prim[i].dir, prim[i].tmax, SceneFrame::kCurrent, hit);
        benchmark::DoNotOptimize(hit);
      });
    kernelFloor["primary"] = std::max(0.0, rep.primary - lookup["primary"]);
    c["replay_ms_primary"] = rep.primary;
    for (const auto& [name, ms] : rep.pass) {
      kernelFloor[name] = std::max(0.0, ms - lookup[name]);
      c["replay_ms_" + name] = ms;
    }
    kernelFloor["reproject"] = rep.reproject;
    kernelFloor["scene_update"] = sceneUpdate;
    // One thread, CPU time: replayed frame minus all lookups alone.
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    SetRayHook(d.Scene(), &replay);
    replay.ResetCursors();
    const StageTimes rep1 = RenderOnce(d, pipeline, history);
    SetRayHook(d.Scene(), nullptr);
    if (rep1.hash != frameHash) c["replay_hash_match"] = 0;
    replay.ResetCursors();
    const double cpu0 = ThreadCpuMs();
    for (size_t i = 0; i < intersectCount; ++i) {
      RawHit hit;
      hook->AnswerIntersect(prim[i].org, prim[i].dir, prim[i].tmax, SceneFrame::kCurrent, hit);
      benchmark::DoNotOptimize(hit);
    }
    for (size_t i = 0; i < shadowCount; ++i) {
      bool occ = false;
      hook->AnswerOccluded(shad[i].org, shad[i].dir, shad[i].tmax,
                           shad[i].previous ? SceneFrame::kPrevious : SceneFrame::kCurrent, occ);
      benchmark::DoNotOptimize(occ);
    }
    const double lookupCpu1 = ThreadCpuMs() - cpu0;
    kernelFloorCpu1 = std::max(0.0, rep1.cpu - lookupCpu1) + sceneUpdate;
    c["cpu1_ms_replay"] = rep1.cpu;
    c["cpu1_ms_lookups"] = lookupCpu1;
  }
  c["ray_mismatches"] = double(mismatches.load());

  // Counters.
  double rayFloorMs = 0, kernelFloorMs = 0;
  for (const auto& [name, ms] : rayFloor) rayFloorMs += ms;
  for (const auto& [name, ms] : kernelFloor) kernelFloorMs += ms;
  c["width"] = w;
  c["height"] = h;
  size_t surfaces = 0;
  for (size_t i = 0; i < d.Gbuffer().Size(); ++i) surfaces += d.Gbuffer().IsSurface(i) ? 1 : 0;
  c["surface_pixels"] = double(surfaces);
  c["threads"] = tbb::this_task_arena::max_concurrency();
  c["ms_frame"] = bestMs;
  c["ms_frame_1thread"] = oneThreadMs;
  c["ms_scene_update"] = sceneUpdate;
  c["ms_primary"] = best.primary;
  c["ms_reproject"] = best.reproject;
  c["rays_primary"] = double(primaryCount);
  for (const char* name : kPassNames) {
    const std::string n = name;
    c["ms_" + n] = best.pass.count(n) ? best.pass.at(n) : 0.0;
    c["rays_" + n] = best.rays.count(n) ? double(best.rays.at(n)) : 0.0;
    c["rayfloor_ms_" + n] = rayFloor.count(n) ? rayFloor.at(n) : 0.0;
    c["kernelfloor_ms_" + n] = kernelFloor.count(n) ? kernelFloor.at(n) : 0.0;
    c["lookup_ms_" + n] = lookup.count(n) ? lookup.at(n) : 0.0;
    const PassStats w = best.work.count(n) ? best.work.at(n) : PassStats{};
    c["ris_pixels_" + n] = double(w.risPixels);
    c["targets_" + n] = double(w.targets);
    c["combinations_" + n] = double(w.combinations);
  }
  c["rayfloor_ms_primary"] = rayFloor["primary"];
  c["kernelfloor_ms_primary"] = kernelFloor["primary"];
  c["lookup_ms_primary"] = lookup["primary"];
  c["kernelfloor_ms_reproject"] = kernelFloor["reproject"];
  c["kernelfloor_ms_scene_update"] = kernelFloor["scene_update"];
  c["rayfloor_ms"] = rayFloorMs;
  c["rayfloor_ms_shadow"] = rayFloorMs - rayFloor["primary"];
  c["kernelfloor_ms"] = kernelFloorMs;
  c["rays_shadow"] = double(shadowCount);
  c["ratio_frame_to_floors"] = bestMs / (rayFloorMs + kernelFloorMs);
  c["ratio_frame_to_rayfloor"] = bestMs / rayFloorMs;
  c["thread_scaling"] = oneThreadMs / bestMs;
  c["cpu1_ms_frame"] = oneThreadCpu;
  c["cpu1_ms_rayfloor"] = rayFloorCpu1;
  c["cpu1_ms_kernelfloor"] = kernelFloorCpu1;
  c["cpu1_ratio_frame_to_floors"] = oneThreadCpu / (rayFloorCpu1 + kernelFloorCpu1);
  c["cpu1_ratio_frame_to_rayfloor"] = oneThreadCpu / rayFloorCpu1;
  c["deterministic"] = deterministic ? 1 : 0;
  c["rss_peak_mb"] = PeakRssMb();
  c["loadavg_end"] = LoadAverage();
#ifdef NDEBUG
  c["ndebug"] = 1;
#else
  c["ndebug"] = 0;
#endif

  if (keepRays) {
    rec.Shadow().resize(shadowCount);
    out.shadow = std::move(rec.Shadow());
  } else {
    out.driver.reset();
  }
  return out;
}

// The restir-unbiased capture, kept for BM_ShadowRayApi.
PresetResult& UnbiasedCapture() {
  static PresetResult kept;
  return kept;
}

void BM_Frame(benchmark::State& state, const Preset* preset) {
  const bool keep = preset->name == "restir-unbiased";
  for (auto _ : state) {
    PresetResult r = RunPreset(*preset, keep);
    state.SetIterationTime(r.counters["ms_frame"] / 1000.0);
    for (const auto& [name, value] : r.counters) state.counters[name] = value;
    if (keep) UnbiasedCapture() = std::move(r);
  }
  state.SetLabel(preset->name);
}

// ---- Embree entry points for the same shadow rays ----------------------------------------------------------

const char* ApiName(OcclusionApi api) {
  switch (api) {
    case OcclusionApi::k1: return "rtcOccluded1";
    case OcclusionApi::k4: return "rtcOccluded4";
    case OcclusionApi::k8: return "rtcOccluded8";
    case OcclusionApi::k16: return "rtcOccluded16";
    case OcclusionApi::kStream1M: return "rtcOccluded1M";
  }
  return "?";
}

void BM_ShadowRayApi(benchmark::State& state, OcclusionApi api) {
  PresetResult& kept = UnbiasedCapture();
  if (!kept.driver) kept = RunPreset(*FindPreset("restir-unbiased"), true);
  // Batches keep capture order, split by scene frame (a batch traces one scene).
  static std::vector<ShadowRay> rays[2];
  static std::vector<uint8_t> answers[2];
  if (rays[0].empty() && rays[1].empty()) {
    for (const CapturedRay& r : kept.shadow) {
      rays[r.previous].push_back(ShadowRay{r.org, r.dir, r.tmax});
      answers[r.previous].push_back(r.answer);
    }
  }
  const EmbreeScene& scene = kept.driver->Scene();
  constexpr size_t kBatch = 256;  // rays per batch call (one task's share)
  std::vector<uint8_t> occ[2] = {std::vector<uint8_t>(rays[0].size()), std::vector<uint8_t>(rays[1].size())};
  double best = 1e300;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    for (int f = 0; f < 2; ++f) {
      const SceneFrame frame = f ? SceneFrame::kPrevious : SceneFrame::kCurrent;
      const size_t n = rays[f].size();
      tbb::parallel_for(tbb::blocked_range<size_t>(0, (n + kBatch - 1) / kBatch),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t b = r.begin(); b != r.end(); ++b) {
                            const size_t begin = b * kBatch, count = std::min(kBatch, n - begin);
                            OccludedBatch(scene, api, rays[f].data() + begin, occ[f].data() + begin, count, frame);
                          }
                        });
    }
    const double ms = MsSince(t0);
    best = std::min(best, ms);
    state.SetIterationTime(ms / 1000.0);
  }
  uint64_t mismatches = 0;
  for (int f = 0; f < 2; ++f)
    for (size_t i = 0; i < occ[f].size(); ++i) mismatches += occ[f][i] != answers[f][i];
  const double total = double(rays[0].size() + rays[1].size());
  state.counters["ms_best"] = best;
  state.counters["rays"] = total;
  state.counters["mrays_per_s"] = total / (best * 1000.0);
  state.counters["mismatches_vs_occluded1"] = double(mismatches);
  state.counters["threads"] = tbb::this_task_arena::max_concurrency();
  state.SetLabel(ApiName(api));
}

// ---- Memory ------------------------------------------------------------------------------------------------

template <typename T>
double VecBytes(const std::vector<T>& v) {
  return double(v.capacity()) * sizeof(T);
}

double GBufferBytes(const GBuffer& g) {
  double b = 0;
  GBuffer::ForEachArray(g, [&](const auto& v) { b += VecBytes(v); });
  return b;
}

// Per-pixel state of one preset's frame (the driver's two G-buffers, the pipeline's reservoir buffers and cells,
// the frame's image and per-pixel flags) after two frames of the preset with the most state, plus the runner's
// own per-pixel arrays (sim/run/runner.cpp), and the process's peak resident memory at that point.
void BM_Memory(benchmark::State& state, const Preset* preset) {
  for (auto _ : state) {
    const int w = Width(), h = Height();
    const double n = double(w) * h;
    FrameLoop d(WindowBars(), w, h);
    Pipeline p(preset->settings);
    d.Play(kHistoryFrame, kMeasuredFrame, [&](int) { d.Render(p, WindowBars().seed); });
    d.BeginFrame(kMeasuredFrame);  // measured, never ended
    const auto t0 = Clock::now();
    const FrameResult fr = d.Render(p, WindowBars().seed);
    state.SetIterationTime(MsSince(t0) / 1000.0);
    const double gbuffers = GBufferBytes(d.Gbuffer()) + GBufferBytes(d.PreviousGbuffer());
    // Pipeline: its reservoir buffers (private members, so counted from sizeof and the pixel count); cell lists
    // with stochastic pairwise MIS; Cell is 32 bytes.
    const int reservoirBuffers = Pipeline::kReservoirBuffers;
    const double reservoirs = double(reservoirBuffers) * sizeof(StoredReservoir) * n;
    const double cells = VecBytes(p.Cells().pixelCell) + VecBytes(p.Cells().pixels) + sizeof(CellGrid::Cell) * double(p.Cells().cells.size());
    const double frame = VecBytes(fr.image.pixels) + VecBytes(fr.temporalAccepted);
    // sim/run/runner.cpp, per preset: previousImages + accumSum (ImageRgb each); shared: the reference's mean and
    // standard error and previousReference (ImageRgb each), disoccAge and age (uint16), recentMask and restMask.
    const double runnerPerPreset = 2.0 * sizeof(Vec3);
    const double runnerShared = 3.0 * sizeof(Vec3) + 2.0 * sizeof(uint16_t) + 2.0;
    state.counters["bpp_gbuffers"] = gbuffers / n;
    state.counters["bpp_reservoirs"] = reservoirs / n;
    state.counters["bpp_cells"] = cells / n;
    state.counters["bpp_frame_image_flags"] = frame / n;
    state.counters["bpp_total"] = (gbuffers + reservoirs + cells + frame) / n;
    state.counters["bpp_runner_per_preset"] = runnerPerPreset;
    state.counters["bpp_runner_shared"] = runnerShared;
    state.counters["sizeof_reservoir"] = sizeof(StoredReservoir);
    state.counters["reservoir_buffers"] = reservoirBuffers;
    state.counters["width"] = w;
    state.counters["height"] = h;
    state.counters["rss_peak_mb"] = PeakRssMb();
    state.counters["state_mb"] = (gbuffers + reservoirs + cells + frame) / 1048576.0;
  }
  state.SetLabel(preset->name);
}

void RegisterAll() {
  // Memory first: the peak resident memory is a high-water mark, so it is read before any capture is held.
  const Preset* biggest = FindPreset("restir-spmis");
  if (!biggest) biggest = &AllPresets().back();
  benchmark::RegisterBenchmark(("BM_Memory/" + biggest->name).c_str(), BM_Memory, biggest)
      ->Iterations(1)
      ->UseManualTime()
      ->Unit(benchmark::kMillisecond);
  std::vector<const Preset*> presets;
  for (const Preset& p : AllPresets()) presets.push_back(&p);
  for (const Preset& p : IndirectPresets()) presets.push_back(&p);  // ReSTIR GI (issue 41)
  for (const Preset* p : presets) {
    benchmark::RegisterBenchmark(("BM_Frame/" + p->name).c_str(), BM_Frame, p)
        ->Iterations(1)
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond);
  }
  for (OcclusionApi api : {OcclusionApi::k1, OcclusionApi::k4, OcclusionApi::k8, OcclusionApi::k16,
                           OcclusionApi::kStream1M}) {
    benchmark::RegisterBenchmark((std::string("BM_ShadowRayApi/") + ApiName(api)).c_str(), BM_ShadowRayApi, api)
        ->Iterations(3)
        ->UseManualTime()
        ->Unit(benchmark::kMillisecond);
  }
}

}  // namespace
}  // namespace restir

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  // RESTIR_BENCH_EMBREE_ISA=sse4.2|avx2|avx512: Embree's ISA for every scene (default: restir-sim's default).
  if (const char* isa = std::getenv("RESTIR_BENCH_EMBREE_ISA")) {
    const std::optional<restir::EmbreeIsa> parsed = restir::ParseEmbreeIsa(isa);
    if (!parsed || !restir::SetEmbreeIsa(*parsed)) {
      std::fprintf(stderr, "frame_bench: RESTIR_BENCH_EMBREE_ISA=%s is not an ISA this CPU supports\n", isa);
      return 2;
    }
  }
  benchmark::AddCustomContext("embree_isa", restir::EmbreeIsaName(restir::ActiveEmbreeIsa()));
  restir::RegisterAll();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
