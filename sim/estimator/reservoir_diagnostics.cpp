#include "sim/estimator/reservoir_diagnostics.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace restir {

namespace {

bool Contributes(const StoredReservoir& r) {
  const float pw = r.targetPdf * r.W;
  return std::isfinite(pw) && pw > 0.0f;
}

// A sample as the duplicate count compares it: its light id and its point's bits, packed so that the 5x5 window's
// comparisons read 16 bytes a pixel instead of a 48-byte reservoir and two G-buffer arrays.
struct SampleKey {
  uint64_t lo = 0, hi = 0;
  bool operator==(const SampleKey&) const = default;
};
static_assert(sizeof(uint32_t) + sizeof(Vec3) == sizeof(SampleKey));

SampleKey KeyOf(const StoredReservoir& r) {
  uint32_t words[4];
  words[0] = r.lightId;
  std::memcpy(words + 1, &r.position, sizeof(Vec3));
  SampleKey k;
  std::memcpy(&k, words, sizeof(k));
  return k;
}

}  // namespace

Contributing ContributingFraction(const GBuffer& g, const ReservoirBuffer& reservoirs,
                                  const std::vector<uint8_t>* region) {
  const bool masked = region && region->size() == g.Size();
  // Counts, so the parallel sum is exact: the same fractions whatever the thread count and split.
  struct Counts {
    size_t surfaces = 0, contributing = 0, regionSurfaces = 0, regionContributing = 0;
  };
  const size_t n = std::min(g.Size(), reservoirs.size());
  const Counts total = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 4096), Counts{},
      [&](const tbb::blocked_range<size_t>& range, Counts c) {
        for (size_t i = range.begin(); i < range.end(); ++i) {
          if (!g.IsSurface(i)) continue;
          const bool contributes = Contributes(reservoirs[i]);
          ++c.surfaces;
          c.contributing += contributes;
          if (masked && (*region)[i]) ++c.regionSurfaces, c.regionContributing += contributes;
        }
        return c;
      },
      [](Counts a, const Counts& b) {
        a.surfaces += b.surfaces, a.contributing += b.contributing;
        a.regionSurfaces += b.regionSurfaces, a.regionContributing += b.regionContributing;
        return a;
      });
  Contributing f;
  f.all = total.surfaces ? double(total.contributing) / double(total.surfaces) : 0.0;
  f.region = total.regionSurfaces ? double(total.regionContributing) / double(total.regionSurfaces) : 0.0;
  return f;
}

void MeasureOutputReservoirs(const GBuffer& g, const ReservoirBuffer& reservoirs, ReservoirDiagnostics& d) {
  const int w = g.width, h = g.height;
  if (reservoirs.size() != g.Size()) return;
  // Per row, then rows summed in order: the same sums whatever the thread count.
  struct Row {
    double confidence = 0.0, confidence2 = 0.0, age = 0.0, duplicates = 0.0;
    size_t surfaces = 0, sampled = 0, compared = 0;
  };
  std::vector<Row> rows(static_cast<size_t>(h));
  std::vector<SampleKey> key(g.Size());
  std::vector<uint8_t> sampled(g.Size());  // a surface whose reservoir has a sample: the pixels compared
  tbb::parallel_for(tbb::blocked_range<size_t>(0, g.Size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i < range.end(); ++i) {
      sampled[i] = g.IsSurface(i) && reservoirs[i].HasSample();
      if (sampled[i]) key[i] = KeyOf(reservoirs[i]);
    }
  });
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& range) {
    for (int y = range.begin(); y < range.end(); ++y) {
      Row& row = rows[static_cast<size_t>(y)];
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (!g.IsSurface(i)) continue;
        const StoredReservoir& r = reservoirs[i];
        ++row.surfaces;
        if (std::isfinite(r.confidence))
          row.confidence += r.confidence, row.confidence2 += double(r.confidence) * r.confidence;
        if (!r.HasSample()) continue;
        ++row.sampled;
        row.age += r.history.age;
        int same = 0, others = -1;  // the window counts the pixel itself, which has a sample
        const SampleKey own = key[i];
        const int x0 = std::max(0, x - kDuplicateRadius), x1 = std::min(w - 1, x + kDuplicateRadius);
        for (int ny = std::max(0, y - kDuplicateRadius); ny <= std::min(h - 1, y + kDuplicateRadius); ++ny)
          for (int nx = x0; nx <= x1; ++nx) {
            const size_t j = static_cast<size_t>(ny) * w + nx;
            if (!sampled[j]) continue;
            ++others;
            same += key[j] == own;
          }
        --same;  // and its own sample is the same
        if (others > 0) {
          row.duplicates += double(same) / double(others);
          ++row.compared;
        }
      }
    }
  });
  Row total;
  for (const Row& r : rows) {
    total.confidence += r.confidence, total.confidence2 += r.confidence2, total.age += r.age;
    total.duplicates += r.duplicates;
    total.surfaces += r.surfaces, total.sampled += r.sampled, total.compared += r.compared;
  }
  const double n = double(total.surfaces);
  d.confidenceMean = total.surfaces ? total.confidence / n : 0.0;
  d.confidenceSd = total.surfaces
                       ? std::sqrt(std::max(0.0, total.confidence2 / n - d.confidenceMean * d.confidenceMean))
                       : 0.0;
  d.ageMean = total.sampled ? total.age / double(total.sampled) : 0.0;
  d.duplicateFraction = total.compared ? total.duplicates / double(total.compared) : 0.0;
}

void RecordContributing(const Contributing& initial, const Contributing& temporal, const Contributing& spatial,
                        ReservoirDiagnostics& d) {
  d.contributingInitial = initial.all, d.contributingInitialRegion = initial.region;
  d.contributingTemporal = temporal.all, d.contributingTemporalRegion = temporal.region;
  d.contributingSpatial = spatial.all, d.contributingSpatialRegion = spatial.region;
}

}  // namespace restir
