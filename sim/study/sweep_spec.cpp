// Reading a sweep file and planning its jobs (sim/study/sweep.h).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "sim/util/hash.h"
#include "sim/util/input_file.h"
#include "sim/util/json_reader.h"
#include "sim/estimator/presets.h"
#include "sim/scene/sequence.h"
#include "sim/estimator/settings.h"
#include "sim/study/sweep.h"
#include "sim/util/text.h"

namespace restir {

namespace {

namespace fs = std::filesystem;

// Jobs one sweep may plan: a Slurm array's default MaxArraySize is 1001, so a study is split well before this.
constexpr size_t kMaxJobs = 100000;
// Seeds per sequence: the merge holds one open file per seed of a configuration (the usual limit is 1024).
constexpr int64_t kMaxSeeds = 512;

// A sweep file being read: JsonReader's located errors, plus what only a sweep has (settings and presets).
class SweepReader : public JsonReader {
 public:
  using JsonReader::JsonReader;

  // A setting's value as --set takes it: numbers, booleans and strings.
  std::string SettingValue(const Json& v, const std::string& pointer) const {
    if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
    // dump() spells a number in the fewest digits that read back to it: 0.1234567 stays 0.1234567.
    if (v.is_number()) return v.dump();
    if (v.is_string()) return v.get<std::string>();
    Fail(pointer, "expected a number, a boolean or a string");
  }

  const Preset& PresetNamed(const Json& v, const std::string& pointer) const {
    const std::string name = Name(v, pointer);
    if (const Preset* p = FindPreset(name)) return *p;
    Fail(pointer, UnknownPresetMessage(name));
  }

  // Applies KEY=VALUE to a copy of the preset's settings, so a bad key or value is reported where it is written.
  void CheckSetting(const Preset& preset, const std::string& key, const std::string& value,
                    const std::string& pointer) const {
    PipelineSettings s = preset.settings;
    try {
      ApplySetting(s, key, value);
    } catch (const InputError& e) {
      Fail(pointer, e.what());
    }
  }

};

// A run directory name: the characters a file name can always hold, never "." or ".." or hidden (a leading dot),
// and short enough for any file system (a long grid name keeps its start and a hash of the whole).
std::string SafeName(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '=') ? c : '_';
  if (out.empty() || out[0] == '.') out = "_" + out;
  constexpr size_t kMaxName = 120;
  if (out.size() > kMaxName) out = out.substr(0, kMaxName - 17) + "~" + HexHash(Fnv1a(s.data(), s.size()));
  return out;
}

// "sequence" (one file) or "sequences" (a list), each relative to the sweep file, loaded once here so that a bad
// sequence is reported before any job runs, and so each job can be checked against its sequence's content.
void ReadSequences(const SweepReader& r, const Json& root, const std::string& sweepPath,
                   std::vector<SweepSequence>& out) {
  if (root.contains("sequence") == root.contains("sequences"))
    r.Fail("", "give 'sequence' (one file) or 'sequences' (a list), exactly one of them");
  std::vector<std::pair<std::string, std::string>> paths;  // (pointer, path as written)
  if (root.contains("sequence")) {
    paths.emplace_back("/sequence", r.Name(root["sequence"], "/sequence"));
  } else {
    const Json& list = r.AsArray(root["sequences"], "/sequences", true);
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string p = PointerChild("/sequences", i);
      paths.emplace_back(p, r.Name(list[i], p));
    }
  }
  std::set<std::string> names;
  for (const auto& [pointer, written] : paths) {
    const fs::path p(written);
    SweepSequence q;
    q.path = p.is_absolute() ? p.string() : (fs::path(sweepPath).parent_path() / p).string();
    std::error_code ec;
    if (!fs::is_regular_file(q.path, ec)) r.Fail(pointer, "no sequence file '" + q.path + "'");
    q.name = SafeName(fs::path(q.path).stem().string());
    if (!names.insert(q.name).second)
      r.Fail(pointer, "two sequences named '" + q.name + "' (their files' stems name their runs): rename one");
    const Sequence seq = LoadSequence(q.path);  // InputError names the sequence file, line and column
    q.contentHash = seq.contentHash;
    q.seeds = {seq.seed};
    out.push_back(std::move(q));
  }
}

// "seed" (one), "seeds" (a list) or "seedCount" (N seeds from "seed", or from each sequence's own seed).
void ReadSeeds(const SweepReader& r, const Json& root, std::vector<SweepSequence>& sequences) {
  if (root.contains("seeds") && (root.contains("seed") || root.contains("seedCount")))
    r.Fail("/seeds", "give 'seeds' (a list) or 'seed' with an optional 'seedCount', not both");
  std::vector<uint32_t> list;
  if (root.contains("seeds")) {
    const Json& s = r.AsArray(root["seeds"], "/seeds", true);
    if (s.size() > kMaxSeeds) r.Fail("/seeds", "more than " + std::to_string(kMaxSeeds) + " seeds");
    std::set<uint32_t> seen;
    for (size_t i = 0; i < s.size(); ++i) {
      const std::string p = PointerChild("/seeds", i);
      const auto v = static_cast<uint32_t>(r.Integer(s[i], p, 0, UINT32_MAX, "seed"));
      if (!seen.insert(v).second) r.Fail(p, "seed " + std::to_string(v) + " is listed twice");
      list.push_back(v);
    }
  }
  int64_t count = 1;
  if (root.contains("seedCount")) count = r.Integer(root["seedCount"], "/seedCount", 1, kMaxSeeds, "seedCount");
  for (SweepSequence& q : sequences) {
    if (!list.empty()) {
      q.seeds = list;
      continue;
    }
    const uint32_t first =
        root.contains("seed") ? static_cast<uint32_t>(r.Integer(root["seed"], "/seed", 0, UINT32_MAX, "seed"))
                              : q.seeds.front();
    if (uint64_t(first) + uint64_t(count) - 1 > UINT32_MAX)
      r.Fail(root.contains("seed") ? "/seed" : "/seedCount", "seeds run past 4294967295");
    q.seeds.clear();
    for (int64_t k = 0; k < count; ++k) q.seeds.push_back(first + static_cast<uint32_t>(k));
  }
}

// "resolution", "frames" and the reference ("referenceSpp" or "referenceError"): what every run shares.
void ReadRunOptions(const SweepReader& r, const Json& root, RunOptions& b) {
  if (root.contains("resolution")) {
    const Json& v = root["resolution"];
    if (!v.is_array() || v.size() != 2) r.Fail("/resolution", "expected [width, height]");
    b.width = static_cast<int>(r.Integer(v[0], "/resolution/0", 1, 16384, "width"));
    b.height = static_cast<int>(r.Integer(v[1], "/resolution/1", 1, 16384, "height"));
  }
  if (root.contains("frames")) {
    const Json& v = root["frames"];
    if (!v.is_array() || v.size() != 2) r.Fail("/frames", "expected [first, end) as [A, B]");
    b.frameBegin = static_cast<int>(r.Integer(v[0], "/frames/0", 0, 1 << 20, "first frame"));
    b.frameEnd = static_cast<int>(r.Integer(v[1], "/frames/1", b.frameBegin + 1, 1 << 20, "end frame"));
  }
  if (root.contains("referenceSpp"))
    b.referenceSpp = static_cast<int>(r.Integer(root["referenceSpp"], "/referenceSpp", 1, 1 << 20, "referenceSpp"));
  if (root.contains("referenceError")) {
    if (root.contains("referenceSpp")) r.Fail("/referenceError", "give 'referenceSpp' or 'referenceError', not both");
    b.referenceError = r.Number(root["referenceError"], "/referenceError");
    if (!(b.referenceError >= 1e-4 && b.referenceError <= 1.0))
      r.Fail("/referenceError", "expected a relative standard error in [0.0001, 1]");
  }
}

// The configurations read so far. Their names, made safe for a directory, name the runs, so each is unique.
class ConfigList {
 public:
  ConfigList(const SweepReader& r, std::vector<SweepConfig>& configs) : r_(r), configs_(configs) {}

  void Add(SweepConfig c, const std::string& pointer) {
    c.name = SafeName(c.name);
    if (!names_.insert(c.name).second) r_.Fail(pointer, "configuration name '" + c.name + "' is used twice");
    configs_.push_back(std::move(c));
  }

 private:
  const SweepReader& r_;
  std::vector<SweepConfig>& configs_;
  std::set<std::string> names_;
};

// A grid's axes: (setting, its values as --set takes them), in file order.
using GridAxes = std::vector<std::pair<std::string, std::vector<std::string>>>;

// "grid": each value is checked against every known preset of `presets` (an unknown one is reported later,
// where it is named).
GridAxes ReadGridAxes(const SweepReader& r, const Json& root, const Json& presets) {
  GridAxes axes;
  const Json& g = root["grid"];
  if (!g.is_object()) r.Fail("/grid", "expected an object of setting -> array of values");
  for (const auto& [key, values] : g.items()) {
    const std::string gp = PointerChild("/grid", key);
    if (!values.is_array() || values.empty()) r.Fail(gp, "expected a non-empty array of values");
    std::vector<std::string> vs;
    for (size_t k = 0; k < values.size(); ++k) {
      const std::string vp = PointerChild(gp, k);
      vs.push_back(r.SettingValue(values[k], vp));
      for (size_t i = 0; i < presets.size(); ++i)
        if (const Preset* p = FindPreset(presets[i].is_string() ? presets[i].get<std::string>() : ""))
          r.CheckSetting(*p, key, vs.back(), vp);
    }
    axes.emplace_back(key, vs);
  }
  return axes;
}

// Combination `c` of the axes (the last axis fastest) on a preset, named "<preset>_<key>=<value>_...".
SweepConfig GridConfig(const Preset& preset, const GridAxes& axes, size_t c) {
  SweepConfig cfg;
  cfg.preset = preset.name;
  cfg.name = preset.name;
  size_t rest = c;
  std::vector<std::string> parts;
  for (size_t a = axes.size(); a-- > 0;) {
    const size_t k = rest % axes[a].second.size();
    rest /= axes[a].second.size();
    parts.insert(parts.begin(), axes[a].first + "=" + axes[a].second[k]);
  }
  cfg.overrides = parts;
  for (const std::string& part : parts) cfg.name += "_" + part;
  return cfg;
}

// The grid: every preset of "presets" with every combination of the grid's values (first key slowest).
void ReadGridConfigs(const SweepReader& r, const Json& root, ConfigList& configs) {
  if (root.contains("grid") && !root.contains("presets")) r.Fail("/grid", "a grid needs a 'presets' list");
  if (!root.contains("presets")) return;
  const Json& ps = root["presets"];
  if (!ps.is_array() || ps.empty()) r.Fail("/presets", "expected a non-empty array of preset names");
  const GridAxes axes = root.contains("grid") ? ReadGridAxes(r, root, ps) : GridAxes{};
  for (size_t i = 0; i < ps.size(); ++i) {
    const std::string pp = PointerChild("/presets", i);
    const Preset& preset = r.PresetNamed(ps[i], pp);
    size_t combos = 1;
    for (const auto& a : axes) {
      if (combos > 4096 / a.second.size()) r.Fail("/grid", "more than 4096 combinations");
      combos *= a.second.size();
    }
    for (size_t c = 0; c < combos; ++c) configs.Add(GridConfig(preset, axes, c), pp);
  }
}

// "configs": explicit {name, preset, set} configurations, after the grid's.
void ReadExplicitConfigs(const SweepReader& r, const Json& root, ConfigList& configs) {
  if (!root.contains("configs")) return;
  const Json& cs = root["configs"];
  if (!cs.is_array()) r.Fail("/configs", "expected an array of {name, preset, set}");
  for (size_t i = 0; i < cs.size(); ++i) {
    const std::string cp = PointerChild("/configs", i);
    const Json& c = cs[i];
    if (!c.is_object()) r.Fail(cp, "expected an object {name, preset, set}");
    r.CheckKeys(c, cp, {"name", "preset", "set"});
    r.Need(c, cp, "name");
    r.Need(c, cp, "preset");
    SweepConfig cfg;
    cfg.name = r.Name(c["name"], cp + "/name");
    const Preset& preset = r.PresetNamed(c["preset"], cp + "/preset");
    cfg.preset = preset.name;
    if (c.contains("set")) {
      if (!c["set"].is_object()) r.Fail(cp + "/set", "expected an object of setting -> value");
      for (const auto& [key, value] : c["set"].items()) {
        const std::string vp = PointerChild(cp + "/set", key);
        const std::string v = r.SettingValue(value, vp);
        r.CheckSetting(preset, key, v, vp);
        cfg.overrides.push_back(key + "=" + v);
      }
    }
    configs.Add(cfg, cp + "/name");
  }
}

}  // namespace

SweepSpec LoadSweep(const std::string& path) {
  // A FIFO or /dev/zero given as the sweep file is refused, not read forever (DESIGN §10).
  const SweepReader r(path, ReadInputFile(path, size_t(16) << 20, "sweep file"));
  const Json& root = r.AsObject(r.Root(), "");
  r.CheckKeys(root, "", {"sequence", "sequences", "resolution", "frames", "seed", "seeds", "seedCount",
                         "referenceSpp", "referenceError", "presets", "grid", "configs"});

  SweepSpec spec;
  spec.path = path;
  ReadSequences(r, root, path, spec.sequences);
  ReadRunOptions(r, root, spec.base);
  ReadSeeds(r, root, spec.sequences);
  spec.base.writeImages = false;
  spec.base.report = false;  // the sweep writes its own reports

  ConfigList configs(r, spec.configs);
  ReadGridConfigs(r, root, configs);
  ReadExplicitConfigs(r, root, configs);
  if (spec.configs.empty()) r.Fail("", "no configurations: give 'presets' (with an optional 'grid') or 'configs'");
  size_t jobs = 0;
  for (const SweepSequence& q : spec.sequences) jobs += q.seeds.size() * spec.configs.size();
  if (jobs > kMaxJobs) r.Fail("", "more than " + std::to_string(kMaxJobs) + " jobs");
  return spec;
}

std::vector<SweepJob> PlanSweep(const SweepSpec& spec) {
  std::vector<SweepJob> jobs;
  for (size_t q = 0; q < spec.sequences.size(); ++q)
    for (size_t c = 0; c < spec.configs.size(); ++c)
      for (uint32_t seed : spec.sequences[q].seeds) {
        SweepJob j;
        j.index = jobs.size();
        j.sequence = q;
        j.config = c;
        j.seed = seed;
        j.id = spec.sequences[q].name + "/" + spec.configs[c].name + "/seed-" + std::to_string(seed);
        j.dir = "runs/" + j.id;
        jobs.push_back(std::move(j));
      }
  return jobs;
}

const SweepJob& FindSweepJob(const SweepSpec& spec, const std::vector<SweepJob>& jobs, const std::string& idOrIndex) {
  // An unset array variable (SLURM_ARRAY_TASK_ID outside an array) must not run the whole study in its place.
  if (idOrIndex.empty())
    throw InputError(spec.path + ": error: --job was given an empty id (an array task passes its index, 0 to " +
                     std::to_string(jobs.size() - 1) + ", or an id from --plan)");
  const bool number = !idOrIndex.empty() && idOrIndex.size() <= 9 &&
                      std::all_of(idOrIndex.begin(), idOrIndex.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (number) {
    const size_t k = std::stoul(idOrIndex);
    if (k < jobs.size()) return jobs[k];
    throw InputError(spec.path + ": error: no job " + idOrIndex + " (the plan has jobs 0 to " +
                     std::to_string(jobs.size() - 1) + ")");
  }
  for (const SweepJob& j : jobs)
    if (j.id == idOrIndex) return j;
  throw InputError(spec.path + ": error: no job '" + idOrIndex + "' (see --plan)");
}

std::string SweepJobLine(const SweepSpec& spec, const SweepJob& job) {
  const SweepConfig& c = spec.configs[job.config];
  const nlohmann::ordered_json j = {{"index", job.index},
                                    {"id", job.id},
                                    {"sequence", spec.sequences[job.sequence].name},
                                    {"sequencePath", spec.sequences[job.sequence].path},
                                    {"config", c.name},
                                    {"preset", c.preset},
                                    {"set", c.overrides},
                                    {"seed", job.seed},
                                    {"dir", job.dir}};
  return j.dump();
}

std::string SlurmArraySpec(const std::vector<SweepJob>& jobs) {
  std::vector<size_t> ids;
  for (const SweepJob& j : jobs) ids.push_back(j.index);
  std::sort(ids.begin(), ids.end());
  std::string out;
  for (size_t k = 0; k < ids.size();) {
    size_t e = k;
    while (e + 1 < ids.size() && ids[e + 1] == ids[e] + 1) ++e;
    if (!out.empty()) out += ",";
    out += std::to_string(ids[k]);
    if (e > k) out += "-" + std::to_string(ids[e]);
    k = e + 1;
  }
  return out;
}

}  // namespace restir
