// PipelineSettings, every setting by its dotted name ("temporal.maxHistory"), for `--set KEY=VALUE`, run.json
// and `restir-sim presets`, and the bounds of its fields. (The passes' cross-pass fields, such as
// temporal.visibility, are not settings: the pipeline fills them from the others, PassSettings.) One table, so a new field is printable, recordable
// and overridable at once; one table of bounds, so `--set` and the Pipeline cannot disagree on them.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sim/estimator/passes/initial_sampling.h"
#include "sim/estimator/passes/shade.h"
#include "sim/estimator/passes/spatial_common.h"
#include "sim/estimator/passes/temporal_reuse.h"

namespace restir {

// Indirect light (issue 41): what a preset's frames model beyond direct light, after the direct light's passes.
// Paths come from the reference's path sampler (sim/reference/reference_paths.h), one a pixel, which the frame
// loop traces (sim/run/frame_loop.h FrameLoop::RenderPreset): added as they are, or resampled by ReSTIR GI.
struct IndirectParams {
  // The most surfaces after the primary hit that a path's light may reflect at before it reaches the pixel, 0 to 8
  // (kMaxIndirectBounces); 0: direct light only, the frames as they were before issue 41. A run's presets must all
  // model the same, as their one reference does (ReferenceParams::indirectBounces).
  int bounces = 0;
  // ReSTIR GI (Ouyang et al. 2021): each path's first vertex after the primary hit, x₂, becomes a reservoir
  // sample that the passes below reuse across frames and pixels by the reconnection shift (Pipeline::
  // RenderIndirect; DESIGN §4 "Path reuse"). false: each pixel's path is added as it is.
  bool reuse = false;
  TemporalParams temporal;  // the GI reservoirs' temporal reuse (its visibility follows shade.visibility below)
  SpatialParams spatial;    // their spatial reuse: k neighbours, or stochastic pairwise over cells
  ShadeParams shade;        // their shading: f V W of each pixel's final GI sample
};

struct PipelineSettings {
  InitialSamplingParams initial;  // the initial-sampling pass
  TemporalParams temporal;        // the temporal-reuse pass
  SpatialParams spatial;          // the spatial-reuse pass (k neighbours, or stochastic pairwise over cells)
  ShadeParams shade;              // the shading pass
  IndirectParams indirect;        // indirect light, after the direct light's passes (FrameLoop::RenderPreset)
};

// (name, value) for every field, in a fixed order.
std::vector<std::pair<std::string, std::string>> SettingsToStrings(const PipelineSettings& settings);

// Sets one field from text. Throws InputError naming the key (with the nearest known key) or the bad value,
// or the bound (SettingBounds) the settings then break.
void ApplySetting(PipelineSettings& settings, const std::string& key, const std::string& value);

// Applies "KEY=VALUE".
void ApplySettingAssignment(PipelineSettings& settings, const std::string& assignment);

// One bound on one field. Values compare as doubles (every int and float field converts exactly), so a NaN
// breaks every bound.
struct SettingBound {
  std::string key;    // the field's dotted name, as `--set` takes it
  double low = 0.0;   // inclusive; -infinity: none
  double high = 0.0;  // inclusive unless highExclusive; +infinity: none
  bool highExclusive = false;
  bool integer = false;  // an int field (else a float one)
  // The Pipeline refuses a value outside it too, even one set in code: the passes' per-batch scratch is sized
  // by it. The other bounds are `--set`'s alone, as they always were.
  bool pipeline = false;
  std::string reason;  // what `--set` says after "error at KEY: ", one text for the bounds one check states
  std::function<double(const PipelineSettings&)> get;
  // Places any value, one `--set` refuses included: tests put values just outside a bound with it.
  std::function<void(PipelineSettings&, double)> set;

  bool Holds(const PipelineSettings& settings) const;
};

// Every bound, in the order they are checked: the first one broken is the one reported.
const std::vector<SettingBound>& SettingBounds();

// Which bounds to check: all of them (`--set`) or those the Pipeline relies on (SettingBound::pipeline).
enum class BoundsScope { kAll, kPipeline };

// The first bound of the scope that `settings` breaks; nullptr when they all hold.
const SettingBound* BrokenBound(const PipelineSettings& settings, BoundsScope scope);

}  // namespace restir
