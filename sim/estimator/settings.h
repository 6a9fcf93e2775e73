// Every field of PipelineSettings by its dotted name ("temporal.maxHistory"), for `--set KEY=VALUE`, run.json
// and `restir-sim presets`. One table, so a new field is printable, recordable and overridable at once.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "sim/estimator/pipeline.h"

namespace restir {

// (name, value) for every field, in a fixed order.
std::vector<std::pair<std::string, std::string>> SettingsToStrings(const PipelineSettings& settings);

// Sets one field from text. Throws InputError naming the key (with the nearest known key) or the bad value.
void ApplySetting(PipelineSettings& settings, const std::string& key, const std::string& value);

// Applies "KEY=VALUE".
void ApplySettingAssignment(PipelineSettings& settings, const std::string& assignment);

}  // namespace restir
