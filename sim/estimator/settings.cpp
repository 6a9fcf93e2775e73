#include "sim/estimator/settings.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <type_traits>

#include "core/gris.h"
#include "sim/estimator/passes/stochastic_pairwise_reuse.h"
#include "sim/util/input_error.h"
#include "sim/util/text.h"

namespace restir {

namespace {

template <typename E>
struct EnumNames {
  std::vector<std::pair<E, const char*>> names;
};

const EnumNames<MisFamily> kMisNames{[] {
  std::vector<std::pair<MisFamily, const char*>> v;
  for (MisFamily f : {MisFamily::kUniform, MisFamily::kZ, MisFamily::kBalance, MisFamily::kPairwise,
                      MisFamily::kStochasticPairwise})
    v.emplace_back(f, MisFamilyName(f));  // core/mis.h spells them
  return v;
}()};
const EnumNames<BiasCorrection> kBiasNames{
    {{BiasCorrection::kNone, "none"}, {BiasCorrection::kBasic, "basic"}, {BiasCorrection::kRayTraced, "raytraced"}}};
const EnumNames<VisibilityReuse> kVisNames{{{VisibilityReuse::kNone, "final-ray"},
                                            {VisibilityReuse::kSelected, "reuse-selected"},
                                            {VisibilityReuse::kWeighted, "wis-estimate"}}};
const EnumNames<LightSelection> kSelNames{{{LightSelection::kPower, "power"}, {LightSelection::kUniform, "uniform"}}};
const EnumNames<CanonicalPdf> kCanonicalPdfNames{
    {{CanonicalPdf::kUniform, "uniform"}, {CanonicalPdf::kConfidence, "confidence"}}};

std::string ToString(int v) { return std::to_string(v); }
std::string ToString(bool v) { return v ? "true" : "false"; }
// The shortest %g form that reads back as the same float: a printed setting (a run's manifest, a sweep's plan)
// must reproduce the run, and defaults such as cellSearchRadius = 30/1080 need more than %g's 6 digits.
std::string ToString(float v) {
  char buf[32];
  for (int precision = 6; precision <= 9; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
    if (std::strtof(buf, nullptr) == v || v != v) break;
  }
  return buf;
}
template <typename E>
std::string ToString(E v, const EnumNames<E>& names) {
  for (const auto& [e, n] : names.names)
    if (e == v) return n;
  return "?";
}

[[noreturn]] void BadValue(const std::string& key, const std::string& value, const std::string& expected) {
  throw InputError("--set: error at " + key + ": '" + value + "' is not " + expected);
}

void Parse(const std::string& key, const std::string& text, int& out) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < 0 || v > 1000000) BadValue(key, text, "an integer in [0, 1000000]");
  out = static_cast<int>(v);
}
void Parse(const std::string& key, const std::string& text, float& out) {
  char* end = nullptr;
  const float v = std::strtof(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < 0.0f) BadValue(key, text, "a finite number >= 0");
  out = v;
}
void Parse(const std::string& key, const std::string& text, bool& out) {
  if (text == "true" || text == "on" || text == "1") out = true;
  else if (text == "false" || text == "off" || text == "0") out = false;
  else BadValue(key, text, "true/false");
}
template <typename E>
void Parse(const std::string& key, const std::string& text, E& out, const EnumNames<E>& names) {
  std::string all;
  for (const auto& [e, n] : names.names) {
    if (text == n) {
      out = e;
      return;
    }
    all += (all.empty() ? "" : ", ") + std::string(n);
  }
  BadValue(key, text, "one of " + all);
}

// The one table: name -> (print, parse) for each field.
struct Field {
  std::string name;
  std::function<std::string(const PipelineSettings&)> get;
  std::function<void(PipelineSettings&, const std::string&, const std::string&)> set;
};

#define RESTIR_FIELD(NAME, MEMBER)                                                                    \
  Field {                                                                                             \
    NAME, [](const PipelineSettings& s) { return ToString(s.MEMBER); },                              \
        [](PipelineSettings& s, const std::string& k, const std::string& v) { Parse(k, v, s.MEMBER); } \
  }
#define RESTIR_ENUM_FIELD(NAME, MEMBER, TABLE)                                                               \
  Field {                                                                                                    \
    NAME, [](const PipelineSettings& s) { return ToString(s.MEMBER, TABLE); },                              \
        [](PipelineSettings& s, const std::string& k, const std::string& v) { Parse(k, v, s.MEMBER, TABLE); } \
  }

const std::vector<Field>& Fields() {
  static const std::vector<Field> fields = {
      RESTIR_FIELD("initial.candidates", initial.candidates),
      RESTIR_ENUM_FIELD("initial.lightSelection", initial.lightSelection, kSelNames),
      RESTIR_FIELD("initial.visibility", initial.visibility),
      RESTIR_FIELD("initial.countCandidates", initial.countCandidates),
      RESTIR_FIELD("initial.sunCandidates", initial.sunCandidates),
      RESTIR_FIELD("initial.environmentCandidates", initial.environmentCandidates),
      RESTIR_FIELD("initial.brdfCandidates", initial.brdfCandidates),
      RESTIR_FIELD("initial.brdfCutoff", initial.brdfCutoff),
      RESTIR_FIELD("temporal.enabled", temporal.enabled),
      RESTIR_ENUM_FIELD("temporal.mis", temporal.mis, kMisNames),
      RESTIR_ENUM_FIELD("temporal.bias", temporal.bias, kBiasNames),
      RESTIR_FIELD("temporal.maxHistory", temporal.maxHistory),
      RESTIR_FIELD("temporal.sampleChecks", temporal.sampleChecks),
      RESTIR_FIELD("temporal.targetRatioClamp", temporal.targetRatioClamp),
      RESTIR_FIELD("temporal.permutation", temporal.permutation),
      RESTIR_FIELD("temporal.boilingFilterStrength", temporal.boilingFilterStrength),
      RESTIR_FIELD("temporal.visibilityShortcut", temporal.visibilityShortcut),
      RESTIR_FIELD("temporal.fusedNeighbours", temporal.fusedNeighbours),
      RESTIR_FIELD("temporal.fusedRadius", temporal.fusedRadius),
      RESTIR_FIELD("spatial.enabled", spatial.enabled),
      RESTIR_ENUM_FIELD("spatial.mis", spatial.mis, kMisNames),
      RESTIR_ENUM_FIELD("spatial.bias", spatial.bias, kBiasNames),
      RESTIR_FIELD("spatial.neighbours", spatial.neighbours),
      RESTIR_FIELD("spatial.disocclusionNeighbours", spatial.disocclusionNeighbours),
      RESTIR_FIELD("spatial.radius", spatial.radius),
      RESTIR_FIELD("spatial.iterations", spatial.iterations),
      RESTIR_FIELD("spatial.normalThreshold", spatial.normalThreshold),
      RESTIR_FIELD("spatial.depthThreshold", spatial.depthThreshold),
      RESTIR_FIELD("spatial.discountNaiveSamples", spatial.discountNaiveSamples),
      RESTIR_FIELD("spatial.draws", spatial.stochastic.draws),
      RESTIR_FIELD("spatial.disocclusionDraws", spatial.stochastic.disocclusionDraws),
      RESTIR_FIELD("spatial.canonicalDraws", spatial.stochastic.canonicalDraws),
      RESTIR_ENUM_FIELD("spatial.canonicalPdf", spatial.stochastic.canonicalPdf, kCanonicalPdfNames),
      RESTIR_FIELD("spatial.cellTile", spatial.stochastic.cellTile),
      RESTIR_FIELD("spatial.normalBins", spatial.stochastic.normalBins),
      RESTIR_FIELD("spatial.cellSearchIterations", spatial.stochastic.cellSearchIterations),
      RESTIR_FIELD("spatial.cellSearchRadius", spatial.stochastic.cellSearchRadius),
      RESTIR_FIELD("spatial.cellSearchGrowth", spatial.stochastic.cellSearchGrowth),
      RESTIR_FIELD("spatial.confidenceScaling", spatial.stochastic.confidenceScaling),
      RESTIR_ENUM_FIELD("shade.visibility", shade.visibility, kVisNames),
      RESTIR_FIELD("shade.reuseFinalVisibility", shade.reuseFinalVisibility),
      RESTIR_FIELD("shade.finalVisibilityMaxAge", shade.finalVisibilityMaxAge),
      RESTIR_FIELD("shade.finalVisibilityMaxDistance", shade.finalVisibilityMaxDistance),
      RESTIR_FIELD("shade.discardInvisibleSamples", shade.discardInvisibleSamples),
      RESTIR_FIELD("indirect.bounces", indirect.bounces),
      RESTIR_FIELD("indirect.reuse", indirect.reuse),
      RESTIR_FIELD("indirect.temporal.enabled", indirect.temporal.enabled),
      RESTIR_ENUM_FIELD("indirect.temporal.mis", indirect.temporal.mis, kMisNames),
      RESTIR_ENUM_FIELD("indirect.temporal.bias", indirect.temporal.bias, kBiasNames),
      RESTIR_FIELD("indirect.temporal.maxHistory", indirect.temporal.maxHistory),
      RESTIR_FIELD("indirect.temporal.sampleChecks", indirect.temporal.sampleChecks),
      RESTIR_FIELD("indirect.temporal.targetRatioClamp", indirect.temporal.targetRatioClamp),
      RESTIR_FIELD("indirect.temporal.boilingFilterStrength", indirect.temporal.boilingFilterStrength),
      RESTIR_FIELD("indirect.temporal.permutation", indirect.temporal.permutation),
      RESTIR_FIELD("indirect.spatial.enabled", indirect.spatial.enabled),
      RESTIR_ENUM_FIELD("indirect.spatial.mis", indirect.spatial.mis, kMisNames),
      RESTIR_ENUM_FIELD("indirect.spatial.bias", indirect.spatial.bias, kBiasNames),
      RESTIR_FIELD("indirect.spatial.neighbours", indirect.spatial.neighbours),
      RESTIR_FIELD("indirect.spatial.disocclusionNeighbours", indirect.spatial.disocclusionNeighbours),
      RESTIR_FIELD("indirect.spatial.radius", indirect.spatial.radius),
      RESTIR_FIELD("indirect.spatial.iterations", indirect.spatial.iterations),
      RESTIR_FIELD("indirect.spatial.normalThreshold", indirect.spatial.normalThreshold),
      RESTIR_FIELD("indirect.spatial.depthThreshold", indirect.spatial.depthThreshold),
      RESTIR_FIELD("indirect.spatial.draws", indirect.spatial.stochastic.draws),
      RESTIR_FIELD("indirect.spatial.canonicalDraws", indirect.spatial.stochastic.canonicalDraws),
      RESTIR_FIELD("indirect.spatial.disocclusionDraws", indirect.spatial.stochastic.disocclusionDraws),
      RESTIR_ENUM_FIELD("indirect.spatial.canonicalPdf", indirect.spatial.stochastic.canonicalPdf,
                        kCanonicalPdfNames),
      RESTIR_FIELD("indirect.spatial.cellTile", indirect.spatial.stochastic.cellTile),
      RESTIR_FIELD("indirect.spatial.normalBins", indirect.spatial.stochastic.normalBins),
      RESTIR_FIELD("indirect.spatial.cellSearchIterations", indirect.spatial.stochastic.cellSearchIterations),
      RESTIR_FIELD("indirect.spatial.cellSearchRadius", indirect.spatial.stochastic.cellSearchRadius),
      RESTIR_FIELD("indirect.spatial.cellSearchGrowth", indirect.spatial.stochastic.cellSearchGrowth),
      RESTIR_FIELD("indirect.spatial.confidenceScaling", indirect.spatial.stochastic.confidenceScaling),
      RESTIR_ENUM_FIELD("indirect.shade.visibility", indirect.shade.visibility, kVisNames),
      RESTIR_FIELD("indirect.shade.discardInvisibleSamples", indirect.shade.discardInvisibleSamples),
  };
  return fields;
}

// The accessor of PipelineSettings' field MEMBER, for const and mutable settings alike.
#define RESTIR_MEMBER(MEMBER) [](auto& s) -> auto& { return s.MEMBER; }

template <typename Access>
SettingBound Bound(const char* key, Access member, double low, double high, const std::string& reason,
                   bool pipeline = false, bool highExclusive = false) {
  using Value = std::remove_cvref_t<decltype(member(std::declval<PipelineSettings&>()))>;
  SettingBound b;
  b.key = key;
  b.low = low;
  b.high = high;
  b.highExclusive = highExclusive;
  b.integer = std::is_integral_v<Value>;
  b.pipeline = pipeline;
  b.reason = reason;
  b.get = [member](const PipelineSettings& s) { return static_cast<double>(member(s)); };
  b.set = [member](PipelineSettings& s, double v) { member(s) = static_cast<Value>(v); };
  return b;
}

std::vector<SettingBound> MakeBounds() {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  constexpr bool kPipeline = true;  // SettingBound::pipeline
  const std::string neighbours = "at most " + std::to_string(kMaxGrisInputs - 1) + " spatial neighbours";
  const std::string candidates =
      "candidate counts must be in [0, " + std::to_string(kMaxCandidatesPerSource) + "]";
  const std::string fused = "fusedNeighbours must be in [0, " + std::to_string(kMaxGrisInputs - 2) +
                            "] and fusedRadius in [0, 1e4]";
  const std::string finalVisibility =
      "finalVisibilityMaxAge must be in [0, 255] and finalVisibilityMaxDistance in [0, 1e6]";
  const std::string draws =
      "draws and canonicalDraws must be in [1, " + std::to_string(kMaxGrisInputs - 1) + "]";
  const std::string cells = "cellTile must be in [1, " + std::to_string(kMaxCellTile) +
                            "], normalBins in [1, 64] and cellSearchIterations in [1, " +
                            std::to_string(kMaxCellSearchIterations) + "]";
  // In the order `--set` always checked them, for the first broken bound is the message: a candidate count of
  // 0 "needs at least 1 candidate" before the range of every candidate count.
  return {
      Bound("spatial.neighbours", RESTIR_MEMBER(spatial.neighbours), -kNone, kMaxGrisInputs - 1, neighbours),
      Bound("spatial.disocclusionNeighbours", RESTIR_MEMBER(spatial.disocclusionNeighbours), -kNone,
            kMaxGrisInputs - 1, neighbours),
      Bound("initial.candidates", RESTIR_MEMBER(initial.candidates), 1, kNone, "needs at least 1 candidate"),
      Bound("initial.candidates", RESTIR_MEMBER(initial.candidates), 0, kMaxCandidatesPerSource, candidates),
      Bound("initial.sunCandidates", RESTIR_MEMBER(initial.sunCandidates), 0, kMaxCandidatesPerSource,
            candidates),
      Bound("initial.environmentCandidates", RESTIR_MEMBER(initial.environmentCandidates), 0,
            kMaxCandidatesPerSource, candidates),
      Bound("initial.brdfCandidates", RESTIR_MEMBER(initial.brdfCandidates), 0, kMaxCandidatesPerSource,
            candidates),
      Bound("temporal.boilingFilterStrength", RESTIR_MEMBER(temporal.boilingFilterStrength), 0, 1,
            "boilingFilterStrength must be in [0, 1] (0: off)"),
      Bound("temporal.fusedNeighbours", RESTIR_MEMBER(temporal.fusedNeighbours), 0, kMaxGrisInputs - 2, fused,
            kPipeline),
      Bound("temporal.fusedRadius", RESTIR_MEMBER(temporal.fusedRadius), 0, 1e4, fused),
      Bound("shade.finalVisibilityMaxAge", RESTIR_MEMBER(shade.finalVisibilityMaxAge), 0, 255,
            finalVisibility),
      Bound("shade.finalVisibilityMaxDistance", RESTIR_MEMBER(shade.finalVisibilityMaxDistance), 0, 1e6,
            finalVisibility),
      Bound("initial.brdfCutoff", RESTIR_MEMBER(initial.brdfCutoff), 0, 1, "brdfCutoff must be in [0, 1)",
            /*pipeline=*/false, /*highExclusive=*/true),
      Bound("spatial.draws", RESTIR_MEMBER(spatial.stochastic.draws), 1, kMaxGrisInputs - 1, draws,
            kPipeline),
      Bound("spatial.disocclusionDraws", RESTIR_MEMBER(spatial.stochastic.disocclusionDraws), 1,
            kMaxGrisInputs - 1, "disocclusionDraws must be in [1, " + std::to_string(kMaxGrisInputs - 1) + "]",
            kPipeline),
      Bound("spatial.canonicalDraws", RESTIR_MEMBER(spatial.stochastic.canonicalDraws), 1, kMaxGrisInputs - 1,
            draws, kPipeline),
      Bound("spatial.cellTile", RESTIR_MEMBER(spatial.stochastic.cellTile), 1, kMaxCellTile, cells,
            kPipeline),
      Bound("spatial.normalBins", RESTIR_MEMBER(spatial.stochastic.normalBins), 1, 64, cells),
      Bound("spatial.cellSearchIterations", RESTIR_MEMBER(spatial.stochastic.cellSearchIterations), 1,
            kMaxCellSearchIterations, cells, kPipeline),
      // In image heights since issue 39: a value in pixels (the old unit, 30 by default) is refused, not run.
      Bound("spatial.cellSearchRadius", RESTIR_MEMBER(spatial.stochastic.cellSearchRadius), 1.0 / 4096.0, 1,
            "cellSearchRadius is in image heights and must be in [1/4096, 1] (the paper's 30 px at 1080 rows is "
            "0.0277778)"),
      // 8: kMaxIndirectBounces (sim/reference/reference_paths.h), which the estimator may not include.
      Bound("indirect.bounces", RESTIR_MEMBER(indirect.bounces), 0, 8, "indirect.bounces must be in [0, 8]"),
      // The GI reservoirs' passes are the direct light's, with the same per-batch scratch.
      Bound("indirect.spatial.neighbours", RESTIR_MEMBER(indirect.spatial.neighbours), -kNone, kMaxGrisInputs - 1,
            neighbours),
      Bound("indirect.spatial.disocclusionNeighbours", RESTIR_MEMBER(indirect.spatial.disocclusionNeighbours),
            -kNone, kMaxGrisInputs - 1, neighbours),
      Bound("indirect.temporal.boilingFilterStrength", RESTIR_MEMBER(indirect.temporal.boilingFilterStrength), 0, 1,
            "boilingFilterStrength must be in [0, 1] (0: off)"),
      Bound("indirect.spatial.draws", RESTIR_MEMBER(indirect.spatial.stochastic.draws), 1, kMaxGrisInputs - 1,
            draws, kPipeline),
      Bound("indirect.spatial.canonicalDraws", RESTIR_MEMBER(indirect.spatial.stochastic.canonicalDraws), 1,
            kMaxGrisInputs - 1, draws, kPipeline),
      Bound("indirect.spatial.disocclusionDraws", RESTIR_MEMBER(indirect.spatial.stochastic.disocclusionDraws), 1,
            kMaxGrisInputs - 1, "disocclusionDraws must be in [1, " + std::to_string(kMaxGrisInputs - 1) + "]",
            kPipeline),
      Bound("indirect.spatial.cellTile", RESTIR_MEMBER(indirect.spatial.stochastic.cellTile), 1, kMaxCellTile,
            cells, kPipeline),
      Bound("indirect.spatial.normalBins", RESTIR_MEMBER(indirect.spatial.stochastic.normalBins), 1, 64, cells),
      Bound("indirect.spatial.cellSearchIterations",
            RESTIR_MEMBER(indirect.spatial.stochastic.cellSearchIterations), 1, kMaxCellSearchIterations, cells,
            kPipeline),
      Bound("indirect.spatial.cellSearchRadius", RESTIR_MEMBER(indirect.spatial.stochastic.cellSearchRadius),
            1.0 / 4096.0, 1,
            "cellSearchRadius is in image heights and must be in [1/4096, 1] (the paper's 30 px at 1080 rows is "
            "0.0277778)"),
  };
}

#undef RESTIR_MEMBER

}  // namespace

bool SettingBound::Holds(const PipelineSettings& settings) const {
  const double v = get(settings);
  return v >= low && (highExclusive ? v < high : v <= high);  // false for NaN
}

const std::vector<SettingBound>& SettingBounds() {
  static const std::vector<SettingBound> bounds = MakeBounds();
  return bounds;
}

const SettingBound* BrokenBound(const PipelineSettings& settings, BoundsScope scope) {
  for (const SettingBound& b : SettingBounds())
    if ((scope == BoundsScope::kAll || b.pipeline) && !b.Holds(settings)) return &b;
  return nullptr;
}

std::vector<std::pair<std::string, std::string>> SettingsToStrings(const PipelineSettings& settings) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const Field& f : Fields()) out.emplace_back(f.name, f.get(settings));
  return out;
}

void ApplySetting(PipelineSettings& settings, const std::string& key, const std::string& value) {
  for (const Field& f : Fields()) {
    if (f.name == key) {
      f.set(settings, key, value);
      // All bounds, not only the key's (the table is short), reported at the key being set.
      if (const SettingBound* b = BrokenBound(settings, BoundsScope::kAll))
        throw InputError("--set: error at " + key + ": " + b->reason);
      return;
    }
  }
  std::vector<std::string> names;
  for (const Field& f : Fields()) names.push_back(f.name);
  throw InputError("--set: error: unknown setting '" + key + "'" + Suggestion(key, names));
}

void ApplySettingAssignment(PipelineSettings& settings, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("--set: error: '" + assignment + "' is not KEY=VALUE");
  ApplySetting(settings, assignment.substr(0, eq), assignment.substr(eq + 1));
}

}  // namespace restir
