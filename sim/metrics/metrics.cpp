#include "sim/metrics/metrics.h"

#include <algorithm>
#include <cmath>

#include "sim/metrics/summary.h"  // StudentTQuantile975

namespace restir {

namespace {

// A reference pixel's error covariance across its channels, for the delta method. The replicates give each
// channel's standard error and the luminance's, not the three covariances: one light sample feeds all three
// channels, so they are modelled with one correlation ρ, the one that makes Var(Y) = Σ w_c² se_c² +
// 2 ρ Σ_{c<c'} w_c w_c' se_c se_c' hold, clamped to [−0.5, 1] (the range that keeps the matrix positive).
struct PixelCovariance {
  PixelCovariance(const Vec3& se, float seY) {
    const double w[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; ++c) s[c] = se[c];  // all three first: the cross terms read the later channels
    double own = 0.0, cross = 0.0;
    for (int c = 0; c < 3; ++c) {
      own += w[c] * w[c] * s[c] * s[c];
      for (int k = c + 1; k < 3; ++k) cross += 2.0 * w[c] * w[k] * s[c] * s[k];
    }
    rho = cross > 0.0 ? std::clamp((double(seY) * double(seY) - own) / cross, -0.5, 1.0) : 0.0;
  }
  // gᵀ C g.
  double Quadratic(const double g[3]) const {
    double q = 0.0;
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) q += g[c] * g[k] * s[c] * s[k] * (c == k ? 1.0 : rho);
    return q;
  }
  double s[3];
  double rho;
};

}  // namespace

AccuracyMetrics MeasureAccuracy(const ImageRgb& estimate, const ImageRgb& reference,
                                const std::vector<uint8_t>* mask, const ReferenceNoise* noise) {
  AccuracyMetrics m;
  double se = 0.0, seLuma = 0.0, rel = 0.0, sumY = 0.0, sumYRef = 0.0, spe = 0.0;
  double noiseVar = 0.0, noiseVarLuma = 0.0, noiseRel = 0.0;  // Σ se², Σ se_Y², Σ se² / (R² + 0.01)
  // The delta method's sums: Σ (∂S/∂R)² se² for each metric's sum S (squared error, luma squared error, relmse's
  // terms, rmspe's squared relative errors).
  double dSe = 0.0, dSeLuma = 0.0, dRel = 0.0, dSpe = 0.0;
  const bool corrected = noise && noise->standardError && noise->lumaStandardError;
  size_t count = 0, litCount = 0;
  for (size_t i = 0; i < estimate.Size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    const Vec3& a = estimate.pixels[i];
    const Vec3& r = reference.pixels[i];
    double gSe[3] = {0.0, 0.0, 0.0}, gRel[3] = {0.0, 0.0, 0.0};  // ∂/∂R_c of the pixel's squared and relmse terms
    for (int c = 0; c < 3; ++c) {
      const double d = double(a[c]) - double(r[c]);
      se += d * d;
      rel += d * d / RelmseDenominator(r[c]);
      if (corrected) {
        const double v = double(noise->standardError->pixels[i][c]) * double(noise->standardError->pixels[i][c]);
        noiseVar += v;
        // Only the numerator's share: the terms from the denominator's own noise (−2 d g' v + d² g'' v / 2 with
        // g = 1 / (R² + 0.01)) would need derivatives of 1/R̂², which explode where R̂ is noisy and near 0.
        noiseRel += v / RelmseDenominator(r[c]);
        // ∂(d²)/∂r = −2d; ∂(d² / (r² + 0.01))/∂r = −2d / D − 2 r d² / D².
        const double den = RelmseDenominator(r[c]);
        gSe[c] = -2.0 * d;
        gRel[c] = -2.0 * d / den - 2.0 * double(r[c]) * d * d / (den * den);
      }
    }
    if (corrected) {
      const PixelCovariance cov(noise->standardError->pixels[i], (*noise->lumaStandardError)[i]);
      dSe += cov.Quadratic(gSe);
      dRel += cov.Quadratic(gRel);
    }
    const double ya = Luminance(a), yr = Luminance(r);
    seLuma += (ya - yr) * (ya - yr);
    const double vY = corrected ? double((*noise->lumaStandardError)[i]) * double((*noise->lumaStandardError)[i]) : 0.0;
    noiseVarLuma += vY;
    dSeLuma += 4.0 * (ya - yr) * (ya - yr) * vY;
    if (yr > 1e-4) {
      spe += ((ya - yr) / yr) * ((ya - yr) / yr);
      // ∂((a / r − 1)²)/∂r = −2 (a / r − 1) a / r².
      const double gSpe = -2.0 * (ya / yr - 1.0) * ya / (yr * yr);
      dSpe += gSpe * gSpe * vY;
      ++litCount;
    }
    sumY += ya;
    sumYRef += yr;
    ++count;
  }
  m.pixels = count;
  if (count == 0) return m;
  m.rmse = std::sqrt(se / (3.0 * count));
  m.lumaRmse = std::sqrt(seLuma / count);
  m.relmse = rel / (3.0 * count);
  m.lumaRatio = sumYRef > 0.0 ? sumY / sumYRef : (sumY > 0.0 ? INFINITY : 1.0);
  m.rmspe = litCount ? std::sqrt(spe / double(litCount)) : 0.0;
  m.lumaSum = sumY;
  m.referenceLumaSum = sumYRef;
  m.mseCorrected = (se - noiseVar) / (3.0 * count);
  m.lumaMseCorrected = (seLuma - noiseVarLuma) / count;
  m.rmseCorrected = std::sqrt(std::max(0.0, m.mseCorrected));
  m.lumaRmseCorrected = std::sqrt(std::max(0.0, m.lumaMseCorrected));
  m.relmseCorrected = (rel - noiseRel) / (3.0 * count);
  // sqrt(S / n) moves by dS / (2 n sqrt(S / n)); a metric at exactly 0 has no first-order term.
  auto rootSd = [](double varSum, double n, double root) {
    return root > 0.0 ? std::sqrt(varSum) / (2.0 * n * root) : 0.0;
  };
  m.rmseReferenceSd = rootSd(dSe, 3.0 * count, m.rmse);
  m.lumaRmseReferenceSd = rootSd(dSeLuma, double(count), m.lumaRmse);
  m.relmseReferenceSd = std::sqrt(dRel) / (3.0 * count);
  m.rmspeReferenceSd = litCount ? rootSd(dSpe, double(litCount), m.rmspe) : 0.0;
  return m;
}

double StabilityLumaRmse(const ImageRgb& current, const ImageRgb& previous) {
  double sum = 0.0;
  for (size_t i = 0; i < current.Size(); ++i) {
    const double d = double(Luminance(current.pixels[i])) - double(Luminance(previous.pixels[i]));
    sum += d * d;
  }
  return current.Size() ? std::sqrt(sum / double(current.Size())) : 0.0;
}

double Flicker(const ImageRgb& current, const ImageRgb& previous, const ImageRgb& reference,
               const ImageRgb& previousReference) {
  double sum = 0.0;
  for (size_t i = 0; i < current.Size(); ++i) {
    const double d = (double(Luminance(current.pixels[i])) - double(Luminance(previous.pixels[i]))) -
                     (double(Luminance(reference.pixels[i])) - double(Luminance(previousReference.pixels[i])));
    sum += d * d;
  }
  return current.Size() ? std::sqrt(sum / double(current.Size())) : 0.0;
}

double MaskFraction(const std::vector<uint8_t>& mask) {
  if (mask.empty()) return 0.0;
  size_t n = 0;
  for (uint8_t v : mask) n += v != 0;
  return double(n) / double(mask.size());
}

}  // namespace restir

namespace restir {

EnsembleStats MeasureEnsemble(const std::vector<ImageRgb>& images, const ImageRgb& reference,
                              const ImageRgb& referenceStdError, ImageRgb& bias, ImageRgb& variance) {
  EnsembleStats s;
  const size_t k = images.size(), n = reference.Size();
  if (k < 2 || n == 0) return s;
  bias = ImageRgb(reference.width, reference.height);
  variance = ImageRgb(reference.width, reference.height);
  std::vector<double> memberLuma(k, 0.0);
  double refLuma = 0.0, refLumaVar = 0.0, meanLuma = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Vec3 r = reference.pixels[i];
    const Vec3 se = referenceStdError.pixels[i];
    for (int c = 0; c < 3; ++c) {
      double mean = 0.0, mse = 0.0;
      for (size_t m = 0; m < k; ++m) {
        const double v = images[m].pixels[i][c];
        mean += v;
        mse += (v - r[c]) * (v - r[c]);
      }
      mean /= static_cast<double>(k);
      double var = 0.0;
      for (size_t m = 0; m < k; ++m) {
        const double d = images[m].pixels[i][c] - mean;
        var += d * d;
      }
      var /= static_cast<double>(k);
      s.mse += mse / static_cast<double>(k);
      s.bias2 += (mean - r[c]) * (mean - r[c]);
      s.variance += var;
      s.bias2Noise += var / static_cast<double>(k - 1) + double(se[c]) * se[c];
      bias.pixels[i][c] = static_cast<float>(mean - r[c]);
      variance.pixels[i][c] = static_cast<float>(var);
    }
    for (size_t m = 0; m < k; ++m) memberLuma[m] += Luminance(images[m].pixels[i]);
    refLuma += Luminance(r);
    const double seY = Luminance(se);  // >= the standard error of Y(R): conservative
    refLumaVar += seY * seY;
  }
  const double samples = 3.0 * static_cast<double>(n);
  s.mse /= samples, s.bias2 /= samples, s.variance /= samples, s.bias2Noise /= samples;
  for (double l : memberLuma) meanLuma += l / static_cast<double>(k);
  double spread = 0.0;
  for (double l : memberLuma) spread += (l - meanLuma) * (l - meanLuma);
  spread /= static_cast<double>(k - 1);
  if (refLuma > 0.0) {
    s.lumaRatio = meanLuma / refLuma;
    const double seMean = std::sqrt(spread / static_cast<double>(k)) / refLuma;
    const double seRef = s.lumaRatio * std::sqrt(refLumaVar) / refLuma;
    s.lumaRatioStdError = std::sqrt(seMean * seMean + seRef * seRef);
  } else {
    s.lumaRatio = meanLuma == 0.0 ? 1.0 : INFINITY;
  }
  // Each member's error metrics against the reference, and their spread over the members.
  std::vector<AccuracyMetrics> members;
  for (const ImageRgb& image : images) members.push_back(MeasureAccuracy(image, reference));
  double AccuracyMetrics::*const fields[4] = {&AccuracyMetrics::rmse, &AccuracyMetrics::lumaRmse,
                                              &AccuracyMetrics::relmse, &AccuracyMetrics::rmspe};
  for (int f = 0; f < 4; ++f) {
    double mean = 0.0, var = 0.0;
    for (const AccuracyMetrics& m : members) mean += m.*fields[f] / static_cast<double>(k);
    for (const AccuracyMetrics& m : members) var += (m.*fields[f] - mean) * (m.*fields[f] - mean);
    s.seedSd[f] = std::sqrt(var / static_cast<double>(k - 1));
  }
  return s;
}

ConvergedRmspe MeasureConvergedRmspe(const std::vector<const ImageRgb*>& memberSums, int frames,
                                     const ImageRgb& reference, const std::vector<float>& referenceLumaStdError) {
  ConvergedRmspe out;
  const size_t k = memberSums.size(), n = reference.Size();
  if (k < 3 || frames < 1 || n == 0) return out;
  const double kd = static_cast<double>(k), invFrames = 1.0 / static_cast<double>(frames);
  // One pixel's b², from its members' mean and sample variance.
  auto term = [](double mean, double var, double members, double r, double seY2) {
    return ((mean - r) * (mean - r) - var / members - seY2) / (r * r);
  };
  double spe = 0.0, bias2 = 0.0, referenceVar = 0.0;
  std::vector<double> bias2Without(k, 0.0);  // Σ b² with member j left out (the jackknife)
  std::vector<double> y(k);
  size_t lit = 0;
  for (size_t i = 0; i < n; ++i) {
    const double r = Luminance(reference.pixels[i]);
    if (!(r > 1e-4)) continue;
    ++lit;
    double s1 = 0.0, s2 = 0.0;
    for (size_t m = 0; m < k; ++m) {
      y[m] = Luminance(memberSums[m]->pixels[i]) * invFrames;
      s1 += y[m];
      s2 += y[m] * y[m];
    }
    const double seY2 = double(referenceLumaStdError[i]) * double(referenceLumaStdError[i]);
    const double mean = s1 / kd;
    const double var = std::max(0.0, (s2 - kd * mean * mean) / (kd - 1.0));
    const double b2 = term(mean, var, kd, r, seY2);
    spe += (mean - r) * (mean - r) / (r * r);
    bias2 += b2;
    // ∂b²/∂r = −2 (Ī − r) / r² − 2 b² / r.
    const double g = -2.0 * (mean - r) / (r * r) - 2.0 * b2 / r;
    referenceVar += g * g * seY2;
    for (size_t j = 0; j < k; ++j) {
      const double meanJ = (s1 - y[j]) / (kd - 1.0);
      const double varJ = std::max(0.0, ((s2 - y[j] * y[j]) - (kd - 1.0) * meanJ * meanJ) / (kd - 2.0));
      bias2Without[j] += term(meanJ, varJ, kd - 1.0, r, seY2);
    }
  }
  if (lit == 0) return out;
  const double litD = static_cast<double>(lit);
  out.rmspe = std::sqrt(spe / litD);
  out.bias2 = bias2 / litD;
  out.bias = std::sqrt(std::max(0.0, out.bias2));
  double meanWithout = 0.0, spread = 0.0;
  for (double& b : bias2Without) meanWithout += (b /= litD) / kd;
  for (double b : bias2Without) spread += (b - meanWithout) * (b - meanWithout);
  const double jackknifeVar = (kd - 1.0) / kd * spread;
  const double h =
      StudentTQuantile975(static_cast<int>(k) - 1) * std::sqrt(jackknifeVar + referenceVar / (litD * litD));
  out.biasLow = std::sqrt(std::max(0.0, out.bias2 - h));
  out.biasHigh = std::sqrt(std::max(0.0, out.bias2 + h));
  return out;
}

namespace {

using Columns = std::vector<std::pair<std::string, double>>;

const PassStats* FindPass(const FrameMeasurement& m, const char* name) {
  for (const PassStats& ps : *m.passes)
    if (ps.name == name) return &ps;
  return nullptr;
}

// The frame's and its passes' times and rays. Fixed columns for every preset: a pass it does not run reports 0.
void AppendCostColumns(const FrameMeasurement& m, Columns& v) {
  const size_t pixels = m.image->Size();
  double msPasses = 0.0;
  uint64_t rays = static_cast<uint64_t>(pixels);  // primary rays
  v.emplace_back("ms_scene_update", m.msSceneUpdate);
  v.emplace_back("ms_primary", m.msPrimary);
  v.emplace_back("ms_reproject", m.msReproject);
  for (const char* name : kPassNames) {
    const PassStats* ps = FindPass(m, name);
    v.emplace_back(std::string("ms_") + name, ps ? ps->ms : 0.0);
    msPasses += ps ? ps->ms : 0.0;
    rays += ps ? ps->rays : 0;
  }
  v.emplace_back("ms_frame", m.msSceneUpdate + m.msPrimary + m.msReproject + msPasses);
  v.emplace_back("ms_reference", m.reference ? m.msReference : 0.0);
  v.emplace_back("reference_cached", m.referenceCached ? 1.0 : 0.0);
  v.emplace_back("rays", static_cast<double>(rays));
  for (const char* name : kPassNames) {
    const PassStats* ps = FindPass(m, name);
    v.emplace_back(std::string("rays_per_pixel_") + name, ps ? double(ps->rays) / double(pixels) : 0.0);
  }
}

// The errors against the reference: whole image, its intervals, the revealed and other pixels, the running mean,
// the ensemble's split and flicker.
void AppendErrorColumns(const FrameMeasurement& m, Columns& v) {
  const ImageRgb& ref = *m.reference;
  const ReferenceNoise* noise = m.referenceNoise.standardError ? &m.referenceNoise : nullptr;
  // The corrected forms sit after the raw group so the raw columns keep their places.
  auto corrected = [&](const AccuracyMetrics& x, const std::string& suffix) {
    if (!noise) return;
    v.emplace_back("rmse_corrected" + suffix, x.rmseCorrected);
    v.emplace_back("luma_rmse_corrected" + suffix, x.lumaRmseCorrected);
    v.emplace_back("relmse_corrected" + suffix, x.relmseCorrected);
  };
  const AccuracyMetrics a = MeasureAccuracy(*m.image, ref, nullptr, noise);
  v.emplace_back("rmse", a.rmse);
  v.emplace_back("luma_rmse", a.lumaRmse);
  v.emplace_back("relmse", a.relmse);
  v.emplace_back("luma_ratio", a.lumaRatio);
  v.emplace_back("rmspe", a.rmspe);
  v.emplace_back("flip", MeanFlip(*m.flip));
  v.emplace_back("luma_sum", a.lumaSum);
  v.emplace_back("reference_luma_sum", a.referenceLumaSum);
  v.emplace_back("reference_rel_stderr", m.referenceRelStdError);
  v.emplace_back("reference_spp", m.referenceSpp);
  v.emplace_back("reference_capped", m.referenceCapped ? 1.0 : 0.0);
  corrected(a, "");
  if (noise) {
    v.emplace_back("rmse_ref_sd", a.rmseReferenceSd);
    v.emplace_back("luma_rmse_ref_sd", a.lumaRmseReferenceSd);
    v.emplace_back("relmse_ref_sd", a.relmseReferenceSd);
    v.emplace_back("rmspe_ref_sd", a.rmspeReferenceSd);
  }
  // The same errors over the recently revealed pixels and over the others.
  for (const auto& [mask, suffix] : {std::pair{m.recentMask, "_disocc"}, std::pair{m.restMask, "_rest"}}) {
    const std::string sfx = suffix;
    const AccuracyMetrics x = MeasureAccuracy(*m.image, ref, mask, noise);
    v.emplace_back("rmse" + sfx, x.rmse);
    v.emplace_back("luma_rmse" + sfx, x.lumaRmse);
    v.emplace_back("relmse" + sfx, x.relmse);
    v.emplace_back("rmspe" + sfx, x.rmspe);
    v.emplace_back("luma_ratio" + sfx, x.pixels ? x.lumaRatio : 1.0);
    v.emplace_back("flip" + sfx, MeanFlip(*m.flip, mask));
    corrected(x, sfx);
  }
  const AccuracyMetrics acc = MeasureAccuracy(*m.accumulatedMean, ref, nullptr, noise);
  v.emplace_back("accum_frames", m.accumFrames);
  v.emplace_back("accum_rmse", acc.rmse);
  v.emplace_back("accum_luma_ratio", acc.lumaRatio);
  v.emplace_back("accum_rmspe", acc.rmspe);
  if (noise) v.emplace_back("accum_rmse_corrected", acc.rmseCorrected);
  if (m.ensemble) {
    v.emplace_back("ensemble_mse", m.ensemble->mse);
    v.emplace_back("ensemble_bias2", m.ensemble->bias2);
    v.emplace_back("ensemble_variance", m.ensemble->variance);
    v.emplace_back("ensemble_bias2_noise", m.ensemble->bias2Noise);
    v.emplace_back("ensemble_luma_ratio", m.ensemble->lumaRatio);
    v.emplace_back("ensemble_luma_ratio_stderr", m.ensemble->lumaRatioStdError);
    v.emplace_back("rmse_seed_sd", m.ensemble->seedSd[0]);
    v.emplace_back("luma_rmse_seed_sd", m.ensemble->seedSd[1]);
    v.emplace_back("relmse_seed_sd", m.ensemble->seedSd[2]);
    v.emplace_back("rmspe_seed_sd", m.ensemble->seedSd[3]);
  }
  if (m.converged) {
    v.emplace_back("ensemble_accum_rmspe", m.converged->rmspe);
    v.emplace_back("ensemble_accum_rmspe_bias", m.converged->bias);
    v.emplace_back("ensemble_accum_rmspe_bias_low", m.converged->biasLow);
    v.emplace_back("ensemble_accum_rmspe_bias_high", m.converged->biasHigh);
  }
  v.emplace_back("flicker", m.previousImage ? Flicker(*m.image, *m.previousImage, ref, *m.previousReference) : 0.0);
}

// The same for ReSTIR GI's reservoirs, whose samples are paths' secondary vertices (issue 41): seed 004's regime is
// where few of them contribute. Fixed columns; 0 for a preset that does not reuse paths.
void AppendIndirectReservoirColumns(const FrameMeasurement& m, Columns& v) {
  const size_t pixels = m.image->Size();
  const ReservoirDiagnostics d = m.indirectDiagnostics ? *m.indirectDiagnostics : ReservoirDiagnostics{};
  v.emplace_back("gi_contrib_initial", d.contributingInitial);
  v.emplace_back("gi_contrib_temporal", d.contributingTemporal);
  v.emplace_back("gi_contrib_spatial", d.contributingSpatial);
  v.emplace_back("gi_contrib_shaded", d.contributingShaded);
  v.emplace_back("gi_contrib_initial_disocc", d.contributingInitialRegion);
  v.emplace_back("gi_contrib_temporal_disocc", d.contributingTemporalRegion);
  v.emplace_back("gi_contrib_spatial_disocc", d.contributingSpatialRegion);
  v.emplace_back("gi_mean_confidence", d.confidenceMean);
  v.emplace_back("gi_sample_age", d.ageMean);
  v.emplace_back("gi_duplicate_fraction", d.duplicateFraction);
  const PassStats spatial = m.indirectSpatial ? *m.indirectSpatial : PassStats{};
  v.emplace_back("ms_gi_spatial", spatial.ms);
  v.emplace_back("gi_rays_per_pixel_spatial", double(spatial.rays) / double(pixels));
  v.emplace_back("gi_targets_per_pixel_spatial", double(spatial.targets) / double(pixels));
  v.emplace_back("gi_reservoir_reads_per_pixel_spatial", double(spatial.reservoirReads) / double(pixels));
  v.emplace_back("gi_spatial_failed_fraction", spatial.visited ? double(spatial.failed) / double(spatial.visited) : 0.0);
}

// What the reservoirs held (issue 20) and the spatial pass's work per pixel, so a reader can price a method for
// other hardware (issue 39), with the share of its surface pixels that found nothing to reuse.
void AppendReservoirColumns(const FrameMeasurement& m, Columns& v) {
  const size_t pixels = m.image->Size();
  const ReservoirDiagnostics& d = m.diagnostics;
  v.emplace_back("mean_confidence", d.confidenceMean);
  v.emplace_back("confidence_sd", d.confidenceSd);
  v.emplace_back("contrib_initial", d.contributingInitial);
  v.emplace_back("contrib_temporal", d.contributingTemporal);
  v.emplace_back("contrib_spatial", d.contributingSpatial);
  v.emplace_back("contrib_shaded", d.contributingShaded);
  v.emplace_back("contrib_initial_disocc", d.contributingInitialRegion);
  v.emplace_back("contrib_temporal_disocc", d.contributingTemporalRegion);
  v.emplace_back("contrib_spatial_disocc", d.contributingSpatialRegion);
  v.emplace_back("sample_age", d.ageMean);
  v.emplace_back("duplicate_fraction", d.duplicateFraction);
  v.emplace_back("cross_object_reuse", static_cast<double>(m.crossObjectReuse));
  v.emplace_back("guarded", static_cast<double>(m.guarded));
  for (const char* name : kPassNames) {
    const PassStats* ps = FindPass(m, name);
    v.emplace_back(std::string("targets_per_pixel_") + name, ps ? double(ps->targets) / double(pixels) : 0.0);
  }
  const PassStats* spatial = FindPass(m, "spatial");
  v.emplace_back("reservoir_reads_per_pixel_spatial", spatial ? double(spatial->reservoirReads) / double(pixels) : 0.0);
  v.emplace_back("spatial_failed_fraction",
                 spatial && spatial->visited ? double(spatial->failed) / double(spatial->visited) : 0.0);
  AppendIndirectReservoirColumns(m, v);
}

}  // namespace

FrameMetricsRow MeasureFrame(const FrameMeasurement& m) {
  FrameMetricsRow row;
  row.frame = m.frame;
  row.preset = m.preset;
  AppendCostColumns(m, row.values);
  if (m.reference) AppendErrorColumns(m, row.values);
  Columns& v = row.values;
  v.emplace_back("stability_luma_rmse", m.previousImage ? StabilityLumaRmse(*m.image, *m.previousImage) : 0.0);
  v.emplace_back("disocc_fraction", m.disoccFraction);
  v.emplace_back("disocc_recent_fraction", m.recentFraction);
  v.emplace_back("temporal_acceptance", m.temporalAcceptance);
  AppendReservoirColumns(m, v);
  row.imageHash = HexHash(HashImage(*m.image));
  return row;
}

}  // namespace restir
