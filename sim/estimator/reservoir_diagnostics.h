// What the reservoirs hold, frame by frame, as numbers (issue 20): whether a pixel's reservoir contributes
// after each pass, how much history it carries, how old its sample is and how often its neighbours hold the
// very same sample. Seed 004 argues that spatial reuse fails where contributing reservoirs are sparse; these
// columns say which regime a sequence is in. Definitions: docs/metrics.md, "Reservoir diagnostics".
#pragma once

#include <cstdint>
#include <vector>

#include "sim/scene/gbuffer.h"
#include "sim/estimator/passes/frame_view.h"

namespace restir {

struct ReservoirDiagnostics {
  // Fractions of surface pixels whose reservoir has p̂(Y) W > 0 (a sample its own target does not reject),
  // after initial sampling, after temporal reuse and after spatial reuse; a pass the preset lacks leaves the
  // previous value. p̂ is the pass's own target (unshadowed, or with visibility where the preset's targets
  // trace it).
  double contributingInitial = 0.0;
  double contributingTemporal = 0.0;
  double contributingSpatial = 0.0;
  // The same three among the surface pixels of FrameInputs::diagnosticsRegion (the run's pixels revealed in
  // the last 4 frames: seed 004's "around a reveal"); 0 when the region has none.
  double contributingInitialRegion = 0.0;
  double contributingTemporalRegion = 0.0;
  double contributingSpatialRegion = 0.0;
  // Fraction of surface pixels whose shaded reservoir reaches the image: f(Y) V(Y) W > 0, visibility traced.
  double contributingShaded = 0.0;
  double confidenceMean = 0.0;  // mean output confidence c over surface pixels
  double confidenceSd = 0.0;    // its standard deviation over the same pixels (population form)
  double ageMean = 0.0;         // mean SampleHistory::age over surface pixels whose reservoir has a sample
  // Mean over surface pixels with a sample of: the fraction of the other pixels with a sample in its
  // (2 kDuplicateRadius + 1)² window that hold the same sample (light id and point, bit for bit). 0 when
  // every sample is distinct; spatial reuse copies samples, so it raises this (RTXDI's duplication map
  // measures the same correlation to shorten history where it is high).
  double duplicateFraction = 0.0;
};

inline constexpr int kDuplicateRadius = 2;

// Fractions of surface pixels of `g` whose reservoir has p̂ W > 0 (finite): of all of them, and of those where
// region[i] is nonzero (region null or empty: 0).
struct Contributing {
  double all = 0.0;
  double region = 0.0;
};
Contributing ContributingFraction(const GBuffer& g, const ReservoirBuffer& reservoirs,
                                  const std::vector<uint8_t>* region);
// Stores the contributing shares measured after the initial, temporal and spatial passes into d.
void RecordContributing(const Contributing& initial, const Contributing& temporal, const Contributing& spatial,
                        ReservoirDiagnostics& d);

// Confidence, age and duplication of the frame's output reservoirs (the other fields are left as they are).
// Deterministic: sums in pixel order, whatever the thread count.
void MeasureOutputReservoirs(const GBuffer& g, const ReservoirBuffer& reservoirs, ReservoirDiagnostics& d);

}  // namespace restir
