#include "sim/output/report.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sim/util/atomic_file.h"
#include "sim/output/frame_writer.h"
#include "sim/output/heat_map.h"
#include "sim/output/png_encode.h"
#include "sim/output/report_motion.h"
#include "sim/util/input_file.h"
#include "sim/metrics/summary.h"
#include "sim/output/svg_plot.h"
#include "sim/util/text.h"
#include "sim/util/input_error.h"

namespace restir {

namespace fs = std::filesystem;

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

Recovery ComputeRecovery(const std::vector<int>& frames, const std::vector<double>& disoccRecent,
                         const std::vector<double>& relmse, const std::vector<double>& relmseDisocc) {
  Recovery r;
  // The first row has no previous frame: every pixel is new there, although no disocclusion is recorded.
  const size_t first = frames.size() > 1 ? 1 : 0;
  std::vector<double> steady;
  for (size_t i = first; i < frames.size(); ++i)
    if (!(disoccRecent[i] > 0.0)) steady.push_back(relmse[i]);
  if (steady.empty()) {
    steady.assign(relmse.begin() + first, relmse.end());
    r.steadyFromAllFrames = true;
  }
  r.steadyRelmse = Median(steady);
  const double threshold = 2.0 * r.steadyRelmse;
  for (size_t i = 0; i < frames.size();) {
    if (!(disoccRecent[i] > 0.0)) {
      ++i;
      continue;
    }
    RecoveryWindow w;
    w.startFrame = frames[i];
    size_t j = i;
    while (j < frames.size() && disoccRecent[j] > 0.0 && (j == i || frames[j] == frames[j - 1] + 1)) {
      if (w.framesToRecover < 0 && relmseDisocc[j] <= threshold) w.framesToRecover = static_cast<int>(j - i);
      ++j;
    }
    w.length = static_cast<int>(j - i);
    r.windows.push_back(w);
    i = j;
  }
  return r;
}

std::vector<int> ReportStripFrames(const std::vector<int>& frames) {
  std::vector<int> chosen;
  if (frames.empty()) return chosen;
  for (int f : {frames.front(), frames[frames.size() / 2], frames.back()})
    if (std::find(chosen.begin(), chosen.end(), f) == chosen.end()) chosen.push_back(f);
  return chosen;
}

const std::vector<std::string>& ReportPlotMetrics() {
  static const std::vector<std::string> kMetrics = {
      "relmse",         "luma_rmse",           "rmspe",           "flip",
      "luma_ratio",     "flicker",             "stability_luma_rmse", "accum_rmse",
      "relmse_disocc",  "flip_disocc",         "ms_frame",        "temporal_acceptance",
      "disocc_fraction", "disocc_recent_fraction", "mean_confidence", "contrib_initial",
      "contrib_spatial", "contrib_shaded", "contrib_spatial_disocc", "sample_age", "duplicate_fraction"};
  return kMetrics;
}

namespace {

using Json = nlohmann::ordered_json;

// JSON number, or null when not finite (JSON has no NaN).
Json Num(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

std::string Fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, v);
  return buf;
}


// Percent-encodes a path component for a relative URL (preset names are identifiers, but be safe).
std::string UrlPath(const std::string& s) {
  std::string o;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '/') {
      o += static_cast<char>(c);
    } else {
      char buf[4];
      std::snprintf(buf, sizeof(buf), "%%%02X", c);
      o += buf;
    }
  }
  return o;
}

// Everything summary.json and the summary table say about one preset.
struct PresetSummary {
  std::string name;
  int rows = 0;
  std::vector<double> means;          // per numeric column
  int postRevealRows = 0;
  std::vector<std::pair<std::string, double>> postReveal;  // *_disocc column -> mean over post-reveal rows
  bool hasRecovery = false;
  Recovery recovery;
  double secondsPerFrame = NAN;
  double efficiency = NAN;
  double lumaRatioAccumulated = NAN;
  std::vector<std::pair<std::string, MetricInterval>> intervals;  // kIntervalMetrics present in metrics.csv
};

double SummaryMean(const MetricsTable& t, const PresetSummary& s, const std::string& name) {
  const int c = t.Column(name);
  return c < 0 ? NAN : s.means[c];
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

PresetSummary Summarize(const MetricsTable& t, const PresetSeries& p) {
  PresetSummary s;
  s.name = p.name;
  s.rows = static_cast<int>(p.frames.size());
  for (size_t c = 0; c < p.values.size(); ++c) s.means.push_back(ColumnMean(t.columns[c], p.values[c]));
  const int recent = t.Column("disocc_recent_fraction");
  if (recent >= 0) {
    for (double f : p.values[recent]) s.postRevealRows += f > 0.0;
    for (size_t c = 0; c < t.columns.size(); ++c)
      if (EndsWith(t.columns[c], "_disocc"))
        s.postReveal.emplace_back(t.columns[c], PostRevealMean(p.values[c], p.values[recent]));
    const int relmse = t.Column("relmse"), relmseDisocc = t.Column("relmse_disocc");
    if (relmse >= 0 && relmseDisocc >= 0 && !p.frames.empty()) {
      s.hasRecovery = true;
      s.recovery = ComputeRecovery(p.frames, p.values[recent], p.values[relmse], p.values[relmseDisocc]);
    }
  }
  s.secondsPerFrame = SummaryMean(t, s, "ms_frame") / 1000.0;
  s.efficiency = Efficiency(SummaryMean(t, s, "relmse"), SummaryMean(t, s, "ms_frame"));
  const int luma = t.Column("luma_sum"), refLuma = t.Column("reference_luma_sum");
  if (luma >= 0 && refLuma >= 0) s.lumaRatioAccumulated = AccumulatedLumaRatio(p.values[luma], p.values[refLuma]);
  for (const char* metric : kIntervalMetrics) {
    const int c = t.Column(metric), sd = t.Column(std::string(metric) + "_ref_sd");
    const int seed = t.Column(std::string(metric) + "_seed_sd");
    if (c < 0) continue;
    const std::vector<double> none;
    s.intervals.emplace_back(metric, ColumnInterval(p.values[c], sd >= 0 && refLuma >= 0 ? p.values[sd] : none,
                                                    sd >= 0 && refLuma >= 0 ? p.values[refLuma] : none,
                                                    seed >= 0 ? p.values[seed] : none));
  }
  return s;
}

double RecoveryMean(const Recovery& r, int& recovered) {
  recovered = 0;
  double sum = 0.0;
  for (const RecoveryWindow& w : r.windows)
    if (w.framesToRecover >= 0) {
      ++recovered;
      sum += w.framesToRecover;
    }
  return recovered ? sum / recovered : NAN;
}

const char* kRecoveryDefinition =
    "A post-reveal window is a maximal run of consecutive frames with disocc_recent_fraction > 0; its first frame "
    "is the reveal. The steady level is the median relmse over frames with disocc_recent_fraction == 0, leaving out "
    "the run's first frame (it has no history: every pixel is new there); over all frames but the first when there "
    "are none. A window's frames_to_recover is the number of frames from the reveal to the "
    "first frame of the window whose relmse_disocc <= 2 x steady level (0: already at the reveal frame); null when "
    "no frame of the window gets there (censored: the mask emptied or the run ended first).";

Json SummaryJson(const MetricsTable& t, const std::vector<PresetSummary>& sums, const Json& run) {
  Json j;
  j["sequence"] = run.contains("sequence") && run["sequence"].contains("name") ? run["sequence"]["name"] : Json(nullptr);
  j["metrics"] = "metrics.csv";
  j["definitions"] = {
      {"mean", "mean over the preset's frames of each numeric metrics.csv column; the first frame is left out of "
               "the timings (ms_*), flicker, stability_luma_rmse and temporal_acceptance (docs/metrics.md)"},
      {"post_reveal", "mean of each *_disocc column over the frames with disocc_recent_fraction > 0"},
      {"recovery", kRecoveryDefinition},
      {"seconds_per_frame", "mean ms_frame / 1000"},
      {"efficiency", "1 / (mean relmse * seconds_per_frame)"},
      {"luma_ratio_accumulated", "sum of luma_sum / sum of reference_luma_sum over the frames"},
      {"interval", "per error metric, the 95% interval of its mean: mean ± half_width, half_width = 1.96 sqrt("
                   "estimator_sd² + reference_sd²); estimator_sd from the means of batches of 8 frames (null below 4 "
                   "batches), reference_sd from the *_ref_sd columns (frames sharing a reference add linearly); "
                   "reference_dominated: the reference's part is the larger (docs/metrics.md, Intervals)"}};
  Json presets = Json::object();
  for (const PresetSummary& s : sums) {
    Json p;
    p["frames"] = s.rows;
    Json mean = Json::object();
    for (size_t c = 0; c < t.columns.size(); ++c) mean[t.columns[c]] = Num(s.means[c]);
    p["mean"] = mean;
    if (t.Column("disocc_recent_fraction") >= 0) {
      Json post = Json::object();
      post["frames"] = s.postRevealRows;
      Json pm = Json::object();
      for (const auto& [name, v] : s.postReveal) pm[name] = Num(v);
      post["mean"] = pm;
      p["post_reveal"] = post;
    } else {
      p["post_reveal"] = nullptr;
    }
    if (s.hasRecovery) {
      Json rec;
      rec["steady_relmse"] = Num(s.recovery.steadyRelmse);
      rec["steady_from_all_frames"] = s.recovery.steadyFromAllFrames;
      rec["threshold_relmse_disocc"] = Num(2.0 * s.recovery.steadyRelmse);
      Json windows = Json::array();
      for (const RecoveryWindow& w : s.recovery.windows)
        windows.push_back({{"reveal_frame", w.startFrame},
                           {"frames", w.length},
                           {"frames_to_recover", w.framesToRecover >= 0 ? Json(w.framesToRecover) : Json(nullptr)}});
      rec["windows"] = windows;
      int recovered = 0;
      const double m = RecoveryMean(s.recovery, recovered);
      rec["recovered_windows"] = recovered;
      rec["mean_frames_to_recover"] = Num(m);
      p["recovery"] = rec;
    } else {
      p["recovery"] = nullptr;
    }
    p["seconds_per_frame"] = Num(s.secondsPerFrame);
    p["efficiency"] = Num(s.efficiency);
    p["luma_ratio_accumulated"] = Num(s.lumaRatioAccumulated);
    Json intervals = Json::object();
    for (const auto& [metric, in] : s.intervals)
      intervals[metric] = {{"mean", Num(in.mean)},
                           {"half_width", Num(in.halfWidth)},
                           {"estimator_sd", Num(in.estimatorSd)},
                           {"reference_sd", Num(in.referenceSd)},
                           {"reference_dominated", in.referenceDominated}};
    p["interval"] = intervals;
    presets[s.name] = p;
  }
  j["presets"] = presets;
  return j;
}

// ---- speed against error ----

// One preset's mean error against its mean ms per frame, for the speed-against-error plot and summary.json.
struct SpeedPoint {
  std::string preset;
  double msFrame = NAN, error = NAN;
  double referenceHalfWidth = NAN;  // 1.96 x the reference's sd of the mean error (kIntervalMetrics only)
  bool pareto = false;
};

std::vector<SpeedPoint> SpeedVsError(const MetricsTable& t, const std::vector<PresetSummary>& sums,
                                     const std::string& metric) {
  std::vector<SpeedPoint> points;
  std::vector<double> cost, error;
  for (const PresetSummary& s : sums) {
    SpeedPoint p;
    p.preset = s.name;
    p.msFrame = SummaryMean(t, s, "ms_frame");
    p.error = SummaryMean(t, s, metric);
    for (const auto& [name, in] : s.intervals)
      if (name == metric && std::isfinite(in.referenceSd)) p.referenceHalfWidth = 1.96 * in.referenceSd;
    cost.push_back(p.msFrame);
    error.push_back(p.error);
    points.push_back(p);
  }
  const std::vector<uint8_t> front = ParetoFront(cost, error);
  for (size_t i = 0; i < points.size(); ++i) points[i].pareto = front[i] != 0;
  return points;
}

const char* const kSpeedMetrics[] = {"relmse", "flip"};

std::string SpeedPlot(const std::vector<SpeedPoint>& points, const std::string& metric) {
  Plot plot;
  plot.title = metric + " against ms/frame; outlined and joined: the Pareto front";
  plot.xLabel = "ms per frame (estimator passes, reference excluded)";
  plot.yLabel = metric;
  plot.cssClass = "speed";
  plot.dataMetric = metric;
  plot.width = 640;
  plot.height = 300;
  std::vector<std::pair<double, double>> front;
  for (const SpeedPoint& p : points) {
    PlotSeries s;
    s.name = p.preset;
    s.line = false;
    s.x = {p.msFrame};
    s.y = {p.error};
    s.emphasised = {static_cast<uint8_t>(p.pareto)};
    s.titles = {p.preset + ": " + Fmt(p.error) + " at " + Fmt(p.msFrame) + " ms/frame" +
                (std::isfinite(p.referenceHalfWidth) ? " (reference noise ±" + Fmt(p.referenceHalfWidth) + ")" : "")};
    if (std::isfinite(p.referenceHalfWidth)) {
      s.yLow = {p.error - p.referenceHalfWidth};
      s.yHigh = {p.error + p.referenceHalfWidth};
    }
    plot.series.push_back(std::move(s));
    if (p.pareto) front.emplace_back(p.msFrame, p.error);
  }
  std::sort(front.begin(), front.end());
  plot.guide = front;
  return restir::SvgPlot(plot);
}

void HtmlSpeedVsError(std::ostream& o, const MetricsTable& t, const std::vector<PresetSummary>& sums) {
  if (t.Column("ms_frame") < 0) return;
  o << "<h2 id=\"speed\">Speed against error</h2>\n<div class=\"plots\">\n";
  bool any = false;
  for (const char* metric : kSpeedMetrics)
    if (t.Column(metric) >= 0) {
      o << SpeedPlot(SpeedVsError(t, sums, metric), metric);
      any = true;
    }
  o << "</div>\n";
  if (any)
    o << "<p class=\"note\">Lower left is better. A preset is on the Pareto front when no other is at most as slow "
         "and at most as wrong, and better in one. Bars: the 95% interval of the mean error owed to the reference's "
         "own noise (another reference would move every preset's error this much; docs/metrics.md, Intervals); "
         "FLIP has none.</p>\n";
}

Json SpeedVsErrorJson(const MetricsTable& t, const std::vector<PresetSummary>& sums) {
  Json metrics = Json::object();
  for (const char* metric : kSpeedMetrics) {
    if (t.Column(metric) < 0 || t.Column("ms_frame") < 0) continue;
    Json points = Json::array();
    for (const SpeedPoint& p : SpeedVsError(t, sums, metric))
      points.push_back({{"preset", p.preset},
                        {"ms_frame", Num(p.msFrame)},
                        {"mean", Num(p.error)},
                        {"reference_half_width", Num(p.referenceHalfWidth)},
                        {"pareto", p.pareto}});
    metrics[metric] = points;
  }
  return {{"x", "ms_frame"},
          {"definition", "per preset, the mean over frames of the metric against the mean ms_frame; pareto: no "
                         "other preset is at most as slow and as wrong and better in one; reference_half_width: "
                         "1.96 x the reference's sd of the mean (relmse only; null for flip)"},
          {"metrics", metrics}};
}

// ---- plots ----

std::string SvgPlot(const MetricsTable& t, const std::string& metric) {
  const int c = t.Column(metric);
  Plot plot;
  plot.title = metric;
  plot.xLabel = "frame";
  plot.cssClass = "plot";
  plot.dataMetric = metric;
  for (const PresetSeries& p : t.presets) {
    PlotSeries s;
    s.name = p.name;
    s.x.assign(p.frames.begin(), p.frames.end());
    s.y = p.values[c];
    plot.series.push_back(std::move(s));
  }
  return restir::SvgPlot(plot);
}

// ---- images ----

// A heat map as a palette PNG: the pixels of HeatMapRgb in a third of the bytes.
void WriteMapPng(const std::string& path, int w, int h, const std::vector<double>& values, ColourMap map) {
  WriteFileAtomic(path, EncodeIndexedPng(HeatMapLevels(values), w, h, HeatMapPalette(map)));
}

// The heat maps generated from one frame's EXR (empty paths when the EXR lacks the layers).
struct FrameMaps {
  std::string error;  // relative path of the error heat map, or ""
  std::string flip;   // relative path of the FLIP map, or ""
};

// A frame file the report links or reads: absent is fine (the run wrote none, or --no-images), but one that is
// there must be a whole regular file the image library reads, or the report would link a broken image.
bool FrameFileUsable(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || st.type() == fs::file_type::not_found) return false;
  if (st.type() != fs::file_type::regular) throw InputError(path + ": error: not a regular file");
  return true;
}

[[noreturn]] void Unreadable(const std::string& path, const std::string& why) {
  throw InputError(OneLine(path + ": error: cannot read frame (" + why + ")"));
}

// Reads a whole image file (every channel as float) or throws naming it: a truncated EXR or PNG fails here.
std::vector<float> ReadWholeImage(const std::string& path, OIIO::ImageSpec& spec) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) Unreadable(path, OIIO::geterror());
  spec = in->spec();
  if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.width > 16384 || spec.height > 16384 ||
      spec.nchannels > 64)
    Unreadable(path, "unexpected size");
  std::vector<float> px(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data())) Unreadable(path, in->geterror());
  in->close();
  return px;
}

// What run.json says every frame file of the run is; a file that is not that is another run's (or nobody's) and
// is refused, where the report would otherwise show it as this run's frame.
struct FrameExpectation {
  bool known = false;        // run.json was there to say (without it nothing is checked)
  int width = 0, height = 0;  // run.json's resolution
  bool hasReference = false;  // the run had a reference: the EXRs carry its layers, the previews its panel
  std::string sequenceHash;   // run.json's sequence.contentHash, stamped on every EXR
};

std::string Size(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

[[noreturn]] void NotThisRunsFrame(const std::string& path, const std::string& why) {
  throw InputError(OneLine(path + ": error: not a frame of this run (" + why + ")"));
}

// A preview the report links must be a whole PNG: the signature, then chunks whose lengths lead exactly to IEND
// at the end of the file (a cut file fails), and, as run.json says, the run's size (twice as wide with a reference:
// estimate and reference side by side). Checked without decoding, so libpng prints nothing of its own.
void CheckPngStructure(const std::string& path, const FrameExpectation& expect) {
  std::string bytes, problem;
  if (!TryReadRegularFile(path, size_t(1) << 30, bytes, problem)) Unreadable(path, problem);
  static const char kSignature[8] = {'\x89', 'P', 'N', 'G', '\r', '\n', '\x1a', '\n'};
  if (bytes.size() < 8 || bytes.compare(0, 8, kSignature, 8) != 0) Unreadable(path, "not a PNG");
  if (expect.known && bytes.size() >= 24 && bytes.compare(12, 4, "IHDR") == 0) {
    auto word = [&](size_t at) {
      uint32_t v = 0;
      for (size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
      return v;
    };
    const int64_t w = word(16), h = word(20);
    const int64_t wantW = int64_t(expect.width) * (expect.hasReference ? 2 : 1);
    if (w != wantW || h != expect.height)
      NotThisRunsFrame(path, "a " + std::to_string(w) + "x" + std::to_string(h) + " preview where run.json's " +
                                 Size(expect.width, expect.height) + " run writes " +
                                 std::to_string(wantW) + "x" + std::to_string(expect.height));
  }
  if (PngIsWhole(bytes)) return;
  Unreadable(path, "cut short or damaged: no IEND chunk at its end");
}

// The EXR is the run's frame: its size, the channels the run writes, the sequence it was rendered from.
void CheckFrameExr(const std::string& path, const OIIO::ImageSpec& spec, const FrameExpectation& expect) {
  if (!expect.known) return;
  if (spec.width != expect.width || spec.height != expect.height)
    NotThisRunsFrame(path, Size(spec.width, spec.height) + " pixels where run.json's resolution is " +
                               Size(expect.width, expect.height));
  std::vector<std::string> needed = {"R", "G", "B", "disocclusion.Y", "depth.Z"};
  if (expect.hasReference)
    needed.insert(needed.end(), {"reference.R", "reference.G", "reference.B", "error.R", "error.G", "error.B",
                                 "flip.Y"});
  for (const std::string& name : needed)
    if (std::find(spec.channelnames.begin(), spec.channelnames.end(), name) == spec.channelnames.end())
      NotThisRunsFrame(path, "no channel " + name + ", which every frame of this run has");
  const std::string hash = spec.get_string_attribute("restir:sequenceHash");
  if (hash != expect.sequenceHash)
    NotThisRunsFrame(path, hash.empty() ? "no restir:sequenceHash attribute; this run's sequence is " +
                                              expect.sequenceHash
                                        : "rendered from sequence " + hash + ", this run's is " +
                                              expect.sequenceHash);
}

FrameMaps WriteFrameMaps(const std::string& outDir, const std::string& preset, int frame,
                         const FrameExpectation& expect) {
  FrameMaps maps;
  const std::string exr = (fs::path(outDir) / "frames" / preset / (FrameNumber(frame) + ".exr")).string();
  if (!FrameFileUsable(exr)) return maps;
  OIIO::ImageSpec spec;
  const std::vector<float> px = ReadWholeImage(exr, spec);
  CheckFrameExr(exr, spec, expect);
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  auto channel = [&](const char* name) {
    for (int i = 0; i < nc; ++i)
      if (spec.channelnames[i] == name) return i;
    return -1;
  };
  const int er[3] = {channel("error.R"), channel("error.G"), channel("error.B")};
  const int rr[3] = {channel("reference.R"), channel("reference.G"), channel("reference.B")};
  const int fl = channel("flip.Y");
  const std::string rel = "report_images/" + preset + "/" + FrameNumber(frame);
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<double> v(n);
  if (er[0] >= 0 && er[1] >= 0 && er[2] >= 0 && rr[0] >= 0 && rr[1] >= 0 && rr[2] >= 0) {
    for (size_t i = 0; i < n; ++i) {
      const float e[3] = {px[i * nc + er[0]], px[i * nc + er[1]], px[i * nc + er[2]]};
      const float r[3] = {px[i * nc + rr[0]], px[i * nc + rr[1]], px[i * nc + rr[2]]};
      v[i] = PixelRelativeError(e, r);
    }
    WriteMapPng((fs::path(outDir) / (rel + "_error.png")).string(), w, h, v, ColourMap::kInferno);
    maps.error = rel + "_error.png";
  }
  if (fl >= 0) {
    for (size_t i = 0; i < n; ++i) v[i] = px[i * nc + fl];
    WriteMapPng((fs::path(outDir) / (rel + "_flip.png")).string(), w, h, v, ColourMap::kMagma);
    maps.flip = rel + "_flip.png";
  }
  return maps;
}

std::vector<int> ChosenFrames(const MetricsTable& t) {
  std::vector<int> all;
  for (const PresetSeries& p : t.presets) all.insert(all.end(), p.frames.begin(), p.frames.end());
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return ReportStripFrames(all);
}

// ---- run.json ----

struct RunInfo {
  bool present = false;
  std::string text;  // the file as written
  Json json;
};

RunInfo ReadRunJson(const std::string& path) {
  RunInfo info;
  std::string problem;
  if (!TryReadRegularFile(path, size_t(16) << 20, info.text, problem)) {
    if (problem == "no such file") return info;
    throw InputError(path + ": error: cannot read (" + problem + ")");
  }
  info.present = true;
  try {
    info.json = Json::parse(info.text);
  } catch (const nlohmann::json::parse_error& e) {
    int line = 1;
    for (size_t i = 0; i < std::min<size_t>(e.byte, info.text.size()); ++i)
      if (info.text[i] == '\n') ++line;
    throw InputError(path + ":" + std::to_string(line) + ": error: not valid JSON (" + e.what() + ")");
  }
  if (!info.json.is_object()) throw InputError(path + ":1: error: run.json is not a JSON object");
  return info;
}

// What run.json says the frames are; unknown (nothing checked) without a run.json or with one that lacks the fields.
FrameExpectation ExpectedFrames(const RunInfo& run) {
  FrameExpectation e;
  if (!run.present) return e;
  const Json& j = run.json;
  const auto res = j.find("resolution");
  const auto seq = j.find("sequence");
  if (res == j.end() || !res->is_array() || res->size() != 2 || !(*res)[0].is_number_integer() ||
      !(*res)[1].is_number_integer() || seq == j.end() || !seq->is_object() || !seq->contains("contentHash") ||
      !(*seq)["contentHash"].is_string())
    return e;
  e.known = true;
  e.width = (*res)[0].get<int>();
  e.height = (*res)[1].get<int>();
  e.sequenceHash = (*seq)["contentHash"].get<std::string>();
  e.hasReference = j.contains("reference") && j["reference"].is_object();
  return e;
}

std::string JsonText(const Json& j) {
  if (j.is_string()) return j.get<std::string>();
  if (j.is_null()) return "—";
  return j.dump();
}

// ---- HTML ----

const char* kCss = R"(body{font-family:system-ui,-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:1340px}
h1{font-size:1.5em;margin-bottom:4px}h2{font-size:1.2em;margin-top:28px;border-bottom:1px solid #ccc}
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;padding:3px 7px}th{background:#f2f2f2}
td.num{text-align:right;font-variant-numeric:tabular-nums}pre{background:#f7f7f7;padding:8px;font-size:11px;max-height:320px;overflow:auto}
.plots{display:flex;flex-wrap:wrap;gap:8px}svg.plot{background:#fff;border:1px solid #ddd}
svg .title{font-size:13px;font-weight:600}svg .tick,svg .legend{font-size:10px;fill:#333}
svg .grid{stroke:#e6e6e6}svg .axis{stroke:#555}
.strip td{vertical-align:top}.strip img{image-rendering:pixelated;display:block;max-width:360px;height:auto}
.bar{display:inline-block;width:160px;height:10px;vertical-align:middle;border:1px solid #999}
.note{font-size:13px;color:#444}svg.speed{background:#fff;border:1px solid #ddd}
.crops img{max-width:none}.scrub-controls{font-size:13px;margin:6px 0;line-height:1.9}#scrub-frame{width:420px;vertical-align:middle}
.scrub-panel{display:inline-block;margin:0 8px 8px 0;font-size:12px}.scrub-view{position:relative;overflow:hidden;background:#000;cursor:grab}
.scrub-image{position:absolute;left:0;top:0;transform-origin:0 0;image-rendering:pixelated;max-width:none}
video.video{max-width:100%;display:block})";

// The page's head, title and first line.
void HtmlHead(std::ostream& o, const MetricsTable& t, const RunInfo& run) {
  const std::string seqName = run.present && run.json.contains("sequence") && run.json["sequence"].is_object() &&
                                      run.json["sequence"].contains("name")
                                  ? JsonText(run.json["sequence"]["name"])
                                  : std::string("(unknown sequence: no run.json)");
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ReSTIR Sim report: "
    << XmlEscape(seqName) << "</title>\n<style>\n" << kCss << "\n</style>\n</head>\n<body>\n";
  o << "<h1>ReSTIR Sim report: " << XmlEscape(seqName) << "</h1>\n";
  o << "<p class=\"note\">" << t.presets.size() << " preset(s); metrics from <code>metrics.csv</code>, summary in "
    << "<code>summary.json</code>; every column is defined in the project's <code>docs/metrics.md</code>.</p>\n";
}

// Configuration.
void HtmlConfiguration(std::ostream& o, const RunInfo& run) {
  o << "<h2 id=\"configuration\">Configuration</h2>\n";
  if (run.present) {
    const Json& j = run.json;
    auto get = [&](std::initializer_list<const char*> keys) -> Json {
      const Json* cur = &j;
      for (const char* k : keys) {
        if (!cur->is_object() || !cur->contains(k)) return Json(nullptr);
        cur = &(*cur)[k];
      }
      return *cur;
    };
    const std::pair<const char*, Json> rows[] = {
        {"sequence", get({"sequence", "path"})},
        {"sequence content hash", get({"sequence", "contentHash"})},
        {"frames [begin, end)", get({"frames"})},
        {"resolution", get({"resolution"})},
        {"seed", get({"seed"})},
        {"reference spp (fixed budget)", get({"reference", "targetRelativeError"}) == Json(0.0)
                                              ? get({"reference", "samplesPerPixel"})
                                              : Json(nullptr)},
        {"reference error target", get({"reference", "targetRelativeError"})},
        {"reference spp cap", get({"reference", "sppCap"})},
        {"threads", get({"threads"})},
        {"overrides (--set)", get({"overrides"})},
        {"program version", get({"version"})},
        {"status", get({"status"})},
        {"command line", get({"commandLine"})}};
    o << "<table class=\"config\">\n";
    for (const auto& [k, v] : rows)
      o << "<tr><th>" << XmlEscape(k) << "</th><td><code>" << XmlEscape(JsonText(v)) << "</code></td></tr>\n";
    o << "</table>\n<p class=\"note\">The exact configuration, <code>run.json</code> as written (every preset's "
         "resolved settings):</p>\n<pre id=\"run-json\">"
      << XmlEscape(run.text) << "</pre>\n";
  } else {
    o << "<p class=\"note\">No <code>run.json</code> beside <code>metrics.csv</code>: configuration unknown.</p>\n";
  }
}

// The summary table's recovery cell.
std::string RecoveryText(const PresetSummary& s) {
  std::string rec = "n/a";
  if (s.hasRecovery) {
    int recovered = 0;
    const double m = RecoveryMean(s.recovery, recovered);
    const size_t n = s.recovery.windows.size();
    if (n == 0)
      rec = "no reveal";
    else if (recovered == 0)
      rec = "not within window (" + std::to_string(n) + (n == 1 ? " reveal)" : " reveals)");
    else
      rec = Fmt(m, "%.3g") + " (" + std::to_string(recovered) + " of " + std::to_string(n) +
            (n == 1 ? " reveal)" : " reveals)");
  }
  return rec;
}

// One preset's row of the summary table.
void HtmlSummaryRow(std::ostream& o, const MetricsTable& t, const PresetSummary& s, bool hasFlip,
                    bool hasCorrected) {
  auto cell = [&](double v) { o << "<td class=\"num\">" << Fmt(v) << "</td>"; };
  o << "<tr class=\"summary-row\" data-preset=\"" << XmlEscape(s.name) << "\"><td>" << XmlEscape(s.name) << "</td>";
  o << "<td class=\"num\">" << s.rows << "</td>";
  // An error metric with its interval, marked † where the reference's noise is the larger part of it.
  auto errorCell = [&](const char* metric) {
    for (const auto& [name, in] : s.intervals)
      if (name == metric) {
        o << "<td class=\"num\">" << Fmt(in.mean);
        if (!std::isnan(in.halfWidth)) o << " ± " << Fmt(in.halfWidth, "%.2g");
        if (in.referenceDominated) o << " †";
        o << "</td>";
        return;
      }
    cell(SummaryMean(t, s, metric));
  };
  errorCell("relmse");
  errorCell("luma_rmse");
  errorCell("rmspe");
  if (hasFlip) cell(SummaryMean(t, s, "flip"));
  cell(s.lumaRatioAccumulated);
  cell(SummaryMean(t, s, "flicker"));
  cell(SummaryMean(t, s, "stability_luma_rmse"));
  cell(SummaryMean(t, s, "accum_rmse"));
  double postDisocc = NAN;
  for (const auto& [n, v] : s.postReveal)
    if (n == "relmse_disocc") postDisocc = v;
  cell(postDisocc);
  o << "<td class=\"num\">" << XmlEscape(RecoveryText(s)) << "</td>";
  cell(SummaryMean(t, s, "ms_frame"));
  cell(s.efficiency);
  if (hasCorrected) {
    // The share of each mean square that the reference's own variance accounts for (docs/metrics.md).
    auto share = [&](const char* raw, const char* corrected, bool squared) {
      double a = SummaryMean(t, s, raw), b = SummaryMean(t, s, corrected);
      if (squared) a *= a, b *= b;
      return a > 0.0 ? Fmt(100.0 * (a - b) / a, "%.2g") + "%" : std::string("n/a");
    };
    o << "<td class=\"num\">" << share("relmse", "relmse_corrected", false) << " / "
      << share("luma_rmse", "luma_rmse_corrected", true) << " / " << share("rmse", "rmse_corrected", true)
      << "</td>";
  }
  o << "</tr>\n";
}

// The note under the summary table: what its columns mean, and the reference's own noise.
void HtmlSummaryNote(std::ostream& o, const MetricsTable& t, const std::vector<PresetSummary>& sums,
                     bool hasCorrected) {
  o << "<p class=\"note\">luma ratio Σ = Σ luma_sum / Σ reference_luma_sum over the frames; relmse_disocc "
       "(post-reveal) is its mean over frames with disocc_recent_fraction &gt; 0; recovery: mean over reveals of the "
       "frames from a reveal until relmse_disocc ≤ 2 × the steady relmse (median relmse over frames without recent "
       "disocclusion, the first frame left out), counting only reveals that recover within their window; "
       "efficiency = 1 / (mean relmse · mean ms_frame / 1000).";
  if (const int refc = t.Column("reference_rel_stderr"); refc >= 0 && !sums.empty()) {
    const double rs = sums.front().means[refc];
    o << " The reference's own mean relative standard error is " << Fmt(rs)
      << ": a relmse below about its square (" << Fmt(rs * rs) << ") is within the reference's noise.";
    // A capped frame's reference stopped short of its error target: said here, not only in metrics.csv.
    if (const int capc = t.Column("reference_capped"); capc >= 0) {
      const PresetSummary& first = sums.front();
      const long capped = std::lround(first.means[capc] * first.rows);
      if (capped > 0)
        o << " <strong>The reference hit its sample cap on " << capped << " of " << first.rows
          << " frames</strong> (mean " << Fmt(SummaryMean(t, first, "reference_spp"))
          << " samples per pixel): there it did not reach its error target, and its noise is larger than asked.";
    }
    o << " ± is the 95% interval of each mean over frames, from the frames' own spread (batches of 8 frames) and "
         "the reference's noise (docs/metrics.md, Intervals); † marks a metric whose interval is mostly the "
         "reference's noise: a better reference, not more frames, would narrow it.";
    if (hasCorrected)
      o << " The noise share is how much of each mean (over frames) the reference's own variance explains: "
           "1 − <code>*_corrected</code> / raw, with the rmse forms squared.";
  }
  o << "</p>\n";
}

// Summary table.
void HtmlSummary(std::ostream& o, const MetricsTable& t, const std::vector<PresetSummary>& sums) {
  const bool hasFlip = t.Column("flip") >= 0;
  o << "<h2 id=\"summary\">Summary (means over frames)</h2>\n<table class=\"summary\">\n<tr><th>preset</th>"
       "<th>frames</th><th>relmse</th><th>luma_rmse</th><th>rmspe</th>";
  if (hasFlip) o << "<th>flip</th>";
  o << "<th>luma ratio Σ</th><th>flicker</th><th>stability</th><th>accum_rmse</th>"
       "<th>relmse_disocc (post-reveal)</th><th>recovery (frames)</th><th>ms/frame</th>"
       "<th>efficiency 1/(relmse·s)</th>";
  const bool hasCorrected = t.Column("relmse_corrected") >= 0;
  if (hasCorrected) o << "<th>reference noise share of relmse / luma_rmse² / rmse²</th>";
  o << "</tr>\n";
  for (const PresetSummary& s : sums) HtmlSummaryRow(o, t, s, hasFlip, hasCorrected);
  o << "</table>\n";
  HtmlSummaryNote(o, t, sums, hasCorrected);
}

// What the reservoirs held (issue 20): the regime a sequence puts the estimators in.
void HtmlReservoirs(std::ostream& o, const MetricsTable& t, const std::vector<PresetSummary>& sums) {
  if (t.Column("contrib_initial") < 0) return;
  const char* columns[] = {"contrib_initial", "contrib_temporal", "contrib_spatial", "contrib_shaded",
                           "mean_confidence", "confidence_sd", "sample_age", "duplicate_fraction"};
  o << "<h2 id=\"reservoirs\">Reservoirs (means over frames)</h2>\n<table class=\"reservoirs\">\n<tr><th>preset</th>";
  for (const char* c : columns) o << "<th>" << c << "</th>";
  o << "<th>contrib_initial_disocc / contrib_spatial_disocc (post-reveal)</th></tr>\n";
  for (const PresetSummary& s : sums) {
    o << "<tr class=\"reservoir-row\" data-preset=\"" << XmlEscape(s.name) << "\"><td>" << XmlEscape(s.name)
      << "</td>";
    for (const char* c : columns) o << "<td class=\"num\">" << Fmt(SummaryMean(t, s, c)) << "</td>";
    double initial = NAN, spatial = NAN;
    for (const auto& [n, v] : s.postReveal) {
      if (n == "contrib_initial_disocc") initial = v;
      if (n == "contrib_spatial_disocc") spatial = v;
    }
    o << "<td class=\"num\">" << Fmt(initial) << " / " << Fmt(spatial) << "</td></tr>\n";
  }
  o << "</table>\n<p class=\"note\">contrib_*: the fraction of surface pixels whose reservoir holds a sample with "
       "p̂ W &gt; 0 after each pass, and (contrib_shaded) whose shaded sample reaches the image, visibility "
       "included; *_disocc: the same among pixels revealed in the last 4 frames. sample_age: frames since the "
       "sample was drawn; duplicate_fraction: how often the pixels of a 5×5 window hold the very same sample "
       "(docs/metrics.md, \"Reservoir diagnostics\").</p>\n";
}

// Plots.
void HtmlPlots(std::ostream& o, const MetricsTable& t) {
  o << "<h2 id=\"plots\">Per-frame metrics</h2>\n<div class=\"plots\">\n";
  for (const std::string& m : ReportPlotMetrics())
    if (t.Column(m) >= 0) o << SvgPlot(t, m);
  o << "</div>\n";
}

// One frame's strip: each preset's preview, error map and FLIP map (written here, from its EXR).
void HtmlImageStrip(std::ostream& o, const MetricsTable& t, int frame, const std::string& outDir,
                    const FrameExpectation& expect) {
  o << "<h3>Frame " << frame << "</h3>\n<table class=\"strip\">\n<tr><th>preset</th><th>preview</th>"
       "<th>error</th><th>FLIP</th></tr>\n";
  for (const PresetSeries& p : t.presets) {
    if (std::find(p.frames.begin(), p.frames.end(), frame) == p.frames.end()) continue;
    const std::string preview = "frames/" + p.name + "/" + FrameNumber(frame) + ".png";
    const std::string previewPath = (fs::path(outDir) / preview).string();
    const bool hasPreview = FrameFileUsable(previewPath);
    if (hasPreview) CheckPngStructure(previewPath, expect);
    const FrameMaps maps = WriteFrameMaps(outDir, p.name, frame, expect);
    auto img = [&](const std::string& rel, const std::string& alt) {
      if (rel.empty()) {
        o << "<td class=\"note\">—</td>";
        return;
      }
      o << "<td><img src=\"" << XmlEscape(UrlPath(rel)) << "\" alt=\"" << XmlEscape(alt) << "\" width=\"360\"></td>";
    };
    o << "<tr><td>" << XmlEscape(p.name) << "</td>";
    img(hasPreview ? preview : "", p.name + " frame " + std::to_string(frame) + " estimate and reference");
    img(maps.error, p.name + " frame " + std::to_string(frame) + " error heat map");
    img(maps.flip, p.name + " frame " + std::to_string(frame) + " FLIP map");
    o << "</tr>\n";
  }
  o << "</table>\n";
}

// Image strips.
void HtmlImages(std::ostream& o, const MetricsTable& t, const RunInfo& run, const std::string& outDir,
                bool writeImages) {
  o << "<h2 id=\"images\">Images</h2>\n";
  if (!writeImages) {
    o << "<p class=\"note\">No frames were written (<code>--no-images</code>): no image strips.</p>\n";
    return;
  }
  o << "<p class=\"note\">Preview: estimate (left) beside reference (right), one exposure. Error: per pixel "
       "sqrt(mean over RGB of (I − R)² / (R² + 0.01)), 0 <span class=\"bar\" style=\"background:"
    << CssGradient(ColourMap::kInferno) << "\"></span> ≥ 1. FLIP: per-pixel HDR-FLIP, 0 <span class=\"bar\" style=\"background:"
    << CssGradient(ColourMap::kMagma) << "\"></span> 1.</p>\n";
  const FrameExpectation expect = ExpectedFrames(run);
  for (int frame : ChosenFrames(t)) HtmlImageStrip(o, t, frame, outDir, expect);
}

// What the motion sections read, from run.json and metrics.csv; no frames when run.json does not say the run's
// size (the scrub PNGs cannot be checked against it then).
MotionInputs MotionOf(const MetricsTable& t, const RunInfo& run, const std::string& outDir) {
  MotionInputs in;
  in.outDir = outDir;
  const FrameExpectation expect = ExpectedFrames(run);
  if (!expect.known) return in;
  in.width = expect.width;
  in.height = expect.height;
  in.hasReference = expect.hasReference;
  const Json* rate = nullptr;
  if (run.json.contains("sequence") && run.json["sequence"].is_object() && run.json["sequence"].contains("frameRate"))
    rate = &run.json["sequence"]["frameRate"];
  if (rate && rate->is_number() && rate->get<double>() > 0.0 && rate->get<double>() <= 1000.0)
    in.fps = rate->get<double>();
  for (const PresetSeries& p : t.presets) {
    in.presets.push_back(p.name);
    in.frames.insert(in.frames.end(), p.frames.begin(), p.frames.end());
  }
  std::sort(in.frames.begin(), in.frames.end());
  in.frames.erase(std::unique(in.frames.begin(), in.frames.end()), in.frames.end());
  const int recent = t.Column("disocc_recent_fraction");
  if (recent >= 0 && !t.presets.empty())
    for (size_t i = 0; i < t.presets[0].frames.size(); ++i)
      if (t.presets[0].values[recent][i] > 0.0) in.postRevealFrames.push_back(t.presets[0].frames[i]);
  std::sort(in.postRevealFrames.begin(), in.postRevealFrames.end());
  return in;
}

// The motion sections' files and where they stand.
struct Motion {
  bool present = false;  // the scrub PNGs of every frame are there
  MotionInputs in;
  Videos videos;
  Crops crops;
};

Motion WriteMotion(const MetricsTable& t, const RunInfo& run, const std::string& outDir) {
  Motion m;
  m.in = MotionOf(t, run, outDir);
  m.present = ScrubFramesPresent(m.in);
  if (!m.present) return m;
  m.videos = WriteVideos(m.in);
  m.crops = WriteCrops(m.in);
  return m;
}

void HtmlMotion(std::ostream& o, const Motion& m) {
  if (!m.present) {
    o << "<h2 id=\"scrubber\">Frames</h2>\n<p class=\"note\">The run wrote no scrub frames (<code>--no-images</code>, "
         "or a run from before them): no frame scrubber, videos or crops.</p>\n";
    return;
  }
  HtmlScrubber(o, m.in);
  HtmlVideos(o, m.videos);
  HtmlCrops(o, m.crops);
}

std::string Html(const MetricsTable& t, const std::vector<PresetSummary>& sums, const RunInfo& run,
                 const std::string& outDir, bool writeImages, const Motion& motion) {
  std::ostringstream o;
  HtmlHead(o, t, run);
  HtmlConfiguration(o, run);
  HtmlSummary(o, t, sums);
  HtmlSpeedVsError(o, t, sums);
  HtmlMotion(o, motion);
  HtmlReservoirs(o, t, sums);
  HtmlPlots(o, t);
  HtmlImages(o, t, run, outDir, writeImages);
  o << "</body>\n</html>\n";
  return o.str();
}
}  // namespace

void WriteReport(const std::string& outDir) {
  std::error_code ec;
  if (!fs::is_directory(outDir, ec)) throw InputError(outDir + ": error: not a directory (expected a run's output directory)");
  const MetricsTable t = ReadMetricsCsv((fs::path(outDir) / "metrics.csv").string());
  const RunInfo run = ReadRunJson((fs::path(outDir) / "run.json").string());
  std::vector<PresetSummary> sums;
  for (const PresetSeries& p : t.presets) sums.push_back(Summarize(t, p));
  const bool writeImages = fs::is_directory(fs::path(outDir) / "frames", ec);
  const Motion motion = WriteMotion(t, run, outDir);
  const std::string html = Html(t, sums, run, outDir, writeImages, motion);
  Json summary = SummaryJson(t, sums, run.json);
  summary["speed_vs_error"] = SpeedVsErrorJson(t, sums);
  summary["videos"] = motion.present ? VideosJson(motion.videos) : Json(nullptr);
  summary["crop"] = motion.present ? CropsJson(motion.crops) : Json(nullptr);
  WriteFileAtomic((fs::path(outDir) / "summary.json").string(), summary.dump(2) + "\n");
  WriteFileAtomic((fs::path(outDir) / "report.html").string(), html);
}

}  // namespace restir
