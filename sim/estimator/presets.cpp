#include "sim/estimator/presets.h"

#include <algorithm>
#include <deque>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "sim/estimator/settings.h"
#include "sim/util/text.h"

namespace restir {

namespace {

Preset Make(const std::string& name, const std::string& description, const std::string& source,
            void (*configure)(PipelineSettings&)) {
  Preset p;
  p.name = name;
  p.description = description;
  p.source = source;
  configure(p.settings);
  return p;
}

// No reuse, then temporal reuse alone: seed 003's baselines.
std::vector<Preset> BaselinePresets() {
  return {
      Make("ris", "no reuse: streaming RIS over 32 power-sampled light candidates, one final shadow ray",
           "seed 003 §1 (baseline); Talbot et al. 2005",
           [](PipelineSettings&) {}),
      Make("temporal",
           "RIS plus temporal reuse of the reprojected reservoir with seed 003's validation list and merge "
           "weight currentTarget * W_prev * min(c_prev, maxHistory) (uniform MIS), final shadow ray",
           "seed 003 §3-5 (ReSTIR DI - 02 - Temporal Reuse)",
           [](PipelineSettings& s) {
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kUniform;
             s.temporal.bias = BiasCorrection::kBasic;
             s.temporal.targetRatioClamp = true;
           }),
  };
}

// Bitterli 2020's biased ReSTIR and seed 000's visibility reuse: no ray-traced bias correction.
std::vector<Preset> BiasedPresets() {
  return {
      Make("restir-biased",
           "Bitterli 2020 biased ReSTIR: initial visibility, temporal + 5 spatial neighbours, uniform MIS",
           "Bitterli et al. 2020, Spatiotemporal reservoir resampling, biased variant",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kUniform;
             s.temporal.bias = BiasCorrection::kNone;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kUniform;
             s.spatial.bias = BiasCorrection::kNone;
             s.spatial.neighbours = 5;
           }),
      Make("restir-vis",
           "seed 000 Algorithm 1, previous method: visibility reuse keeping V of the selected sample, "
           "confidence-weighted balance MIS, no final shadow ray",
           "seed 000 Algorithm 1 (Wyman & Panteleev 2021 visibility reuse)",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kBalance;
             s.temporal.bias = BiasCorrection::kBasic;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kBalance;
             s.spatial.bias = BiasCorrection::kBasic;
             s.spatial.neighbours = 5;
             s.shade.visibility = VisibilityReuse::kSelected;
           }),
      Make("restir-wisvis",
           "seed 000 Algorithm 1 with the WIS visibility estimate V_X = sum V_i w_i / sum w_i, no final ray",
           "seed 000 Eq. 4, Algorithm 1",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kBalance;
             s.temporal.bias = BiasCorrection::kBasic;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kBalance;
             s.spatial.bias = BiasCorrection::kBasic;
             s.spatial.neighbours = 5;
             s.shade.visibility = VisibilityReuse::kWeighted;
           }),
  };
}

// Unbiased ReSTIR: ray-traced bias correction under pairwise, balance or stochastic pairwise MIS.
std::vector<Preset> UnbiasedPresets() {
  return {
      Make("restir-unbiased",
           "unbiased ReSTIR: initial visibility, temporal + 5 spatial neighbours, defensive pairwise MIS with "
           "ray-traced bias correction (previous frame's scene for the temporal input), final shadow ray",
           "seed 004 Eq. 11 (defensive pairwise MIS); Lin et al. 2022 GRIS",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kPairwise;
             s.temporal.bias = BiasCorrection::kRayTraced;
             s.temporal.sampleChecks = false;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kPairwise;
             s.spatial.bias = BiasCorrection::kRayTraced;
             s.spatial.neighbours = 5;
           }),
      Make("restir-balance",
           "unbiased ReSTIR with the confidence-weighted generalized balance heuristic (O(k^2) targets), "
           "ray-traced bias correction, final shadow ray",
           "seed 000 Eq. 3 (generalized balance MIS); Talbot 2005",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kBalance;
             s.temporal.bias = BiasCorrection::kRayTraced;
             s.temporal.sampleChecks = false;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kBalance;
             s.spatial.bias = BiasCorrection::kRayTraced;
             s.spatial.neighbours = 5;
           }),
      Make("restir-spmis",
           "unbiased ReSTIR whose spatial reuse is stochastic pairwise MIS over screen-space cells: neighbour cell "
           "by weighted reservoir search (from 30 px at 1080 rows), N = 5 draws by contribution (10 where "
           "temporal reuse failed, as restir-unbiased's neighbours), N_c = 5 canonical draws by confidence, "
           "min(1, N/M) confidence scaling; temporal as restir-unbiased",
           "seed 004 (Hedstrom et al. 2026, Stochastic Pairwise MIS), Eq. 15-19, §4.3, §5",
           [](PipelineSettings& s) {
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kPairwise;
             s.temporal.bias = BiasCorrection::kRayTraced;
             s.temporal.sampleChecks = false;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kStochasticPairwise;
             s.spatial.bias = BiasCorrection::kRayTraced;
             s.spatial.stochastic.draws = 5;
             s.spatial.stochastic.canonicalDraws = 5;
             // docs/studies/spmis_ablation.md: never worse than the paper's uniform draws, at the same cost, and
             // each draw's term is bounded (C / N_c instead of M c_j / N_c).
             s.spatial.stochastic.canonicalPdf = CanonicalPdf::kConfidence;
           }),
  };
}

// RTXDI 3.1's library defaults, where they map onto these passes.
std::vector<Preset> RtxdiPresets() {
  return {
      Make("rtxdi-defaults",
           "RTXDI 3.1's library defaults where they map: 8 uniformly chosen local-light, 1 sun, 1 environment and 1 "
           "BSDF candidates (BRDF cutoff 1e-4), initial visibility; temporal reuse (history 20, permutation "
           "sampling, boiling filter at strength 0.2) and 1 spatial neighbour (8 where temporal reuse failed, "
           "radius 32 px), both with the balance weights and unshadowed targets of RTXDI's Basic bias correction, "
           "normal 0.5 / depth 0.1 thresholds; final shadow ray whose visibility is reused up to 4 frames and 16 px. "
           "Not modelled: ReGIR",
           "RTXDI 3.1 rtxdi-sdk ReSTIRDI.cpp GetDefaultReSTIRDI*Params (docs/architecture.md, \"rtxdi-defaults\")",
           [](PipelineSettings& s) {
             s.initial.candidates = 8;
             s.initial.lightSelection = LightSelection::kUniform;
             s.initial.sunCandidates = 1;
             s.initial.environmentCandidates = 1;
             s.initial.brdfCandidates = 1;
             s.initial.brdfCutoff = 1e-4f;
             s.initial.visibility = true;
             s.temporal.enabled = true;
             s.temporal.mis = MisFamily::kBalance;
             s.temporal.bias = BiasCorrection::kBasic;
             s.temporal.maxHistory = 20.0f;
             s.temporal.permutation = true;
             s.temporal.boilingFilterStrength = 0.2f;
             s.spatial.enabled = true;
             s.spatial.mis = MisFamily::kBalance;
             s.spatial.bias = BiasCorrection::kBasic;
             s.spatial.neighbours = 1;
             s.spatial.disocclusionNeighbours = 8;
             s.spatial.radius = 32.0f;
             s.spatial.normalThreshold = 0.5f;
             s.spatial.depthThreshold = 0.1f;
             s.shade.reuseFinalVisibility = true;
             s.shade.finalVisibilityMaxAge = 4;
             s.shade.finalVisibilityMaxDistance = 16.0f;
           }),
  };
}

// ReSTIR GI (issue 41) over a direct-light preset: `direct`'s settings with one bounce of indirect light whose path
// vertices are resampled as `configure` sets indirect.temporal, spatial and shade.
Preset WithIndirect(const std::string& direct, const std::string& name, const std::string& description,
                    const std::string& source, void (*configure)(IndirectParams&)) {
  // From AllPresets alone: FindPreset would reach IndirectPresets, whose list this call is building.
  const auto it = std::find_if(AllPresets().begin(), AllPresets().end(),
                               [&](const Preset& q) { return q.name == direct; });
  if (it == AllPresets().end()) throw std::logic_error("WithIndirect: no direct-light preset '" + direct + "'");
  Preset p = *it;
  p.name = name;
  p.description = description + "; direct light as " + direct;
  p.source = source;
  p.settings.indirect.bounces = 1;
  p.settings.indirect.reuse = true;
  configure(p.settings.indirect);
  return p;
}

// Each GI preset's indirect passes as the unbiased direct-light presets set theirs: pairwise MIS with ray-traced
// bias correction in temporal reuse (the previous frame's scene), and in spatial reuse over `spatial`'s family.
void UnbiasedIndirect(IndirectParams& in, MisFamily spatial) {
  in.temporal.enabled = true;
  in.temporal.mis = MisFamily::kPairwise;
  in.temporal.bias = BiasCorrection::kRayTraced;
  in.temporal.sampleChecks = false;
  in.spatial.enabled = true;
  in.spatial.mis = spatial;
  in.spatial.bias = BiasCorrection::kRayTraced;
  in.spatial.neighbours = 5;
  in.spatial.stochastic.draws = 5;
  in.spatial.stochastic.canonicalDraws = 5;
  in.spatial.stochastic.canonicalPdf = CanonicalPdf::kConfidence;
}

std::vector<Preset> MakeIndirectPresets() {
  return {
      WithIndirect("rtxdi-defaults", "restir-gi",
                   "ReSTIR GI with RTXDI's defaults for it: one path a pixel, its first vertex x2 resampled by "
                   "the reconnection shift; temporal reuse (history 8, boiling filter 0.2) and 2 spatial "
                   "neighbours (radius 32 px, normal 0.6 / depth 0.1), balance weights with unshadowed targets "
                   "(RTXDI's Basic bias correction), final shadow ray",
                   "Ouyang et al. 2021, ReSTIR GI; RTXDI rtxdi-sdk ReSTIRGI.cpp GetDefaultReSTIRGI*Params",
                   [](IndirectParams& in) {
                     in.temporal.enabled = true;
                     in.temporal.mis = MisFamily::kBalance;
                     in.temporal.bias = BiasCorrection::kBasic;
                     in.temporal.maxHistory = 8.0f;
                     in.temporal.boilingFilterStrength = 0.2f;
                     in.spatial.enabled = true;
                     in.spatial.mis = MisFamily::kBalance;
                     in.spatial.bias = BiasCorrection::kBasic;
                     in.spatial.neighbours = 2;
                     in.spatial.radius = 32.0f;
                     in.spatial.normalThreshold = 0.6f;
                     in.spatial.depthThreshold = 0.1f;
                   }),
      WithIndirect("restir-unbiased", "restir-gi-unbiased",
                   "unbiased ReSTIR GI: x2 reused by the reconnection shift with defensive pairwise MIS and "
                   "ray-traced bias correction, temporal + 5 spatial neighbours, final shadow ray",
                   "Ouyang et al. 2021; seed 004 Eq. 11 (pairwise MIS); Lin et al. 2022 GRIS §7 (shifts)",
                   [](IndirectParams& in) { UnbiasedIndirect(in, MisFamily::kPairwise); }),
      WithIndirect("restir-spmis", "restir-gi-spmis",
                   "unbiased ReSTIR GI whose spatial reuse is stochastic pairwise MIS over screen-space cells (5 "
                   "draws, 5 canonical draws by confidence), temporal as restir-gi-unbiased",
                   "seed 004 (Hedstrom et al. 2026) in its own regime: path reuse; Ouyang et al. 2021",
                   [](IndirectParams& in) { UnbiasedIndirect(in, MisFamily::kStochasticPairwise); }),
  };
}

// "A+B": A's direct light with B's indirect light, as an engine shades both (issue 41); nullptr unless both are
// known and B models indirect light.
const Preset* CombinedPreset(const std::string& name) {
  const size_t plus = name.find('+');
  if (plus == std::string::npos || name.find('+', plus + 1) != std::string::npos) return nullptr;
  const Preset* direct = FindPreset(name.substr(0, plus));
  const Preset* indirect = FindPreset(name.substr(plus + 1));
  if (!direct || !indirect || indirect->settings.indirect.bounces == 0) return nullptr;
  static std::mutex mutex;
  static std::deque<Preset> made;  // stable addresses, one entry per combination asked for
  const std::lock_guard<std::mutex> lock(mutex);
  for (const Preset& p : made)
    if (p.name == name) return &p;
  Preset p = *direct;
  p.name = name;
  p.description = direct->name + "'s direct light with " + indirect->name + "'s indirect light";
  p.source = direct->source + "; " + indirect->source;
  p.settings.indirect = indirect->settings.indirect;
  made.push_back(p);
  return &made.back();
}

}  // namespace

const std::vector<Preset>& IndirectPresets() {
  static const std::vector<Preset> presets = MakeIndirectPresets();
  return presets;
}

const std::vector<Preset>& AllPresets() {
  static const std::vector<Preset> presets = [] {
    std::vector<Preset> all;
    for (std::vector<Preset> (*family)() : {BaselinePresets, BiasedPresets, UnbiasedPresets, RtxdiPresets})
      for (Preset& p : family()) all.push_back(std::move(p));
    return all;
  }();
  return presets;
}

const Preset* FindPreset(const std::string& name) {
  for (const Preset& p : AllPresets())
    if (p.name == name) return &p;
  for (const Preset& p : IndirectPresets())
    if (p.name == name) return &p;
  return CombinedPreset(name);
}

std::string UnknownPresetMessage(const std::string& name) {
  std::vector<std::string> names;
  for (const Preset& p : AllPresets()) names.push_back(p.name);
  for (const Preset& p : IndirectPresets()) names.push_back(p.name);
  const size_t plus = name.find('+');
  if (plus != std::string::npos) {  // "A+B": say which half is wrong
    const std::string a = name.substr(0, plus), b = name.substr(plus + 1);
    if (b.find('+') != std::string::npos) return "preset '" + name + "' combines more than two presets";
    if (!FindPreset(a)) return "unknown preset '" + a + "' in '" + name + "'" + Suggestion(a, names);
    if (!FindPreset(b)) return "unknown preset '" + b + "' in '" + name + "'" + Suggestion(b, names);
    std::string gi;
    for (const Preset& p : IndirectPresets()) gi += (gi.empty() ? "" : ", ") + p.name;
    return "preset '" + name + "': '" + b + "' models no indirect light, so it has none to give '" + a +
           "' (after '+' name one that does: " + gi + ")";
  }
  return "unknown preset '" + name + "'" + Suggestion(name, names);
}

std::string DescribePresets() {
  std::ostringstream o;
  std::vector<const Preset*> listed;
  for (const Preset& p : AllPresets()) listed.push_back(&p);
  for (const Preset& p : IndirectPresets()) listed.push_back(&p);
  for (const Preset* preset : listed) {
    const Preset& p = *preset;
    o << p.name << "\n  " << p.description << "\n  source: " << p.source << "\n ";
    int col = 2;
    for (const auto& [key, value] : SettingsToStrings(p.settings)) {
      const std::string item = " " + key + "=" + value;
      if (col + item.size() > 110) o << "\n ", col = 2;
      o << item;
      col += static_cast<int>(item.size());
    }
    o << "\n\n";
  }
  return o.str();
}

void CheckSequencePresets(const Sequence& seq) {
  for (size_t i = 0; i < seq.defaults.presets.size(); ++i) {
    if (FindPreset(seq.defaults.presets[i])) continue;
    throw InputError(seq.path + ": error at /render/presets/" + std::to_string(i) + ": " +
                     UnknownPresetMessage(seq.defaults.presets[i]));
  }
}

}  // namespace restir
