// The reference's path guide (issues 40 and 41; docs/metrics.md "Indirect light"): where a pixel's indirect light
// comes from through a small bright patch (a sunlit floor seen from the rest of a room), paths drawn by the BSDF
// alone find it rarely, and a pixel whose paths all miss it reads exactly 0 with no spread. The pilot's paths
// record, per guide tile, how much they carried back from each world direction; the main pass draws each path's
// first direction from a one-sample mixture of x₁'s BSDF and that histogram (Müller et al. 2017, "Practical Path
// Guiding", learned per screen tile instead of in a spatial tree; Veach 1997 §9.2.4 for the mixture).
//
// What stays unbiased: the histogram is a function of the pilot's random numbers only, independent of the main
// pass's; a path's weight is its integrand over the mixture's density, evaluated at the direction it took (the
// same function for both strategies' directions); the BSDF keeps share kGuideBsdfShare, so every direction the
// integrand reaches keeps a positive density however wrong the histogram is. The histogram only decides how much
// noise is left.
//
// Directions are binned by Lambert's equal-area cylindrical map (z = cos θ and φ each split evenly): every bin
// subtends 4π / kGuideBins steradians, so a bin's density is its share over that solid angle. Pure functions.
#pragma once

#include <array>
#include <cstddef>

#include "core/math.h"

namespace restir {

inline constexpr int kGuideTile = 16;     // pixels a side of a guide tile (16 × 16 × 16 pilot paths = 4096)
inline constexpr int kGuideRows = 16;     // bins in cos θ from world +y (the map's axis), evenly
inline constexpr int kGuideColumns = 32;  // bins in φ
inline constexpr int kGuideBins = kGuideRows * kGuideColumns;  // each ≈ 0.0245 sr, a cone of about 5° half-angle
// The BSDF's share of the first direction's mixture: half the paths are drawn as an unguided reference would draw
// them, so a guide that points wrong costs at most a factor 2 in variance where the BSDF alone would have done.
inline constexpr float kGuideBsdfShare = 0.5f;

// The bin of a unit direction (world space; y up).
int GuideBin(const Vec3& dir);

// One tile's learned distribution over the bins: sample it and ask its density.
class DirectionGuide {
 public:
  DirectionGuide() = default;
  // From per-bin non-negative weights (kGuideBins of them; a non-finite or negative one counts as 0). Empty where
  // their sum is not > 0: nothing to guide by.
  explicit DirectionGuide(const double* weights);
  bool Empty() const { return !(total_ > 0.0f); }
  // Solid-angle density of Sample producing `dir` (unit); 0 for an empty guide.
  float Pdf(const Vec3& dir) const;
  // A direction by the histogram from two uniform numbers: the bin by u0 (then u0 rescaled within the bin's share),
  // a uniform point of the bin by that and u1. Only for a guide that is not Empty.
  Vec3 Sample(float u0, float u1) const;

 private:
  std::array<float, kGuideBins> cdf_{};  // cumulative bin weights; cdf_[kGuideBins − 1] = total_
  float total_ = 0.0f;
};

}  // namespace restir
