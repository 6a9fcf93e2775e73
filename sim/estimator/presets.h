// Named presets (DESIGN §5): bundles of pass settings with the source they follow.
#pragma once

#include <string>
#include <vector>

#include "sim/estimator/pipeline.h"
#include "sim/scene/sequence.h"

namespace restir {

struct Preset {
  std::string name;         // what --preset takes
  std::string description;  // one line
  std::string source;       // the paper or note it follows
  PipelineSettings settings;
};

// The direct-light presets, `--preset all`.
const std::vector<Preset>& AllPresets();
// The ReSTIR GI presets (issue 41): each a direct-light preset with one bounce of indirect light resampled by
// ReSTIR GI. Not in `all`: a run's presets share one reference, so they must model the same bounces.
const std::vector<Preset>& IndirectPresets();
// nullptr when unknown. Knows AllPresets, IndirectPresets and "A+B", A's direct light with B's indirect light (B
// one that models indirect light).
const Preset* FindPreset(const std::string& name);
// "unknown preset 'x'" with the nearest name or the list of them: the body of every message about one.
std::string UnknownPresetMessage(const std::string& name);
// Throws InputError naming the file and the JSON path (/render/presets/i) of the first unknown preset the
// sequence's render.presets names: validate and run report the same line.
void CheckSequencePresets(const Sequence& seq);
// Human-readable listing for `restir-sim presets`.
std::string DescribePresets();

}  // namespace restir
