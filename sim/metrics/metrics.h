// Per-frame error metrics against the reference (DESIGN §6). Sums run sequentially in pixel order in double
// precision, so the numbers are the same whatever the thread count.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "sim/metrics/flip.h"
#include "sim/util/image.h"
#include "sim/estimator/passes/frame_view.h"
#include "sim/estimator/reservoir_diagnostics.h"

namespace restir {

// The reference R is itself an estimate: E[(I − R)²] = (I − R_true)² + Var(R) when I and R use independent random
// numbers. Its replicates give an unbiased per-pixel estimate of Var(R) (ReferenceImage), so subtracting it
// charges the estimate only for its own error (docs/metrics.md, "Reference noise").
struct ReferenceNoise {
  const ImageRgb* standardError = nullptr;                // per pixel and channel
  const std::vector<float>* lumaStandardError = nullptr;  // per pixel, of the luminance Y
};

struct AccuracyMetrics {
  double rmse = 0.0;        // sqrt(mean over pixels and RGB of (I - R)^2)
  double lumaRmse = 0.0;    // sqrt(mean (Y(I) - Y(R))^2), seed 003 "LumaRMSE"
  double relmse = 0.0;      // mean over pixels and RGB of (I - R)^2 / (R^2 + 0.01)
  double lumaRatio = 0.0;   // sum Y(I) / sum Y(R); 1 means no bias in total brightness
  double rmspe = 0.0;       // sqrt(mean over pixels with Y(R) > 1e-4 of ((Y(I) - Y(R)) / Y(R))^2), seed 000
  double lumaSum = 0.0;     // sum Y(I), so ratios can be formed over many frames
  double referenceLumaSum = 0.0;  // sum Y(R)
  size_t pixels = 0;        // pixels the averages ran over
  // With a ReferenceNoise (else equal to the raw values): the same means with the reference's variance taken out
  // of every squared term, (I − R)² − se², so the mean squares are unbiased for the error against the true image.
  // The rmse forms are sqrt(max(0, ·)); relmseCorrected is left signed (a near-perfect estimate can go below 0).
  double mseCorrected = 0.0;       // mean over pixels and RGB of (I − R)² − se²
  double lumaMseCorrected = 0.0;   // mean of (Y(I) − Y(R))² − se_Y²
  double rmseCorrected = 0.0;      // sqrt(max(0, mseCorrected))
  double lumaRmseCorrected = 0.0;  // sqrt(max(0, lumaMseCorrected))
  double relmseCorrected = 0.0;    // mean of ((I − R)² − se²) / (R² + 0.01): unbiased to first order in se²
  // With a ReferenceNoise (else 0): the standard deviation each metric owes to the reference's own noise, to first
  // order (the delta method: sqrt(Σ gᵀ C g) over pixels, g the metric's gradient in the pixel's reference
  // channels, C their covariance, modelled from se and se_Y; pixels' reference errors independent). The luminance
  // metrics use se_Y alone. A metric's interval: docs/metrics.md, "Intervals".
  double rmseReferenceSd = 0.0;
  double lumaRmseReferenceSd = 0.0;
  double relmseReferenceSd = 0.0;
  double rmspeReferenceSd = 0.0;
};

// relmse's denominator for a reference value r: the 0.01 keeps dark pixels from dominating (docs/metrics.md).
inline double RelmseDenominator(double r) { return r * r + 0.01; }

// Over every pixel, or over the pixels where mask[i] != 0 when a mask is given.
AccuracyMetrics MeasureAccuracy(const ImageRgb& estimate, const ImageRgb& reference,
                                const std::vector<uint8_t>* mask = nullptr, const ReferenceNoise* noise = nullptr);

// Per-frame stability (seed 003): sqrt(mean (Y(I_t) - Y(I_{t-1}))^2).
double StabilityLumaRmse(const ImageRgb& current, const ImageRgb& previous);

// Flicker net of real change: sqrt(mean ((Y(I_t) - Y(I_{t-1})) - (Y(R_t) - Y(R_{t-1})))^2).
double Flicker(const ImageRgb& current, const ImageRgb& previous, const ImageRgb& reference,
               const ImageRgb& previousReference);

// Fraction of pixels set in a mask.
double MaskFraction(const std::vector<uint8_t>& mask);

}  // namespace restir

namespace restir {

// Seed ensembles (DESIGN §6): K estimates of one frame that differ only in their seed, split into bias² and
// variance. Sums run in pixel order in double precision (deterministic).
struct EnsembleStats {
  double mse = 0.0;                // (1/K) Σ_k mean over pixels and RGB of (I_k − R)²
  double bias2 = 0.0;              // mean over pixels and RGB of (Ī − R)²
  double variance = 0.0;           // mean over pixels and RGB of (1/K) Σ_k (I_k − Ī)²; mse = bias2 + variance
  double bias2Noise = 0.0;         // what bias2 averages to for an unbiased estimator: mean of v/(K−1) + se_R²
  double lumaRatio = 0.0;          // Σ Y(Ī) / Σ Y(R)
  double lumaRatioStdError = 0.0;  // its standard error: the members' spread / sqrt(K) and the reference's own
  // The standard deviation over the K members of rmse, luma_rmse, relmse and rmspe (kIntervalMetrics' order): how
  // much one seed's frame error moves from seed to seed (an interval's estimator part, docs/metrics.md "Intervals").
  double seedSd[4] = {0.0, 0.0, 0.0, 0.0};
};

// Needs K >= 2 images of the reference's size. Fills the per-pixel maps Ī − R (bias) and (1/K) Σ (I_k − Ī)²
// (variance).
EnsembleStats MeasureEnsemble(const std::vector<ImageRgb>& images, const ImageRgb& reference,
                              const ImageRgb& referenceStdError, ImageRgb& bias, ImageRgb& variance);

// Seed 000 Fig. 2 compares *converged* images by RMSPE, where it measures bias alone. With K >= 3 members' running
// means X_k of one unchanged scene state (each a mean over frames of one seed: correlated frames, independent
// members), the ensemble's converged image is Ī = mean_k X_k, and per lit pixel (Y(R) > 1e-4, as rmspe)
//   b²_p = [(Y(Ī) − Y(R))² − s²/K − se_Y²] / Y(R)²,   s² the members' sample variance of Y(X_k),
// is unbiased (to first order in the reference's relative error) for the squared relative bias of the estimator's
// converged luminance: the noise of Ī and of R is taken out. B² = mean over lit pixels of b²_p.
struct ConvergedRmspe {
  double rmspe = 0.0;   // rmspe of Ī against R, both noises included
  double bias2 = 0.0;   // B², signed (an unbiased estimator's averages to 0)
  double bias = 0.0;    // sqrt(max(0, B²)): the converged image's RMSPE owed to bias
  // A 95% interval of the bias, sqrt(max(0, B² ∓ h)): h = t(0.975, K − 1) · sd(B²), its variance the jackknife's
  // over members (delete one) plus the reference's share by the delta method (Σ (∂b²_p/∂R)² se_Y² / n²).
  double biasLow = 0.0, biasHigh = 0.0;
};

// memberSums[k]: Σ over the `frames` frames of member k's estimates. Needs K >= 3 (else all zero).
ConvergedRmspe MeasureConvergedRmspe(const std::vector<const ImageRgb*>& memberSums, int frames,
                                     const ImageRgb& reference, const std::vector<float>& referenceLumaStdError);

}  // namespace restir

namespace restir {

// One row of metrics.csv (docs/metrics.md defines every column).
struct FrameMetricsRow {
  int frame = 0;
  std::string preset;
  std::vector<std::pair<std::string, double>> values;  // column name -> value, in column order
  std::string imageHash;
};

// Everything one preset's row of a frame is measured from. Pointers not set leave their columns out (no
// reference: no error columns; no ensemble: no ensemble_* columns) or read as a first frame (no previous image).
struct FrameMeasurement {
  int frame = 0;
  std::string preset;
  double msSceneUpdate = 0.0, msPrimary = 0.0, msReproject = 0.0;  // the frame's shared stages
  const std::vector<PassStats>* passes = nullptr;  // the preset's passes, in order
  const ImageRgb* image = nullptr;                 // the preset's estimate
  const ImageRgb* previousImage = nullptr;         // its estimate of the previous frame (null: first frame)
  uint64_t guarded = 0;                            // FrameResult counters
  double temporalAcceptance = 0.0;
  ReservoirDiagnostics diagnostics;                // FrameResult::diagnostics
  // FrameResult::indirectDiagnostics and indirectSpatial: ReSTIR GI's reservoirs and spatial pass (null: the
  // preset does not reuse paths; its gi_* columns read 0).
  const ReservoirDiagnostics* indirectDiagnostics = nullptr;
  const PassStats* indirectSpatial = nullptr;
  uint64_t crossObjectReuse = 0;
  double disoccFraction = 0.0, recentFraction = 0.0;  // G-buffer disocclusion and its 4-frame window
  // The reference and what is measured against it:
  const ImageRgb* reference = nullptr;             // null: no reference, no error columns
  double msReference = 0.0;                        // its wall time
  bool referenceCached = false;                    // it was read from the cache
  double referenceRelStdError = 0.0;               // MeanRelativeStandardError
  double referenceSpp = 0.0;                       // its mean samples per pixel, the pilot's included
  bool referenceCapped = false;                    // its error target was cut down to the frame's sample cap
  ReferenceNoise referenceNoise;                   // its per-pixel noise: the *_corrected columns (when set)
  const ImageRgb* previousReference = nullptr;     // the previous frame's (flicker)
  const FlipMap* flip = nullptr;                   // per-pixel HDR-FLIP of the estimate against the reference
  const std::vector<uint8_t>* recentMask = nullptr;  // pixels revealed in the last 4 frames
  const std::vector<uint8_t>* restMask = nullptr;    // the others
  const ImageRgb* accumulatedMean = nullptr;       // running mean since the scene state last changed
  int accumFrames = 0;                             // frames in it
  const EnsembleStats* ensemble = nullptr;         // --ensemble K > 1
  const ConvergedRmspe* converged = nullptr;       // --ensemble K >= 3: the members' running means
};

// The frame's row: every column of metrics.csv in its fixed order.
FrameMetricsRow MeasureFrame(const FrameMeasurement& m);

}  // namespace restir
