// `restir-sim sweep SWEEP.json`: runs a grid of presets and settings on one sequence with shared references and
// reports error against cost (DESIGN §9: speed against error): sweep.csv, a Pareto plot of relmse against ms
// per frame (sweep.svg) and equal-time and equal-sample tables (sweep.md). docs/sweep-format.md describes the
// file.
#pragma once

#include <string>
#include <vector>

#include "sim/runner.h"

namespace restir {

// One configuration of a sweep: a preset and the settings changed from it.
struct SweepConfig {
  std::string name;                    // unique, names its run directory OUT/runs/<name>
  std::string preset;                  // a preset name (restir-sim presets)
  std::vector<std::string> overrides;  // KEY=VALUE, applied in order (as --set)
};

struct SweepSpec {
  std::string path;                  // the sweep file, for messages
  RunOptions base;                   // sequence, frames, resolution, seed, reference: shared by every run
  std::vector<SweepConfig> configs;  // the grid's product, then the explicit configs, in file order
};

// What one configuration measured, averaged over its frames (the first frame's timings skipped: it has no
// temporal input and warms the caches).
struct SweepPoint {
  SweepConfig config;
  double relmse = 0.0;          // mean per-frame relmse
  double relmseDisocc = 0.0;    // mean relmse_disocc over frames with recently disoccluded pixels (NaN: none)
  double flip = 0.0;            // mean flip (NaN when the column is absent)
  double lumaRatio = 0.0;       // Σ luma / Σ reference luma over every frame
  double flicker = 0.0;         // mean flicker
  double msPerFrame = 0.0;      // mean ms_frame
  double shadowRaysPerPixel = 0.0;  // mean shadow rays per pixel (every pass): the sample budget
  double efficiency = 0.0;      // 1 / (relmse · seconds per frame)
  bool pareto = false;          // no other point is at most as slow and at most as wrong, and better in one
};

// Reads and validates a sweep file. Throws InputError with file:line:column and JSON path.
SweepSpec LoadSweep(const std::string& path);

// Summarises one run's metric rows.
SweepPoint Summarize(const SweepConfig& config, const std::vector<FrameMetricsRow>& rows);

// Marks the Pareto front of (msPerFrame, relmse): lower is better in both.
void MarkPareto(std::vector<SweepPoint>& points);

// The three reports, as text (deterministic: same points, same bytes).
std::string SweepCsv(const std::vector<SweepPoint>& points);
std::string SweepSvg(const std::vector<SweepPoint>& points);
std::string SweepMarkdown(const SweepSpec& spec, const std::vector<SweepPoint>& points);

// Runs every configuration into outDir/runs/<name> and writes outDir/sweep.{csv,svg,md}.
std::vector<SweepPoint> RunSweep(const SweepSpec& spec, const std::string& outDir);

}  // namespace restir
