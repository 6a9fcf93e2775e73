#include "sim/metrics/compare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sim/metrics/metrics_csv.h"
#include "sim/metrics/summary.h"
#include "sim/util/input_file.h"
#include "sim/util/input_error.h"

namespace restir {

namespace {

// Continued fraction of the regularized incomplete beta function (modified Lentz; Numerical Recipes §6.4).
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300, kEps = 1e-15;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 500; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < kEps) break;
  }
  return h;
}

// Regularized incomplete beta I_x(a, b).
double IncompleteBeta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double lnFront = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(lnFront) * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - std::exp(lnFront) * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

bool SameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

std::string MetricsPath(const std::string& run) {
  std::error_code ec;
  if (std::filesystem::is_directory(run, ec)) return (std::filesystem::path(run) / "metrics.csv").string();
  if (std::filesystem::exists(run, ec)) return run;
  throw InputError(run + ": error: no such run directory or metrics.csv");
}

// What a run's run.json (beside its metrics.csv) says its rows are; absent when there is none.
struct RunFacts {
  std::string path;          // the run.json read, or "" when there is none
  std::string sequenceHash;  // sequence.contentHash
  int frameBegin = 0, frameEnd = 0;
  std::vector<std::string> presets;
};

RunFacts ReadRunFacts(const std::string& metricsPath) {
  RunFacts f;
  const std::string path = (std::filesystem::path(metricsPath).parent_path() / "run.json").string();
  std::string text, problem;
  if (!TryReadRegularFile(path, size_t(64) << 20, text, problem)) {
    if (problem == "no such file") return f;
    throw InputError(path + ": error: cannot read (" + problem + ")");
  }
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  auto bad = [&](const std::string& what) { throw InputError(path + ": error: " + what); };
  if (!j.is_object()) bad("not a JSON object");
  if (!j.contains("sequence") || !j["sequence"].is_object() || !j["sequence"].contains("contentHash") ||
      !j["sequence"]["contentHash"].is_string())
    bad("no sequence.contentHash");
  if (!j.contains("frames") || !j["frames"].is_array() || j["frames"].size() != 2 ||
      !j["frames"][0].is_number_integer() || !j["frames"][1].is_number_integer())
    bad("frames is not [begin, end]");
  if (!j.contains("presets") || !j["presets"].is_object()) bad("no presets object");
  f.path = path;
  f.sequenceHash = j["sequence"]["contentHash"].get<std::string>();
  f.frameBegin = j["frames"][0].get<int>();
  f.frameEnd = j["frames"][1].get<int>();
  for (const auto& [name, preset] : j["presets"].items()) f.presets.push_back(name);
  return f;
}

// A metrics.csv whose rows are not its run.json's (a preset it did not run, a frame outside its range) is another
// run's file put in its place: refused naming both.
void CheckRowsAgainstRun(const MetricsTable& t, const RunFacts& run) {
  if (run.path.empty()) return;
  for (const PresetSeries& p : t.presets) {
    if (std::find(run.presets.begin(), run.presets.end(), p.name) == run.presets.end())
      throw InputError(t.path + ": error: preset " + p.name + " is not one of " + run.path + "'s presets");
    for (int frame : p.frames)
      if (frame < run.frameBegin || frame >= run.frameEnd)
        throw InputError(t.path + ": error: frame " + std::to_string(frame) + " of preset " + p.name +
                         " is outside " + run.path + "'s frames " + std::to_string(run.frameBegin) + ":" +
                         std::to_string(run.frameEnd));
  }
}

const char* VerdictText(CompareVerdict v) {
  switch (v) {
    case CompareVerdict::kIdentical: return "identical";
    case CompareVerdict::kSignificant: return "SIGNIFICANT";
    case CompareVerdict::kNotSignificant: return "not significant";
    case CompareVerdict::kTooFewFrames: return "too few frames";
  }
  return "";
}

std::string Fmt(double v, const char* f = "%.4g") {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, v);
  return buf;
}

}  // namespace

namespace {

// The shared frames' values of `column` in one run (empty when it has no such column).
std::vector<double> SharedValues(const MetricsTable& t, const PresetSeries& p, const std::vector<size_t>& rows,
                                 const std::string& column) {
  std::vector<double> v;
  const int c = t.Column(column);
  if (c < 0) return v;
  for (size_t k : rows) v.push_back(p.values[c][k]);
  return v;
}

void AddIntervals(const MetricsTable& a, const PresetSeries& pa, const std::vector<size_t>& ia, const MetricsTable& b,
                  const PresetSeries& pb, const std::vector<size_t>& ib, ColumnComparison& col) {
  if (std::find_if(std::begin(kIntervalMetrics), std::end(kIntervalMetrics),
                   [&](const char* m) { return col.column == m; }) == std::end(kIntervalMetrics))
    return;
  const std::string sd = col.column + "_ref_sd";
  if (a.Column(sd) < 0 || b.Column(sd) < 0 || a.Column("reference_luma_sum") < 0 || b.Column("reference_luma_sum") < 0)
    return;
  col.hasIntervals = true;
  const std::string seed = col.column + "_seed_sd";
  col.intervalA = ColumnInterval(SharedValues(a, pa, ia, col.column), SharedValues(a, pa, ia, sd),
                                 SharedValues(a, pa, ia, "reference_luma_sum"), SharedValues(a, pa, ia, seed));
  col.intervalB = ColumnInterval(SharedValues(b, pb, ib, col.column), SharedValues(b, pb, ib, sd),
                                 SharedValues(b, pb, ib, "reference_luma_sum"), SharedValues(b, pb, ib, seed));
}

}  // namespace

double StudentTTwoSidedP(double t, int dof) {
  if (dof < 1 || std::isnan(t)) return NAN;
  if (std::isinf(t)) return 0.0;
  const double n = dof;
  return IncompleteBeta(0.5 * n, 0.5, n / (n + t * t));
}

ColumnComparison CompareSeries(const std::string& column, const std::vector<double>& a, const std::vector<double>& b) {
  ColumnComparison c;
  c.column = column;
  const size_t n = std::min(a.size(), b.size());
  c.meanA = ColumnMean(column, std::vector<double>(a.begin(), a.begin() + n));
  c.meanB = ColumnMean(column, std::vector<double>(b.begin(), b.begin() + n));
  c.relativeChange = c.meanA != 0.0 ? (c.meanB - c.meanA) / std::fabs(c.meanA) : (c.meanB == 0.0 ? 0.0 : NAN);
  bool identical = true;
  for (size_t i = 0; i < n; ++i) identical = identical && SameValue(a[i], b[i]);
  if (identical) {
    c.verdict = CompareVerdict::kIdentical;
    return c;
  }
  c.batches = static_cast<int>(n / kCompareBatch);
  if (c.batches < kCompareMinBatches) {
    c.verdict = CompareVerdict::kTooFewFrames;
    return c;
  }
  std::vector<double> means;
  for (int k = 0; k < c.batches; ++k) {
    double s = 0.0;
    for (int i = 0; i < kCompareBatch; ++i) s += b[k * kCompareBatch + i] - a[k * kCompareBatch + i];
    means.push_back(s / kCompareBatch);
  }
  double m = 0.0;
  for (double x : means) m += x / static_cast<double>(means.size());
  double ss = 0.0;
  for (double x : means) ss += (x - m) * (x - m);
  const double se = std::sqrt(ss / (c.batches - 1) / c.batches);
  if (se > 0.0) {
    c.t = m / se;
    c.p = StudentTTwoSidedP(c.t, c.batches - 1);
  } else {  // every batch moved by exactly the same amount
    c.t = m == 0.0 ? 0.0 : (m > 0 ? INFINITY : -INFINITY);
    c.p = m == 0.0 ? 1.0 : 0.0;
  }
  if (std::isnan(c.p)) c.p = 1.0;  // non-finite inputs: no evidence either way
  c.verdict = c.p < kCompareAlpha ? CompareVerdict::kSignificant : CompareVerdict::kNotSignificant;
  return c;
}

RunComparison CompareRuns(const std::string& runA, const std::string& runB) {
  RunComparison r;
  r.pathA = MetricsPath(runA);
  r.pathB = MetricsPath(runB);
  const MetricsTable a = ReadMetricsCsv(r.pathA), b = ReadMetricsCsv(r.pathB);
  // Frames are paired by number, which means the same image only in runs of one sequence.
  const RunFacts factsA = ReadRunFacts(r.pathA), factsB = ReadRunFacts(r.pathB);
  CheckRowsAgainstRun(a, factsA);
  CheckRowsAgainstRun(b, factsB);
  if (!factsA.path.empty() && !factsB.path.empty() && factsA.sequenceHash != factsB.sequenceHash)
    throw InputError(factsB.path + ": error: sequence " + factsB.sequenceHash + " is not " + factsA.path + "'s " +
                     factsA.sequenceHash + ": compare pairs the frames of one sequence");
  for (const std::string& col : a.columns)
    if (b.Column(col) < 0) r.columnsOnlyInA.push_back(col);
  for (const std::string& col : b.columns)
    if (a.Column(col) < 0) r.columnsOnlyInB.push_back(col);
  for (const PresetSeries& p : b.presets)
    if (!a.Preset(p.name)) r.onlyInB.push_back(p.name);
  for (const PresetSeries& pa : a.presets) {
    const PresetSeries* pb = b.Preset(pa.name);
    if (!pb) {
      r.onlyInA.push_back(pa.name);
      continue;
    }
    // Rows are in frame order in both: pair up the frames both runs have.
    std::vector<size_t> ia, ib;
    for (size_t i = 0, j = 0; i < pa.frames.size() && j < pb->frames.size();) {
      if (pa.frames[i] < pb->frames[j]) {
        ++i;
      } else if (pb->frames[j] < pa.frames[i]) {
        ++j;
      } else {
        ia.push_back(i++);
        ib.push_back(j++);
      }
    }
    PresetComparison pc;
    pc.preset = pa.name;
    pc.frames = static_cast<int>(ia.size());
    if (a.hasImageHash && b.hasImageHash) {
      pc.imageHashesDiffering = 0;
      for (size_t k = 0; k < ia.size(); ++k)
        if (pa.imageHashes[ia[k]] != pb->imageHashes[ib[k]]) ++pc.imageHashesDiffering;
    }
    for (size_t c = 0; c < a.columns.size(); ++c) {
      const int cb = b.Column(a.columns[c]);
      if (cb < 0) continue;
      std::vector<double> va, vb;
      for (size_t k = 0; k < ia.size(); ++k) {
        va.push_back(pa.values[c][ia[k]]);
        vb.push_back(pb->values[cb][ib[k]]);
      }
      pc.columns.push_back(CompareSeries(a.columns[c], va, vb));
      AddIntervals(a, pa, ia, b, *pb, ib, pc.columns.back());
    }
    r.presets.push_back(std::move(pc));
  }
  return r;
}

std::string FormatComparison(const RunComparison& c) {
  std::ostringstream o;
  o << "A: " << c.pathA << "\nB: " << c.pathB << "\n";
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "test: paired t-test on the means of batches of %d consecutive frames of B - A (trailing partial "
                "batch dropped, at least %d batches), two-sided, %g%% level; no multiple-comparison correction\n",
                kCompareBatch, kCompareMinBatches, kCompareAlpha * 100.0);
  o << buf;
  auto list = [&](const char* what, const std::vector<std::string>& v) {
    if (v.empty()) return;
    o << what;
    for (size_t i = 0; i < v.size(); ++i) o << (i ? ", " : " ") << v[i];
    o << "\n";
  };
  list("presets only in A:", c.onlyInA);
  list("presets only in B:", c.onlyInB);
  list("columns only in A:", c.columnsOnlyInA);
  list("columns only in B:", c.columnsOnlyInB);
  if (c.presets.empty()) o << "no preset in both runs\n";
  for (const PresetComparison& p : c.presets) {
    o << "\n== " << p.preset << ": " << p.frames << " frames in both";
    if (p.imageHashesDiffering == 0)
      o << "; image_hash identical in every frame (bit-identical images)";
    else if (p.imageHashesDiffering > 0)
      o << "; image_hash differs in " << p.imageHashesDiffering << " of " << p.frames << " frames";
    o << "\n";
    std::snprintf(buf, sizeof(buf), "%-26s %12s %12s %9s %8s  %s\n", "column", "mean A", "mean B", "change", "p",
                  "verdict");
    bool header = false;
    std::vector<std::string> identical;
    for (const ColumnComparison& col : p.columns) {
      if (col.verdict == CompareVerdict::kIdentical) {
        identical.push_back(col.column);
        continue;
      }
      if (!header) o << buf;  // the table's header, before its first row
      header = true;
      const std::string change =
          std::isnan(col.relativeChange) ? "n/a" : Fmt(col.relativeChange * 100.0, "%+.2f") + "%";
      const std::string pv = col.verdict == CompareVerdict::kTooFewFrames ? "-" : Fmt(col.p, "%.3g");
      std::snprintf(buf, sizeof(buf), "%-26s %12s %12s %9s %8s  %s\n", col.column.c_str(), Fmt(col.meanA).c_str(),
                    Fmt(col.meanB).c_str(), change.c_str(), pv.c_str(), VerdictText(col.verdict));
      o << buf;
      if (col.hasIntervals) {
        auto interval = [](const MetricInterval& in) {
          return "± " + Fmt(in.halfWidth, "%.2g") + (in.referenceDominated ? " (mostly the reference's noise)" : "");
        };
        o << "  95% interval: A " << interval(col.intervalA) << ", B " << interval(col.intervalB) << "\n";
      }
    }
    if (!identical.empty()) {
      o << "identical in both runs (" << identical.size() << "):";
      for (size_t i = 0; i < identical.size(); ++i) o << (i ? ", " : " ") << identical[i];
      o << "\n";
    }
  }
  return o.str();
}

}  // namespace restir
