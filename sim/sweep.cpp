#include "sim/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "sim/atomic_file.h"
#include "sim/json_locator.h"
#include "sim/pipeline.h"
#include "sim/presets.h"
#include "sim/sequence.h"
#include "sim/settings.h"

namespace restir {

namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

// Semantic errors of a sweep file: file:line:column of the offending value, and its JSON path.
class SweepReader {
 public:
  SweepReader(const std::string& path, const std::string& text) : path_(path), locator_(text) {}

  [[noreturn]] void Fail(const std::string& pointer, const std::string& message) const {
    const SourcePos pos = locator_.ValuePos(pointer);
    throw InputError(path_ + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) + ": error at " +
                     (pointer.empty() ? "(top level)" : pointer) + ": " + message);
  }

  void CheckKeys(const Json& object, const std::string& pointer, const std::set<std::string>& known) const {
    for (const auto& [key, value] : object.items()) {
      if (known.count(key)) continue;
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      const SourcePos pos = locator_.KeyPos(PointerChild(pointer, key));
      throw InputError(path_ + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                       ": error at " + PointerChild(pointer, key) + ": unknown key '" + key + "' (known: " + list +
                       ")");
    }
  }

  int64_t Integer(const Json& v, const std::string& pointer, int64_t lo, int64_t hi) const {
    if (!v.is_number_integer() && !v.is_number_unsigned()) Fail(pointer, "expected an integer");
    const int64_t x = v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(INT64_MAX) ? INT64_MAX : v.get<int64_t>();
    if (x < lo || x > hi)
      Fail(pointer, "must be between " + std::to_string(lo) + " and " + std::to_string(hi) + ", got " + v.dump());
    return x;
  }

  std::string String(const Json& v, const std::string& pointer) const {
    if (!v.is_string()) Fail(pointer, "expected a string");
    const std::string s = v.get<std::string>();
    if (s.empty()) Fail(pointer, "must not be empty");
    return s;
  }

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
    const std::string name = String(v, pointer);
    if (const Preset* p = FindPreset(name)) return *p;
    std::string known;
    for (const Preset& q : AllPresets()) known += (known.empty() ? "" : ", ") + q.name;
    Fail(pointer, "unknown preset '" + name + "' (known: " + known + ")");
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

 private:
  std::string path_;
  JsonLocator locator_;
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

double Mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / static_cast<double>(v.size());
}

std::string Num(double v, const char* format = "%.6g") {
  if (std::isnan(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

std::string Joined(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

std::string XmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

}  // namespace

SweepSpec LoadSweep(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::error_code ec;
  if (!f || fs::is_directory(path, ec)) throw InputError(path + ": error: cannot read sweep file");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  Json root;
  try {
    root = Json::parse(text);
  } catch (const Json::exception& e) {
    const size_t byte = (e.id == 101 && dynamic_cast<const Json::parse_error*>(&e))
                            ? static_cast<const Json::parse_error&>(e).byte : 1;
    const SourcePos pos = PosFromOffset(text, byte > 0 ? byte - 1 : 0);
    std::string what = e.what();
    const size_t cut = what.rfind(": ");
    if (cut != std::string::npos) what = what.substr(cut + 2);
    throw InputError(path + ":" + std::to_string(pos.line) + ":" + std::to_string(pos.column) +
                     ": error: invalid JSON: " + what);
  }
  SweepReader r(path, text);
  SourcePos deep;
  JsonLocator probe(text);
  if (probe.TooDeep(deep)) r.Fail("", "JSON nests too deeply");
  if (!probe.DuplicateKeyPointer().empty()) r.Fail(probe.DuplicateKeyPointer(), "key appears twice");
  if (!root.is_object()) r.Fail("", "a sweep file is a JSON object");
  r.CheckKeys(root, "", {"sequence", "resolution", "frames", "seed", "referenceSpp", "presets", "grid", "configs"});

  SweepSpec spec;
  spec.path = path;
  RunOptions& b = spec.base;
  if (!root.contains("sequence")) r.Fail("", "missing key 'sequence'");
  // Relative to the sweep file, as mesh paths are relative to their sequence file.
  const fs::path seqPath(r.String(root["sequence"], "/sequence"));
  b.sequencePath = seqPath.is_absolute() ? seqPath.string() : (fs::path(path).parent_path() / seqPath).string();
  if (!fs::is_regular_file(b.sequencePath, ec)) r.Fail("/sequence", "no sequence file '" + b.sequencePath + "'");
  if (root.contains("resolution")) {
    const Json& v = root["resolution"];
    if (!v.is_array() || v.size() != 2) r.Fail("/resolution", "expected [width, height]");
    b.width = static_cast<int>(r.Integer(v[0], "/resolution/0", 1, 16384));
    b.height = static_cast<int>(r.Integer(v[1], "/resolution/1", 1, 16384));
  }
  if (root.contains("frames")) {
    const Json& v = root["frames"];
    if (!v.is_array() || v.size() != 2) r.Fail("/frames", "expected [first, end) as [A, B]");
    b.frameBegin = static_cast<int>(r.Integer(v[0], "/frames/0", 0, 1 << 20));
    b.frameEnd = static_cast<int>(r.Integer(v[1], "/frames/1", b.frameBegin + 1, 1 << 20));
  }
  if (root.contains("seed")) b.seed = static_cast<uint32_t>(r.Integer(root["seed"], "/seed", 0, UINT32_MAX));
  if (root.contains("referenceSpp"))
    b.referenceSpp = static_cast<int>(r.Integer(root["referenceSpp"], "/referenceSpp", 1, 1 << 20));
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
      for (const auto& a : axes) combos *= a.second.size();
      if (combos > 4096) r.Fail("/grid", "more than 4096 combinations");
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
      if (!c.contains("name")) r.Fail(cp, "missing key 'name'");
      if (!c.contains("preset")) r.Fail(cp, "missing key 'preset'");
      SweepConfig cfg;
      cfg.name = r.String(c["name"], cp + "/name");
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
  std::vector<double> relmse, disocc, flip, flicker, ms, rays;
  double luma = 0.0, refLuma = 0.0;
  for (size_t k = 0; k < rows.size(); ++k) {
    const FrameMetricsRow& r = rows[k];
    relmse.push_back(Value(r, "relmse"));
    if (Value(r, "disocc_recent_fraction") > 0.0) disocc.push_back(Value(r, "relmse_disocc"));
    if (!std::isnan(Value(r, "flip"))) flip.push_back(Value(r, "flip"));
    luma += Value(r, "luma_sum");
    refLuma += Value(r, "reference_luma_sum");
    double shadow = 0.0;
    for (const char* pass : kPassNames) {
      const double v = Value(r, std::string("rays_per_pixel_") + pass);
      if (!std::isnan(v)) shadow += v;
    }
    rays.push_back(shadow);
    if (k > 0 || rows.size() == 1) {
      flicker.push_back(Value(r, "flicker"));
      ms.push_back(Value(r, "ms_frame"));
    }
  }
  p.relmse = Mean(relmse);
  p.relmseDisocc = Mean(disocc);
  p.flip = Mean(flip);
  p.lumaRatio = refLuma > 0.0 ? luma / refLuma : NAN;
  p.flicker = Mean(flicker);
  p.msPerFrame = Mean(ms);
  p.shadowRaysPerPixel = Mean(rays);
  p.efficiency = 1.0 / (p.relmse * p.msPerFrame * 1e-3);
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
  const double W = 760, H = 480, left = 70, right = 190, top = 30, bottom = 50;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const SweepPoint& p : points) {
    if (!(p.msPerFrame > 0.0) || !(p.relmse > 0.0)) continue;
    x0 = std::min(x0, std::log10(p.msPerFrame)), x1 = std::max(x1, std::log10(p.msPerFrame));
    y0 = std::min(y0, std::log10(p.relmse)), y1 = std::max(y1, std::log10(p.relmse));
  }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = -1, y1 = 0;
  x0 = std::floor(x0 * 10) / 10 - 0.05, x1 = std::ceil(x1 * 10) / 10 + 0.05;
  y0 = std::floor(y0 * 10) / 10 - 0.05, y1 = std::ceil(y1 * 10) / 10 + 0.05;
  auto X = [&](double ms) { return left + (std::log10(ms) - x0) / (x1 - x0) * (W - left - right); };
  auto Y = [&](double e) { return H - bottom - (std::log10(e) - y0) / (y1 - y0) * (H - top - bottom); };
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
                                   "#17becf"};
  std::vector<std::string> presets;
  for (const SweepPoint& p : points)
    if (std::find(presets.begin(), presets.end(), p.config.preset) == presets.end()) presets.push_back(p.config.preset);
  auto colour = [&](const std::string& preset) {
    return kColours[(std::find(presets.begin(), presets.end(), preset) - presets.begin()) % 8];
  };
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" viewBox=\"0 0 " << W
    << " " << H << "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << left << "\" y=\"18\" font-size=\"13\">relmse against ms per frame (log-log); the line joins "
       "the Pareto front</text>\n";
  // Axes with decade and half-decade ticks.
  o << "<line x1=\"" << left << "\" y1=\"" << H - bottom << "\" x2=\"" << W - right << "\" y2=\"" << H - bottom
    << "\" stroke=\"black\"/>\n<line x1=\"" << left << "\" y1=\"" << top << "\" x2=\"" << left << "\" y2=\""
    << H - bottom << "\" stroke=\"black\"/>\n";
  for (int k = static_cast<int>(std::floor(x0 * 4)); k <= static_cast<int>(std::ceil(x1 * 4)); ++k) {
    const double lv = k / 4.0;
    if (lv < x0 || lv > x1) continue;
    const double ms = std::pow(10.0, lv), x = X(ms);
    o << "<line x1=\"" << Num(x, "%.1f") << "\" y1=\"" << H - bottom << "\" x2=\"" << Num(x, "%.1f") << "\" y2=\""
      << H - bottom + 5 << "\" stroke=\"black\"/><text x=\"" << Num(x, "%.1f") << "\" y=\"" << H - bottom + 18
      << "\" text-anchor=\"middle\">" << Num(ms, "%.3g") << "</text>\n";
  }
  for (int k = static_cast<int>(std::floor(y0 * 4)); k <= static_cast<int>(std::ceil(y1 * 4)); ++k) {
    const double lv = k / 4.0;
    if (lv < y0 || lv > y1) continue;
    const double e = std::pow(10.0, lv), y = Y(e);
    o << "<line x1=\"" << left - 5 << "\" y1=\"" << Num(y, "%.1f") << "\" x2=\"" << left << "\" y2=\""
      << Num(y, "%.1f") << "\" stroke=\"black\"/><text x=\"" << left - 8 << "\" y=\"" << Num(y + 4, "%.1f")
      << "\" text-anchor=\"end\">" << Num(e, "%.3g") << "</text>\n";
  }
  o << "<text x=\"" << (left + W - right) / 2 << "\" y=\"" << H - 12 << "\" text-anchor=\"middle\">ms per frame</text>\n";
  o << "<text x=\"16\" y=\"" << (top + H - bottom) / 2 << "\" transform=\"rotate(-90 16 " << (top + H - bottom) / 2
    << ")\" text-anchor=\"middle\">relmse</text>\n";
  std::vector<const SweepPoint*> front;
  for (const SweepPoint& p : points)
    if (p.pareto && p.msPerFrame > 0.0 && p.relmse > 0.0) front.push_back(&p);
  std::sort(front.begin(), front.end(), [](const SweepPoint* a, const SweepPoint* b) {
    return a->msPerFrame < b->msPerFrame;
  });
  if (front.size() > 1) {
    o << "<polyline fill=\"none\" stroke=\"#888\" stroke-dasharray=\"4 3\" points=\"";
    for (const SweepPoint* p : front) o << Num(X(p->msPerFrame), "%.1f") << "," << Num(Y(p->relmse), "%.1f") << " ";
    o << "\"/>\n";
  }
  for (const SweepPoint& p : points) {
    if (!(p.msPerFrame > 0.0) || !(p.relmse > 0.0)) continue;
    o << "<circle cx=\"" << Num(X(p.msPerFrame), "%.1f") << "\" cy=\"" << Num(Y(p.relmse), "%.1f") << "\" r=\""
      << (p.pareto ? 5 : 3.5) << "\" fill=\"" << colour(p.config.preset) << "\"><title>" << XmlEscape(p.config.name)
      << ": relmse " << Num(p.relmse, "%.4g") << ", " << Num(p.msPerFrame, "%.4g") << " ms</title></circle>\n";
  }
  for (size_t k = 0; k < presets.size(); ++k) {
    const double y = top + 10 + 16 * k;
    o << "<circle cx=\"" << W - right + 16 << "\" cy=\"" << y << "\" r=\"4\" fill=\"" << colour(presets[k])
      << "\"/><text x=\"" << W - right + 26 << "\" y=\"" << y + 4 << "\">" << XmlEscape(presets[k]) << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
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
