#include "sim/reservoir_diagnostics.h"

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

bool SameSample(const StoredReservoir& a, const StoredReservoir& b) {
  return a.lightId == b.lightId && std::memcmp(&a.position, &b.position, sizeof(Vec3)) == 0;
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
        int same = 0, others = 0;
        for (int dy = -kDuplicateRadius; dy <= kDuplicateRadius; ++dy)
          for (int dx = -kDuplicateRadius; dx <= kDuplicateRadius; ++dx) {
            const int nx = x + dx, ny = y + dy;
            if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
            const size_t j = static_cast<size_t>(ny) * w + nx;
            if (!g.IsSurface(j) || !reservoirs[j].HasSample()) continue;
            ++others;
            same += SameSample(r, reservoirs[j]);
          }
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

}  // namespace restir
