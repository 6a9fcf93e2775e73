// The sweep's reports (sim/study/sweep.h): per-run summaries, the Pareto front, sweep.csv, the plots and sweep.md.
#include "sim/study/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "sim/estimator/pipeline.h"
#include "sim/metrics/summary.h"
#include "sim/output/svg_plot.h"
#include "sim/util/text.h"

namespace restir {

namespace {

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
    std::vector<double> cost, error;
    size_t self = 0;
    for (const SweepPoint& b : points) {
      if (b.sequence != a.sequence) continue;
      if (&b == &a) self = cost.size();
      cost.push_back(b.msPerFrame);
      error.push_back(b.relmse);
    }
    a.pareto = ParetoFront(cost, error)[self] != 0;
  }
}

std::string SweepCsv(const std::vector<SweepPoint>& points) {
  std::ostringstream o;
  o << "sequence,config,preset,overrides,seeds,relmse,relmse_ci95,relmse_disocc,flip,luma_ratio,flicker,ms_frame,"
       "shadow_rays_per_pixel,efficiency,pareto,bias2,bias2_ci95,variance,variance_ci95\n";
  for (const SweepPoint& p : points)
    o << p.sequence << "," << p.config.name << "," << p.config.preset << "," << Joined(p.config.overrides, " ") << ","
      << p.seeds << "," << Num(p.relmse) << "," << Num(p.relmseCi95) << "," << Num(p.relmseDisocc) << ","
      << Num(p.flip) << "," << Num(p.lumaRatio) << "," << Num(p.flicker) << "," << Num(p.msPerFrame) << ","
      << Num(p.shadowRaysPerPixel) << "," << Num(p.efficiency) << "," << (p.pareto ? 1 : 0) << "," << Num(p.bias2)
      << "," << Num(p.bias2Ci95) << "," << Num(p.variance) << "," << Num(p.varianceCi95) << "\n";
  return o.str();
}

std::string SweepSvg(const std::vector<SweepPoint>& all, const std::string& sequence) {
  std::vector<SweepPoint> points;
  for (const SweepPoint& p : all)
    if (p.sequence == sequence) points.push_back(p);
  // Log-log axes: costs and errors of configurations span decades.
  Plot plot;
  plot.title = sequence + ": relmse against ms per frame (log-log); the line joins the Pareto front";
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

// ± half-width, or nothing when there is no interval.
std::string WithInterval(double v, double half, const char* format) {
  if (std::isnan(v)) return "";
  return Num(v, format) + (std::isnan(half) ? "" : " ± " + Num(half, format));
}

}  // namespace

std::string SweepMarkdown(const SweepSpec& spec, const SweepMerge& merge) {
  std::ostringstream o;
  o << "# Sweep: " << spec.path << "\n\n";
  o << merge.points.size() << " results of " << spec.configs.size() << " configurations on " << spec.sequences.size()
    << (spec.sequences.size() == 1 ? " sequence" : " sequences");
  if (spec.base.width > 0) o << " at " << spec.base.width << "×" << spec.base.height;
  if (spec.base.frameEnd > 0) o << ", frames " << spec.base.frameBegin << "–" << spec.base.frameEnd - 1;
  o << "; " << merge.jobs - merge.missing.size() << " of " << merge.jobs << " jobs complete.";
  o << " relmse and flip are means over frames (then over seeds), relmse_disocc over the frames with pixels revealed "
       "in the last 4 frames, ms/frame the estimator's wall time (reference excluded, first frame skipped), shadow "
       "rays/px every pass's shadow rays per pixel. Times come from separate runs, perhaps on different machines: "
       "compare them with care.\n\n";
  if (!merge.missing.empty()) {
    o << "## Missing jobs\n\n" << merge.missing.size() << " jobs have no complete result; every figure below leaves "
      << "them out (`restir-sim sweep FILE --plan --missing` lists them again):\n\n";
    for (size_t k = 0; k < merge.missing.size(); ++k)
      o << "- `" << merge.missing[k] << "`" << (k < merge.missingWhy.size() ? ": " + merge.missingWhy[k] : "") << "\n";
    o << "\n";
  }
  for (const SweepSequence& q : spec.sequences) {
    std::vector<SweepPoint> points;
    for (const SweepPoint& p : merge.points)
      if (p.sequence == q.name) points.push_back(p);
    o << "## " << q.name << "\n\n`" << q.path << "`, seeds";
    for (size_t k = 0; k < q.seeds.size() && k < 8; ++k) o << (k ? ", " : " ") << q.seeds[k];
    if (q.seeds.size() > 8) o << ", … (" << q.seeds.size() << ")";
    o << ". " << (spec.sequences.size() == 1 ? "`sweep.svg`" : "`sweep-" + q.name + ".svg`")
      << " plots relmse against ms per frame.\n\n";
    if (points.empty()) {
      o << "No complete job yet.\n\n";
      continue;
    }
    o << "### Every configuration\n\n| config | preset | overrides | seeds | relmse | relmse_disocc | flip | luma ratio "
         "| flicker | ms/frame | shadow rays/px | efficiency | Pareto |\n|";
    for (int k = 0; k < 13; ++k) o << " --- |";
    o << "\n";
    for (const SweepPoint& p : points)
      o << "| " << p.config.name << " | `" << p.config.preset << "` | " << Joined(p.config.overrides, " ") << " | "
        << p.seeds << " | " << WithInterval(p.relmse, p.relmseCi95, "%.4f") << " | " << Num(p.relmseDisocc, "%.4f")
        << " | " << Num(p.flip, "%.4f") << " | " << Num(p.lumaRatio, "%.4f") << " | " << Num(p.flicker, "%.4f")
        << " | " << Num(p.msPerFrame, "%.1f") << " | " << Num(p.shadowRaysPerPixel, "%.2f") << " | "
        << Num(p.efficiency, "%.3g") << " | " << (p.pareto ? "yes" : "") << " |\n";
    o << "\n### Equal time\n\nFor each budget (every distinct ms/frame of the sequence's results), each preset's "
         "lowest relmse among its configurations within 5% of the budget.\n\n"
      << BudgetTable(points, &SweepPoint::msPerFrame, "ms/frame");
    o << "\n### Equal samples\n\nThe same with shadow rays per pixel as the budget.\n\n"
      << BudgetTable(points, &SweepPoint::shadowRaysPerPixel, "shadow rays/px");
    bool ensembles = false;
    for (const SweepPoint& p : points) ensembles = ensembles || !std::isnan(p.bias2);
    if (ensembles) {
      o << "\n### Seed ensembles\n\nAcross each configuration's seeds, in relmse's units: relmse = bias² + variance + "
           "the reference's noise, in expectation. bias² is corrected for the seeds' own noise and the reference's "
           "(an unbiased estimator reads 0 within its interval); variance is one seed's. Intervals are 95%: Student "
           "t over seeds for relmse, the jackknife over seeds (3 seeds or more) for bias² and variance.\n\n"
           "| config | preset | seeds | relmse | bias² | variance | bias² share |\n| --- | --- | --- | --- | --- | --- "
           "| --- |\n";
      for (const SweepPoint& p : points) {
        if (std::isnan(p.bias2)) continue;
        const double share = p.bias2 + p.variance > 0.0 ? std::max(0.0, p.bias2) / (p.bias2 + p.variance) : NAN;
        o << "| " << p.config.name << " | `" << p.config.preset << "` | " << p.seeds << " | "
          << WithInterval(p.relmse, p.relmseCi95, "%.4g") << " | " << WithInterval(p.bias2, p.bias2Ci95, "%.3g")
          << " | " << WithInterval(p.variance, p.varianceCi95, "%.3g") << " | " << Num(share * 100.0, "%.1f")
          << (std::isnan(share) ? "" : "%") << " |\n";
      }
    }
    o << "\n";
  }
  return o.str();
}

}  // namespace restir
