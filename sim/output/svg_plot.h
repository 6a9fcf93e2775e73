// The one plotter behind report.html's per-frame plots and sweep.svg's Pareto plot: self-contained SVG (no
// scripts), one palette, linear or logarithmic axes.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace restir {

// One series: a polyline through its points, or a marker at each. Non-finite points are skipped (and, on a
// log axis, non-positive ones).
struct PlotSeries {
  std::string name;                  // legend entry, and the polyline's data-preset attribute
  std::vector<double> x, y;          // the points
  bool line = true;                  // a polyline (a lone point gets a marker), or markers only
  std::vector<std::string> titles;   // markers: each point's tooltip (empty: none)
  std::vector<uint8_t> emphasised;   // markers: nonzero draws a point larger, outlined (empty: none)
  std::vector<double> yLow, yHigh;   // markers: a vertical interval bar per point (empty, or non-finite: none)
};

struct Plot {
  std::string title;       // drawn above the plot area
  std::string xLabel;      // under the x axis
  std::string yLabel;      // beside the y axis (empty: none)
  bool logX = false;       // decade axes
  bool logY = false;
  bool yFromZero = true;   // a linear y axis includes 0
  double width = 600.0, height = 250.0;
  double legendWidth = 150.0;  // right margin holding the legend
  std::string cssClass;    // class attribute of the <svg> (report.html styles "plot"); empty: inline styling
  std::string dataMetric;  // data-metric attribute of the <svg>, when not empty
  std::vector<PlotSeries> series;
  std::vector<std::pair<double, double>> guide;  // a dashed grey polyline (e.g. a Pareto front), when not empty
};

std::string SvgPlot(const Plot& plot);

// Colour of series k: every plot uses the same palette, in the same order.
const char* SeriesColour(size_t k);

}  // namespace restir
