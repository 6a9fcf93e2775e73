// How much memory a run will take, decided before it starts (DESIGN §10, issue 14): a sequence at 16384² over
// 100000 frames is valid by the sequence format's limits but would take the machine's memory long before anyone
// stopped it. `run` refuses such a run with exit status 2 and the figure, unless --max-memory says otherwise.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace restir {

struct Light;  // sim/scene/sequence.h

// What decides a run's memory.
struct RunShape {
  int64_t width = 0;             // image width, pixels
  int64_t height = 0;            // image height, pixels
  int64_t frames = 0;            // frames rendered (metrics rows per preset)
  int64_t presets = 0;           // presets run side by side
  int64_t members = 1;           // pipelines per preset (--ensemble K)
  int64_t sharedInitialPasses = 0;  // distinct initial-sampling configurations a frame keeps (InitialSamplingShare)
  int64_t indirectPresets = 0;   // presets with indirect light (indirect.bounces > 0)
  int64_t reusedIndirectPresets = 0;  // of those, the ones whose paths ReSTIR GI resamples (indirect.reuse)
  bool reference = true;         // a reference per frame, FLIP and the error metrics
  bool writeImages = true;       // EXR and PNG per frame
  int64_t sceneTriangles = 0;    // object triangles, for Embree's BVH
  int64_t lightTriangles = 0;    // emitter triangles
  int64_t lightGroups = 0;       // what the reference's light distributions select (core/light.h: a quad is one)
  bool textures = false;         // the scene has base-colour textures: texels in the G-buffers, a per-pixel BSDF table
  bool sky = false;              // an environment or a sun: the reference keeps a light mixture per pixel
  // The most samples one pixel's reference may take (sim/reference/reference.h ReferenceMaxSamplesPerPixel): a block of
  // pixels' samples are held at once.
  double referenceSamplesPerPixel = 0.0;
  double processBytes = 0.0;     // what the process holds already (libraries, the parsed sequence)
};

// Image jobs (one preset's frame files each) that may wait for the run's background writer besides the one it
// writes (sim/run/runner.cpp, sim/output/background_writer.h); what they hold counts toward the peak.
constexpr int kImageJobsWaiting = 1;

struct MemoryEstimate {
  double bytes = 0.0;                                     // the peak, all parts together
  std::vector<std::pair<std::string, double>> parts;      // named parts, largest first, for the message
};

// The light groups of a sequence's emitters (core/light.h LightGroups: a quad light's two triangles are one),
// counted light by light: at least as many as any frame has.
int64_t CountLightGroups(const std::vector<Light>& lights);

// An upper estimate of the run's peak resident memory: the long-lived per-pixel arrays (G-buffers, reservoirs,
// images, references) plus the largest transient of the frame loop (checkpoint serialisation, FLIP, the reference's
// render), the images the background writer holds with its EXR encoding, the metrics rows and the scene. Each part
// is computed from the sizes of the structures that hold it; tests/sim/memory_estimate_test
// checks the sum against the measured peak of real runs.
MemoryEstimate EstimateRunMemory(const RunShape& shape);

// The memory this process may use: the smallest of the machine's RAM (MemTotal), its control group's limit
// (cgroup v2 memory.max or v1 memory.limit_in_bytes) and RLIMIT_AS, with the name of the one that decides.
struct MemoryLimit {
  double bytes = 0.0;
  std::string source;  // "MemTotal", "cgroup memory.max", "RLIMIT_AS"
};
std::optional<MemoryLimit> MachineMemoryLimit();

// This process's resident set now (/proc/self/statm), bytes; 0 when unknown.
double CurrentResidentBytes();

// "512M", "24G", "1.5GiB", "100000000" (bytes): a size for --max-memory; nullopt if it is not one.
std::optional<double> ParseByteSize(const std::string& text);

// Throws InputError "<what>: error: the run needs about X (parts) but Y is available (source); ..." when
// `estimate` exceeds `limitBytes`.
void CheckMemory(const MemoryEstimate& estimate, double limitBytes, const std::string& limitSource,
                 const std::string& what);

}  // namespace restir
