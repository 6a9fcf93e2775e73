#include "sim/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "sim/atomic_file.h"
#include "sim/input_file.h"
#include "sim/json_reader.h"
#include "sim/pipeline.h"
#include "sim/presets.h"
#include "sim/sequence.h"
#include "sim/settings.h"
#include "sim/summary.h"
#include "sim/svg_plot.h"
#include "sim/text.h"

namespace restir {

namespace {

namespace fs = std::filesystem;

// A sweep file being read: JsonReader's located errors, plus what only a sweep has (settings and presets).
class SweepReader : public JsonReader {
 public:
  using JsonReader::JsonReader;

  // A setting's value as --set takes it: numbers, booleans and strings.
  std::string SettingValue(const Json& v, const std::string& pointer) const {
    if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
    if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
    if (v.is_number_float()) {
      std::ostringstream o;
      o << v.get<double>();
      return o.str();
    }
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

// A run directory name: the characters a file name can always hold.
std::string SafeName(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '=') ? c : '_';
  return out;
}

double Value(const FrameMetricsRow& row, const std::string& column) {
  for (const auto& [name, value] : row.values)
    if (name == column) return value;
  return NAN;
}

std::string Num(double v, const char* format = "%.6g") {
  if (std::isnan(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}


}  // namespace

SweepSpec LoadSweep(const std::string& path) {
  // A FIFO or /dev/zero given as the sweep file is refused, not read forever (DESIGN §10).
  const SweepReader r(path, ReadInputFile(path, size_t(16) << 20, "sweep file"));
  const Json& root = r.AsObject(r.Root(), "");
  r.CheckKeys(root, "", {"sequence", "resolution", "frames", "seed", "referenceSpp", "presets", "grid", "configs"});

  SweepSpec spec;
  spec.path = path;
  RunOptions& b = spec.base;
  // Relative to the sweep file, as mesh paths are relative to their sequence file.
  const fs::path seqPath(r.Name(r.Need(root, "", "sequence"), "/sequence"));
  b.sequencePath = seqPath.is_absolute() ? seqPath.string() : (fs::path(path).parent_path() / seqPath).string();
  std::error_code ec;
  if (!fs::is_regular_file(b.sequencePath, ec)) r.Fail("/sequence", "no sequence file '" + b.sequencePath + "'");
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
  if (root.contains("seed")) b.seed = static_cast<uint32_t>(r.Integer(root["seed"], "/seed", 0, UINT32_MAX, "seed"));
  if (root.contains("referenceSpp"))
    b.referenceSpp = static_cast<int>(r.Integer(root["referenceSpp"], "/referenceSpp", 1, 1 << 20, "referenceSpp"));
  b.writeImages = false;
  b.report = false;  // the sweep writes its own reports

  std::set<std::string> names;
  auto add = [&](SweepConfig c, const std::string& pointer) {
    c.name = SafeName(c.name);
    if (!names.insert(c.name).second) r.Fail(pointer, "configuration name '" + c.name + "' is used twice");
    spec.configs.push_back(std::move(c));
  };

  // The grid: every preset of "presets" with every combination of the grid's values (first key slowest).
  if (root.contains("grid") && !root.contains("presets")) r.Fail("/grid", "a grid needs a 'presets' list");
  if (root.contains("presets")) {
    const Json& ps = root["presets"];
    if (!ps.is_array() || ps.empty()) r.Fail("/presets", "expected a non-empty array of preset names");
    std::vector<std::pair<std::string, std::vector<std::string>>> axes;
    if (root.contains("grid")) {
      const Json& g = root["grid"];
      if (!g.is_object()) r.Fail("/grid", "expected an object of setting -> array of values");
      for (const auto& [key, values] : g.items()) {
        const std::string gp = PointerChild("/grid", key);
        if (!values.is_array() || values.empty()) r.Fail(gp, "expected a non-empty array of values");
        std::vector<std::string> vs;
        for (size_t k = 0; k < values.size(); ++k) {
          const std::string vp = PointerChild(gp, k);
          vs.push_back(r.SettingValue(values[k], vp));
          for (size_t i = 0; i < ps.size(); ++i)
            if (const Preset* p = FindPreset(ps[i].is_string() ? ps[i].get<std::string>() : ""))
              r.CheckSetting(*p, key, vs.back(), vp);
        }
        axes.emplace_back(key, vs);
      }
    }
    for (size_t i = 0; i < ps.size(); ++i) {
      const std::string pp = PointerChild("/presets", i);
      const Preset& preset = r.PresetNamed(ps[i], pp);
      size_t combos = 1;
      for (const auto& a : axes) {
        if (combos > 4096 / a.second.size()) r.Fail("/grid", "more than 4096 combinations");
        combos *= a.second.size();
      }
      for (size_t c = 0; c < combos; ++c) {
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
        add(cfg, pp);
      }
    }
  }
  if (root.contains("configs")) {
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
      add(cfg, cp + "/name");
    }
  }
  if (spec.configs.empty()) r.Fail("", "no configurations: give 'presets' (with an optional 'grid') or 'configs'");
  return spec;
}

SweepPoint Summarize(const SweepConfig& config, const std::vector<FrameMetricsRow>& rows) {
  SweepPoint p;
  p.config = config;
  auto column = [&](const std::string& name) {
    std::vector<double> v;
    for (const FrameMetricsRow& r : rows) v.push_back(Value(r, name));
    return v;
  };
  std::vector<double> rays;
  for (const FrameMetricsRow& r : rows) {
    double shadow = 0.0;
    for (const char* pass : kPassNames) {
      const double v = Value(r, std::string("rays_per_pixel_") + pass);
      if (!std::isnan(v)) shadow += v;
    }
    rays.push_back(shadow);
  }
  p.relmse = ColumnMean("relmse", column("relmse"));
  p.relmseDisocc = PostRevealMean(column("relmse_disocc"), column("disocc_recent_fraction"));
  p.flip = ColumnMean("flip", column("flip"));  // NaN when the column is absent
  p.lumaRatio = AccumulatedLumaRatio(column("luma_sum"), column("reference_luma_sum"));
  p.flicker = ColumnMean("flicker", column("flicker"));
  p.msPerFrame = ColumnMean("ms_frame", column("ms_frame"));
  p.shadowRaysPerPixel = ColumnMean("shadow_rays_per_pixel", rays);
  p.efficiency = Efficiency(p.relmse, p.msPerFrame);
  return p;
}

void MarkPareto(std::vector<SweepPoint>& points) {
  for (SweepPoint& a : points) {
    a.pareto = true;
    for (const SweepPoint& b : points) {
      const bool noWorse = b.msPerFrame <= a.msPerFrame && b.relmse <= a.relmse;
      const bool better = b.msPerFrame < a.msPerFrame || b.relmse < a.relmse;
      if (&a != &b && noWorse && better) a.pareto = false;
    }
  }
}

std::string SweepCsv(const std::vector<SweepPoint>& points) {
  std::ostringstream o;
  o << "config,preset,overrides,relmse,relmse_disocc,flip,luma_ratio,flicker,ms_frame,shadow_rays_per_pixel,"
       "efficiency,pareto\n";
  for (const SweepPoint& p : points)
    o << p.config.name << "," << p.config.preset << "," << Joined(p.config.overrides, " ") << "," << Num(p.relmse)
      << "," << Num(p.relmseDisocc) << "," << Num(p.flip) << "," << Num(p.lumaRatio) << "," << Num(p.flicker) << ","
      << Num(p.msPerFrame) << "," << Num(p.shadowRaysPerPixel) << "," << Num(p.efficiency) << ","
      << (p.pareto ? 1 : 0) << "\n";
  return o.str();
}

std::string SweepSvg(const std::vector<SweepPoint>& points) {
  // Log-log axes: costs and errors of configurations span decades.
  Plot plot;
  plot.title = "relmse against ms per frame (log-log); the line joins the Pareto front";
  plot.xLabel = "ms per frame";
  plot.yLabel = "relmse";
  plot.logX = plot.logY = true;
  plot.width = 760, plot.height = 480, plot.legendWidth = 190;
  for (const SweepPoint& p : points) {
    auto it = std::find_if(plot.series.begin(), plot.series.end(),
                           [&](const PlotSeries& s) { return s.name == p.config.preset; });
    if (it == plot.series.end()) {
      plot.series.push_back(PlotSeries{});
      it = plot.series.end() - 1;
      it->name = p.config.preset;
      it->line = false;
    }
    it->x.push_back(p.msPerFrame);
    it->y.push_back(p.relmse);
    it->titles.push_back(p.config.name + ": relmse " + Num(p.relmse, "%.4g") + ", " + Num(p.msPerFrame, "%.4g") +
                         " ms");
    it->emphasised.push_back(p.pareto ? 1 : 0);
  }
  std::vector<const SweepPoint*> front;
  for (const SweepPoint& p : points)
    if (p.pareto && p.msPerFrame > 0.0 && p.relmse > 0.0) front.push_back(&p);
  std::sort(front.begin(), front.end(), [](const SweepPoint* a, const SweepPoint* b) {
    return a->msPerFrame < b->msPerFrame;
  });
  for (const SweepPoint* p : front) plot.guide.emplace_back(p->msPerFrame, p->relmse);
  return SvgPlot(plot);
}

namespace {

// For each budget (a cost of a Pareto point) and each preset: its most accurate configuration within 5% of
// the budget.
std::string BudgetTable(const std::vector<SweepPoint>& points, double SweepPoint::*cost, const std::string& unit) {
  std::vector<std::string> presets;
  for (const SweepPoint& p : points)
    if (std::find(presets.begin(), presets.end(), p.config.preset) == presets.end()) presets.push_back(p.config.preset);
  std::vector<double> budgets;
  for (const SweepPoint& p : points) budgets.push_back(p.*cost);
  std::sort(budgets.begin(), budgets.end());
  budgets.erase(std::unique(budgets.begin(), budgets.end(), [](double a, double b) { return b <= a * 1.05; }),
                budgets.end());
  std::ostringstream o;
  o << "| budget (" << unit << ") |";
  for (const std::string& p : presets) o << " `" << p << "` |";
  o << "\n| --- |";
  for (size_t k = 0; k < presets.size(); ++k) o << " --- |";
  o << "\n";
  for (double b : budgets) {
    o << "| " << Num(b, "%.3g") << " |";
    for (const std::string& preset : presets) {
      const SweepPoint* best = nullptr;
      for (const SweepPoint& p : points)
        if (p.config.preset == preset && p.*cost <= 1.05 * b && (!best || p.relmse < best->relmse)) best = &p;
      if (best) o << " " << Num(best->relmse, "%.4f") << " (" << best->config.name << ") |";
      else o << " — |";
    }
    o << "\n";
  }
  return o.str();
}

}  // namespace

std::string SweepMarkdown(const SweepSpec& spec, const std::vector<SweepPoint>& points) {
  std::ostringstream o;
  o << "# Sweep: " << spec.path << "\n\n";
  o << "Sequence `" << spec.base.sequencePath << "`";
  if (spec.base.width > 0) o << " at " << spec.base.width << "×" << spec.base.height;
  if (spec.base.frameEnd > 0) o << ", frames " << spec.base.frameBegin << "–" << spec.base.frameEnd - 1;
  o << ". relmse and flip are means over frames, relmse_disocc over the frames with pixels revealed in the last 4 "
       "frames, ms/frame the estimator's wall time (reference excluded, first frame skipped), shadow rays/px "
       "every pass's shadow rays per pixel. Times come from separate runs on a shared machine: compare them "
       "with care. `sweep.svg` plots relmse against ms per frame.\n\n";
  o << "## Every configuration\n\n| config | preset | overrides | relmse | relmse_disocc | flip | luma ratio | "
       "flicker | ms/frame | shadow rays/px | efficiency | Pareto |\n|" << std::string(" --- |").c_str();
  for (int k = 0; k < 11; ++k) o << " --- |";
  o << "\n";
  for (const SweepPoint& p : points)
    o << "| " << p.config.name << " | `" << p.config.preset << "` | " << Joined(p.config.overrides, " ") << " | "
      << Num(p.relmse, "%.4f") << " | " << Num(p.relmseDisocc, "%.4f") << " | " << Num(p.flip, "%.4f") << " | "
      << Num(p.lumaRatio, "%.4f") << " | " << Num(p.flicker, "%.4f") << " | " << Num(p.msPerFrame, "%.1f") << " | "
      << Num(p.shadowRaysPerPixel, "%.2f") << " | " << Num(p.efficiency, "%.3g") << " | " << (p.pareto ? "yes" : "")
      << " |\n";
  o << "\n## Equal time\n\nFor each budget (every distinct ms/frame of the sweep), each preset's lowest relmse among "
       "its configurations within 5% of the budget.\n\n"
    << BudgetTable(points, &SweepPoint::msPerFrame, "ms/frame");
  o << "\n## Equal samples\n\nThe same with shadow rays per pixel as the budget.\n\n"
    << BudgetTable(points, &SweepPoint::shadowRaysPerPixel, "shadow rays/px");
  return o.str();
}

std::vector<SweepPoint> RunSweep(const SweepSpec& spec, const std::string& outDir) {
  std::vector<SweepPoint> points;
  for (size_t k = 0; k < spec.configs.size(); ++k) {
    const SweepConfig& c = spec.configs[k];
    RunOptions o = spec.base;
    o.presets = {c.preset};
    o.settings = c.overrides;
    o.outDir = (fs::path(outDir) / "runs" / c.name).string();
    o.commandLine = spec.base.commandLine + " [sweep config " + c.name + "]";
    std::fprintf(stderr, "sweep: %zu/%zu %s\n", k + 1, spec.configs.size(), c.name.c_str());
    const RunResult r = Run(o);
    points.push_back(Summarize(c, r.rows));
  }
  MarkPareto(points);
  WriteFileAtomic((fs::path(outDir) / "sweep.csv").string(), SweepCsv(points));
  WriteFileAtomic((fs::path(outDir) / "sweep.svg").string(), SweepSvg(points));
  WriteFileAtomic((fs::path(outDir) / "sweep.md").string(), SweepMarkdown(spec, points));
  return points;
}

}  // namespace restir
