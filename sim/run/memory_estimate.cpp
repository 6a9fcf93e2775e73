#include "sim/run/memory_estimate.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

#include "core/bsdf.h"
#include "core/light.h"
#include "core/reconnection_shift.h"
#include "sim/metrics/flip.h"
#include "sim/scene/gbuffer.h"
#include "sim/util/input_file.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/pipeline.h"
#include "sim/reference/reference.h"
#include "sim/scene/sequence.h"  // InputError

namespace restir {

namespace {

// The texel arrays exist only in textured scenes (TracePrimary), so they count only there.
double GBufferBytesPerPixel(bool textures) {
  GBuffer g;
  const void* texels[] = {&g.texelR, &g.texelG, &g.texelB};
  double bytes = 0.0;
  GBuffer::ForEachArray(g, [&](auto& v) {
    if (!textures && std::find(std::begin(texels), std::end(texels), static_cast<const void*>(&v)) != std::end(texels))
      return;
    bytes += sizeof(typename std::decay_t<decltype(v)>::value_type);
  });
  return bytes;
}

// One BsdfSoa entry (core/bsdf.h): type, albedo, alpha, specular, specular weight.
constexpr double kBsdfEntry = sizeof(int32_t) + 3 * sizeof(float) + sizeof(float) + 3 * sizeof(float) + sizeof(float);

constexpr double kRgb = sizeof(Vec3);               // one ImageRgb pixel
constexpr double kReservoir = sizeof(StoredReservoir);
constexpr double kVertexPoint = sizeof(LightTriangle);  // a ReSTIR GI vertex as the passes read it
constexpr double kHeldVertex = sizeof(HeldVertex);      // a ReSTIR GI vertex as the next frame keeps it

// A metrics row: at most kMaxColumns (name, value) pairs, each name on the heap when longer than the small-string
// buffer, then the row again as CSV text (the file is rewritten whole each frame) and in the checkpoint.
constexpr double kMaxColumns = 64;
constexpr double kColumnNameBytes = 32;
constexpr double kRowBytes = kMaxColumns * (sizeof(std::pair<std::string, double>) + kColumnNameBytes)  // in memory
                             + kMaxColumns * 16                                                       // CSV text
                             + kMaxColumns * (kColumnNameBytes + 16);                                 // checkpoint

// Embree's BVH with its build-time references, and our own copy of each triangle: Embree documents about 100
// bytes per triangle for a high-quality static BVH and twice that while it builds; 256 covers both.
constexpr double kBytesPerSceneTriangle = 256;

}  // namespace

int64_t CountLightGroups(const std::vector<Light>& lights) {
  int64_t groups = 0;
  for (const Light& l : lights) {
    std::vector<LightTriangle> triangles;
    for (size_t v = 0; v + 2 < l.vertices.size(); v += 3) {
      LightTriangle t;
      // Each triangle's own radiance, as the frames build them (sim/scene/embree_scene.cpp): a pair whose halves differ
      // is two groups there.
      const Vec3 radiance = l.triangleRadiance.empty() ? l.radiance : l.triangleRadiance[v / 3];
      if (MakeLightTriangle(l.vertices[v], l.vertices[v + 1], l.vertices[v + 2], radiance, t)) triangles.push_back(t);
    }
    groups += static_cast<int64_t>(MakeLightGroups(triangles).first.size());
  }
  return groups;
}

MemoryEstimate EstimateRunMemory(const RunShape& s) {
  const double px = double(s.width) * double(s.height);
  const double presets = double(std::max<int64_t>(1, s.presets));
  const double members = double(std::max<int64_t>(1, s.members));
  const double gbuffer = GBufferBytesPerPixel(s.textures);
  MemoryEstimate e;
  auto add = [&](const std::string& name, double bytes) { e.parts.emplace_back(name, bytes); };

  // Long-lived: what every frame holds.
  add("G-buffers (current and previous)", px * 2.0 * gbuffer);
  add("disocclusion ages and masks", px * (sizeof(uint16_t) + 2.0));
  // Textured scenes: the frame's BSDF table has an entry per pixel of this frame's and last frame's G-buffer,
  // built as a list of Bsdf and then as its SoA (FrameBsdfTable).
  if (s.textures) add("BSDF table of textured receivers", px * 2.0 * (sizeof(Bsdf) + kBsdfEntry));
  // Per member: this frame's and last frame's reservoirs, the spatial pass's output buffer and its image.
  add("reservoirs", px * presets * members * 3.0 * kReservoir);
  // ReSTIR GI (Pipeline::RenderIndirect), per member of a preset that reuses its paths: the GI reservoirs of this
  // frame and the last (the spatial pass writes into the last's) and the vertices the last frame's reservoirs hold (at
  // most one a pixel, compact: HeldVertex).
  if (s.reusedIndirectPresets > 0)
    add("ReSTIR GI reservoirs and held vertices",
        px * double(s.reusedIndirectPresets) * members * (2.0 * kReservoir + kHeldVertex));
  // A frame's initial passes, kept for the presets that share them (sim/estimator/pipeline.h InitialSamplingShare).
  if (s.sharedInitialPasses > 0)
    add("shared initial passes", px * double(s.sharedInitialPasses) * members * kReservoir);
  // Per preset: the estimate, the previous estimate, the accumulation sum and mean, FLIP's map, the temporal mask;
  // with an ensemble, the other members' images and the bias and variance images, and from three members on their
  // running sums.
  const double memberImages = members > 1 ? (members - 1.0) * (members >= 3 ? 2.0 : 1.0) + 2.0 : 0.0;
  add("images", px * presets * (4.0 * kRgb + sizeof(float) + 1.0 + memberImages * kRgb));
  if (s.reference) add("references (mean, standard error, previous)", px * 3.0 * kRgb);
  // The reference's kept light distributions stay with the process from the first frame on (sim/reference/reference.h).
  if (s.reference) add("reference light distributions", ReferenceKeptBytes(double(s.width), double(s.height),
                                                                             double(std::max(s.lightGroups, int64_t{1}))));

  // Transient: the largest of what a frame allocates and frees again.
  const double checkpoint =
      px * (gbuffer + sizeof(uint16_t) + (s.reference ? kRgb : 0.0) +
            presets * ((members >= 3 ? members + 1.0 : 2.0) * kRgb + members * kReservoir) +
            double(s.reusedIndirectPresets) * members * (kReservoir + kHeldVertex));
  const double flip = s.reference ? px * double(HdrFlipScratchBytesPerPixel()) : 0.0;
  // A preset frame's indirect pass: its image, and where ReSTIR GI resamples the paths, the paths' vertices, the
  // frame's points (a pixel's own and the held ones: two a pixel at most) with an index of them for keeping the
  // held ones, the next frame's held vertices (one a pixel at most), the cells of a stochastic pairwise pass (two
  // indices a pixel), the reuse's image and its temporal flags.
  const double indirectPass =
      s.reusedIndirectPresets > 0
          ? px * (2.0 * kRgb + sizeof(SecondaryVertex) + 2.0 * kVertexPoint + kHeldVertex +
                  4.0 * sizeof(uint32_t) + 1.0)
          : (s.indirectPresets > 0 ? px * kRgb : 0.0);
  const double cacheEntry = s.reference ? px * 2.0 * kRgb : 0.0;  // a reference cache entry as read and decoded
  const double referenceRender =
      s.reference ? ReferenceScratchBytes(px, double(s.lightTriangles), double(s.lightGroups),
                                          s.referenceSamplesPerPixel, s.sky, double(s.width))
                  : 0.0;
  // The background writer, when images are written, beside the frame loop's transients: the image jobs (the
  // waiting ones, the one it writes and the one being submitted), each a preset's estimate, FLIP map and ensemble
  // images; the frames' inputs they share (the reference, its standard error, five G-buffer arrays and the
  // preview's reference panel) for as many frames as the jobs span, the loop's current one included; and one
  // EXR's encoding: the error image and four scalar layers built for it, then the encoded file in memory (at most
  // the raw float channels: 3 RGB layers, 3 more with a reference, 6 with an ensemble, 6 scalars, and 16 bytes a
  // scanline, which the stream reserves whole: sim/output/frame_writer.cpp).
  double writer = 0.0, frameInputs = 0.0;
  if (s.writeImages) {
    const double runFrames = double(std::max<int64_t>(1, s.frames));
    const double jobs = std::min(kImageJobsWaiting + 2.0, runFrames * presets);
    // The estimate and the FLIP map are copied into each job (the frame's metrics read them after it is
    // submitted); the ensemble's bias and variance images move into it, so the job being submitted holds the
    // loop's own (counted under "images").
    const double job = kRgb + (s.reference ? sizeof(float) : 0.0);
    const double moved = (jobs - 1.0) * (members > 1 ? 2.0 * kRgb : 0.0);
    frameInputs = px * ((s.reference ? 2.0 * kRgb + 3.0 : 0.0) + 1.0 + 4.0 * sizeof(float));
    const double frames = std::min({runFrames, jobs, std::ceil(jobs / presets) + 1.0});
    const double exrChannels = 3.0 * (1 + (s.reference ? 3 : 0) + (members > 1 ? 2 : 0)) + 6.0;
    const double exr = px * (kRgb + 4.0 * sizeof(float) + exrChannels * sizeof(float)) + 16.0 * double(s.height);
    writer = px * (jobs * job + moved) + exr + frames * frameInputs;
  }
  // A checkpoint drains the writer first: beside it only the current frame's inputs stay.
  const double loopTransient = std::max({flip, cacheEntry, referenceRender, indirectPass});
  if (checkpoint + frameInputs >= loopTransient + writer) {
    add("checkpoint", checkpoint + frameInputs);
  } else {
    add(loopTransient == flip              ? "FLIP"
        : loopTransient == referenceRender ? "reference rendering"
        : loopTransient == indirectPass    ? "indirect pass"
                                           : "reference cache entry",
        loopTransient);
    if (writer > 0.0) add("images being written", writer);
  }

  add("metrics rows", double(s.frames) * presets * kRowBytes);
  add("scene", double(s.sceneTriangles + s.lightTriangles) * kBytesPerSceneTriangle +
                   double(s.lightTriangles) * 2.0 * sizeof(LightTriangle));
  add("process (libraries, the sequence)", s.processBytes);
  // Worker threads' stacks and caches and the allocator's free lists, which no array above accounts for.
  add("threads and allocator", 32.0 * 1048576.0);

  for (const auto& [name, bytes] : e.parts) e.bytes += bytes;
  std::stable_sort(e.parts.begin(), e.parts.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  return e;
}

namespace {

std::optional<double> ReadNumberFile(const std::string& path) {
  std::string text, problem;
  if (!TryReadRegularFile(path, 4096, text, problem)) return std::nullopt;
  std::istringstream in(text);
  double v = 0.0;
  if (!(in >> v) || !(v > 0.0)) return std::nullopt;  // "max" (no limit) fails here
  return v;
}

// The control group limits that apply to this process: its own group's (v2 and v1 paths from /proc/self/cgroup)
// and, inside a container whose cgroup namespace hides the path, the mount's root.
std::optional<double> CgroupLimit() {
  std::vector<std::string> files = {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"};
  std::string text, problem;
  if (TryReadRegularFile("/proc/self/cgroup", 1 << 16, text, problem)) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t a = line.find(':'), b = line.find(':', a + 1);
      if (a == std::string::npos || b == std::string::npos) continue;
      const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
      if (controllers.empty()) files.push_back("/sys/fs/cgroup" + path + "/memory.max");
      if (controllers == "memory") files.push_back("/sys/fs/cgroup/memory" + path + "/memory.limit_in_bytes");
    }
  }
  std::optional<double> limit;
  for (const std::string& f : files)
    if (const auto v = ReadNumberFile(f); v && *v < 1e18) limit = std::min(limit.value_or(*v), *v);
  return limit;
}

}  // namespace

std::optional<MemoryLimit> MachineMemoryLimit() {
  std::optional<MemoryLimit> best;
  auto consider = [&](double bytes, const char* source) {
    if (bytes > 0.0 && (!best || bytes < best->bytes)) best = MemoryLimit{bytes, source};
  };
  std::string text, problem;
  if (TryReadRegularFile("/proc/meminfo", 1 << 16, text, problem)) {
    std::istringstream in(text);
    for (std::string key; in >> key;) {
      double kib = 0.0;
      if (key == "MemTotal:" && in >> kib) consider(kib * 1024.0, "the machine's memory (MemTotal)");
      std::string rest;
      std::getline(in, rest);
    }
  }
  if (const auto cg = CgroupLimit()) consider(*cg, "the control group's memory limit");
  struct rlimit rl {};
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    consider(double(rl.rlim_cur), "the address-space limit (ulimit -v)");
  return best;
}

double CurrentResidentBytes() {
  std::string text, problem;
  if (!TryReadRegularFile("/proc/self/statm", 4096, text, problem)) return 0.0;
  std::istringstream in(text);
  double size = 0.0, resident = 0.0;
  if (!(in >> size >> resident)) return 0.0;
  return resident * double(::sysconf(_SC_PAGESIZE));
}

std::optional<double> ParseByteSize(const std::string& text) {
  // Digits with at most one decimal point, then a unit: no sign, exponent, hexadecimal or spaces.
  const size_t used = text.find_first_not_of("0123456789.");
  const std::string number = text.substr(0, used);
  if (number.empty() || !std::isdigit(static_cast<unsigned char>(number[0])) ||
      std::count(number.begin(), number.end(), '.') > 1)
    return std::nullopt;
  const double v = std::strtod(number.c_str(), nullptr);
  if (!std::isfinite(v) || v <= 0.0) return std::nullopt;
  std::string unit = used == std::string::npos ? "" : text.substr(used);
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (unit.size() > 1 && unit.back() == 'B') unit.pop_back();  // "GB", "GIB" -> "G", "GI"
  if (unit.size() > 1 && unit.back() == 'I') unit.pop_back();
  static const std::pair<const char*, double> kUnits[] = {
      {"", 1.0}, {"B", 1.0}, {"K", 1024.0}, {"M", 1048576.0}, {"G", 1073741824.0}, {"T", 1099511627776.0}};
  for (const auto& [name, scale] : kUnits)
    if (unit == name) return v * scale;
  return std::nullopt;
}

void CheckMemory(const MemoryEstimate& estimate, double limitBytes, const std::string& limitSource,
                 const std::string& what) {
  if (estimate.bytes <= limitBytes) return;
  std::string parts;
  for (size_t i = 0; i < estimate.parts.size() && i < 3; ++i)
    parts += (i ? ", " : "") + estimate.parts[i].first + " " + FormatBytes(estimate.parts[i].second);
  throw InputError(what + ": error: the run needs about " + FormatBytes(estimate.bytes) + " of memory (" + parts +
                   ") but " + FormatBytes(limitBytes) + " is available (" + limitSource +
                   "); lower --resolution, --frames, the presets or --ensemble, or set --max-memory");
}

}  // namespace restir
