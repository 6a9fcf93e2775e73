#include "sim/output/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "sim/util/text.h"

namespace restir {

namespace {

const char* const kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};

double NiceStep(double range, int targetTicks) {
  if (!(range > 0.0) || !std::isfinite(range)) return 1.0;
  const double raw = range / targetTicks;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nice = f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0;
  return nice * mag;
}

std::string TickLabel(double v, double step) {
  if (std::fabs(v) < step * 1e-9) v = 0.0;
  char buf[64];
  const double a = std::fabs(v);
  if (v != 0.0 && (a >= 1e5 || a < 1e-3)) {
    std::snprintf(buf, sizeof(buf), "%.2g", v);
  } else {
    const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
    std::snprintf(buf, sizeof(buf), "%.*f", std::min(decimals, 6), v);
  }
  return buf;
}

std::string Coord(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f", v);
  return buf;
}

std::string Short(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

// One axis: data range to plot coordinates, and its ticks.
struct Axis {
  bool log = false;
  double lo = 0.0, hi = 1.0;  // in axis units (log10 for a log axis)
  double step = 1.0;          // linear axes
  bool Usable(double v) const { return std::isfinite(v) && (!log || v > 0.0); }
  double Unit(double v) const { return log ? std::log10(v) : v; }
  double Fraction(double v) const { return (Unit(v) - lo) / (hi - lo); }
  // Tick positions (data values) and labels.
  std::vector<std::pair<double, std::string>> Ticks() const {
    std::vector<std::pair<double, std::string>> out;
    if (log) {  // quarter decades
      for (int k = static_cast<int>(std::floor(lo * 4)); k <= static_cast<int>(std::ceil(hi * 4)); ++k) {
        const double u = k / 4.0;
        if (u >= lo && u <= hi) out.emplace_back(std::pow(10.0, u), Short(std::pow(10.0, u)));
      }
    } else {
      for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-6; v += step)
        out.emplace_back(v, TickLabel(v, step));
    }
    return out;
  }
};

Axis MakeAxis(bool log, double lo, double hi, bool fromZero, int ticks, double minStep) {
  Axis a;
  a.log = log;
  if (log) {
    if (!std::isfinite(lo)) lo = 1.0, hi = 10.0;
    a.lo = std::floor(std::log10(lo) * 10) / 10 - 0.05;
    a.hi = std::ceil(std::log10(hi) * 10) / 10 + 0.05;
    return a;
  }
  if (!std::isfinite(lo)) lo = 0.0, hi = 1.0;
  if (fromZero) lo = std::min(lo, 0.0);
  if (hi <= lo) {
    if (fromZero) hi = lo + 1.0;
    else lo -= 0.5, hi += 0.5;
  }
  a.step = std::max(minStep, NiceStep(hi - lo, ticks));
  a.lo = fromZero ? std::floor(lo / a.step) * a.step : lo;
  a.hi = fromZero ? std::ceil(hi / a.step) * a.step : hi;
  return a;
}

}  // namespace

const char* SeriesColour(size_t k) { return kPalette[k % (sizeof(kPalette) / sizeof(kPalette[0]))]; }

std::string SvgPlot(const Plot& plot) {
  const double W = plot.width, H = plot.height, left = 64, right = plot.legendWidth, top = 26, bottom = 36;
  const double pw = W - left - right, ph = H - top - bottom;
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  Axis probeX, probeY;
  probeX.log = plot.logX, probeY.log = plot.logY;
  for (const PlotSeries& s : plot.series)
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!probeX.Usable(s.x[i]) || !probeY.Usable(s.y[i])) continue;
      xlo = std::min(xlo, s.x[i]), xhi = std::max(xhi, s.x[i]);
      ylo = std::min(ylo, s.y[i]), yhi = std::max(yhi, s.y[i]);
      if (i < s.yLow.size() && probeY.Usable(s.yLow[i])) ylo = std::min(ylo, s.yLow[i]);
      if (i < s.yHigh.size() && probeY.Usable(s.yHigh[i])) yhi = std::max(yhi, s.yHigh[i]);
    }
  // Markers alone sit inside the frame: a point at the range's end would be drawn half outside it.
  bool markersOnly = !plot.series.empty();
  for (const PlotSeries& s : plot.series) markersOnly = markersOnly && !s.line;
  if (markersOnly && std::isfinite(xlo) && xhi >= xlo) {
    if (plot.logX && xlo > 0.0) {
      xlo /= 1.1, xhi *= 1.1;
    } else if (!plot.logX) {
      const double pad = 0.06 * std::max(xhi - xlo, std::fabs(xhi) * 0.1);
      xlo -= pad, xhi += pad;
    }
  }
  const Axis ax = MakeAxis(plot.logX, xlo, xhi, false, 8, plot.logX ? 0.0 : 1.0);
  const Axis ay = MakeAxis(plot.logY, ylo, yhi, plot.yFromZero, 5, 0.0);
  auto X = [&](double x) { return left + ax.Fraction(x) * pw; };
  auto Y = [&](double y) { return top + ph - ay.Fraction(y) * ph; };
  const bool styled = !plot.cssClass.empty();

  std::ostringstream o;
  o << "<svg";
  if (styled) o << " class=\"" << XmlEscape(plot.cssClass) << "\"";
  if (!plot.dataMetric.empty()) o << " data-metric=\"" << XmlEscape(plot.dataMetric) << "\"";
  o << " xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" viewBox=\"0 0 " << W
    << " " << H << "\" role=\"img\" aria-label=\"" << XmlEscape(plot.title) << "\"";
  if (!styled) o << " font-family=\"sans-serif\" font-size=\"11\"";
  o << ">\n";
  if (!styled) o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << left << "\" y=\"16\" class=\"title\">" << XmlEscape(plot.title) << "</text>\n";
  for (const auto& [v, label] : ay.Ticks()) {
    const std::string py = Coord(Y(v));
    o << "<line class=\"grid\" stroke=\"#e6e6e6\" x1=\"" << left << "\" y1=\"" << py << "\" x2=\"" << left + pw
      << "\" y2=\"" << py << "\"/><text class=\"tick\" x=\"" << left - 4 << "\" y=\"" << py
      << "\" text-anchor=\"end\" dy=\"0.32em\">" << label << "</text>\n";
  }
  for (const auto& [v, label] : ax.Ticks()) {
    const std::string px = Coord(X(v));
    o << "<line class=\"axis\" stroke=\"#555\" x1=\"" << px << "\" y1=\"" << top + ph << "\" x2=\"" << px
      << "\" y2=\"" << top + ph + 4 << "\"/><text class=\"tick\" x=\"" << px << "\" y=\"" << top + ph + 15
      << "\" text-anchor=\"middle\">" << label << "</text>\n";
  }
  o << "<line class=\"axis\" stroke=\"#555\" x1=\"" << left << "\" y1=\"" << top + ph << "\" x2=\"" << left + pw
    << "\" y2=\"" << top + ph << "\"/><line class=\"axis\" stroke=\"#555\" x1=\"" << left << "\" y1=\"" << top
    << "\" x2=\"" << left << "\" y2=\"" << top + ph << "\"/>\n";
  o << "<text class=\"tick\" x=\"" << left + pw / 2 << "\" y=\"" << H - 4 << "\" text-anchor=\"middle\">"
    << XmlEscape(plot.xLabel) << "</text>\n";
  if (!plot.yLabel.empty())
    o << "<text class=\"tick\" x=\"12\" y=\"" << top + ph / 2 << "\" transform=\"rotate(-90 12 " << top + ph / 2
      << ")\" text-anchor=\"middle\">" << XmlEscape(plot.yLabel) << "</text>\n";
  if (plot.guide.size() > 1) {
    o << "<polyline fill=\"none\" stroke=\"#888\" stroke-dasharray=\"4 3\" points=\"";
    for (size_t i = 0; i < plot.guide.size(); ++i)
      o << (i ? " " : "") << Coord(X(plot.guide[i].first)) << "," << Coord(Y(plot.guide[i].second));
    o << "\"/>\n";
  }
  for (size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& s = plot.series[k];
    const char* colour = SeriesColour(k);
    std::vector<size_t> points;
    for (size_t i = 0; i < s.x.size(); ++i)
      if (ax.Usable(s.x[i]) && ay.Usable(s.y[i])) points.push_back(i);
    if (s.line) {
      o << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" data-preset=\""
        << XmlEscape(s.name) << "\" points=\"";
      for (size_t j = 0; j < points.size(); ++j)
        o << (j ? " " : "") << Coord(X(s.x[points[j]])) << "," << Coord(Y(s.y[points[j]]));
      o << "\"/>\n";
    }
    if (!s.line || points.size() == 1) {  // a single point draws no line: mark it
      for (size_t i : points) {
        const bool big = i < s.emphasised.size() && s.emphasised[i];
        if (i < s.yLow.size() && i < s.yHigh.size() && ay.Usable(s.yLow[i]) && ay.Usable(s.yHigh[i])) {
          const std::string cx = Coord(X(s.x[i])), l = Coord(X(s.x[i]) - 4), r = Coord(X(s.x[i]) + 4);
          const std::string y0 = Coord(Y(s.yLow[i])), y1 = Coord(Y(s.yHigh[i]));
          o << "<path class=\"interval\" fill=\"none\" stroke=\"" << colour << "\" d=\"M" << cx << "," << y0 << "V" << y1
            << "M" << l << "," << y0 << "H" << r << "M" << l << "," << y1 << "H" << r << "\"/>\n";
        }
        o << "<circle cx=\"" << Coord(X(s.x[i])) << "\" cy=\"" << Coord(Y(s.y[i])) << "\" r=\""
          << (s.line ? 2.5 : big ? 5.0 : 3.5) << "\" fill=\"" << colour << "\""
          << (big && !s.line ? " stroke=\"#222\" stroke-width=\"1.5\"" : "") << ">";
        if (i < s.titles.size()) o << "<title>" << XmlEscape(s.titles[i]) << "</title>";
        o << "</circle>\n";
      }
    }
    const double ly = top + 8 + 15.0 * k;
    if (s.line)
      o << "<line x1=\"" << W - right + 10 << "\" y1=\"" << Coord(ly) << "\" x2=\"" << W - right + 28 << "\" y2=\""
        << Coord(ly) << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/>";
    else
      o << "<circle cx=\"" << W - right + 19 << "\" cy=\"" << Coord(ly) << "\" r=\"4\" fill=\"" << colour << "\"/>";
    o << "<text class=\"legend\" x=\"" << W - right + 32 << "\" y=\"" << Coord(ly) << "\" dy=\"0.32em\">"
      << XmlEscape(s.name) << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

}  // namespace restir
