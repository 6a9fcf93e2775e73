// libFuzzer target for the metrics.csv reader that `report`, `compare` and `sweep` use (issue 14): any bytes must
// parse or throw InputError with a one-line message; what parses has at least one row, preset names that stay
// inside a run's directory, and one value per numeric column per row. Run by scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_message.h"
#include "sim/metrics/metrics_csv.h"
#include "sim/scene/sequence.h"  // InputError

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const restir::MetricsTable t = restir::ParseMetricsCsv(text, "fuzz.csv");
    if (t.presets.empty()) __builtin_trap();
    for (const restir::PresetSeries& p : t.presets) {
      if (p.name.empty() || p.name[0] == '.' || p.name.find('/') != std::string::npos) __builtin_trap();
      if (p.values.size() != t.columns.size() || p.imageHashes.size() != p.frames.size()) __builtin_trap();
      for (const auto& column : p.values)
        if (column.size() != p.frames.size()) __builtin_trap();
    }
  } catch (const restir::InputError& e) {
    const std::string message = e.what();
    if (!IsOneCleanLine(message)) __builtin_trap();
  }
  return 0;
}
