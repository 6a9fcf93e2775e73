// What a learned light distribution could gain in the reference at most (issue 40; docs/metrics.md "What learning
// within a light could gain"): an oracle, not the reference. For the diffuse pixels of a few 8 × 8-pixel tiles of a
// skyless sequence's frame 0, it traces every light triangle's K × K cells (M jittered points each, on the same
// square-root map as core/light.h SampleTrianglePoint, so a cell is a patch of the triangle) and takes the
// discretised integrand as the truth. For each way of choosing a sample it then computes the relative variance of one
// sample exactly: E[X²] / I² − 1 with E[X²] = Σ g² / q over the points (g a point's share of the integral, q its
// probability). Every scheme keeps the reference's defensive power share 0.1 for the triangle and 0.1 / K² for the
// cell, so all are unbiased; they differ in what they know:
//
//   unshadowed       P(triangle) ∝ the pixel's unshadowed contribution U (the reference before issue 40)
//   tile U, tile V   ∝ the tile's mean U (each pixel's normalised) × the tile's visible share (one table per tile)
//   pixel U, tile V  ∝ the pixel's U × the tile's visible share (the reference's per-pixel tables and learning)
//   pixel U, pixel V ∝ the pixel's U × its own visible share: perfect visibility per light
//   tile cells       pixel U, tile V, then a cell ∝ the tile's visible share of that cell (path guiding in a light)
//   pixel cells      pixel U, pixel V, then a cell ∝ the pixel's visible share of it: perfect per cell
//   probe cells      one shadow ray per cell (its first point) decides the cell's weight, 1 or 0
//
// The oracle knows what the reference would have to learn from its 16 pilot samples a pixel, so a scheme's figure
// is the most it could give; a scheme that does not beat the one above it here cannot in the reference. (Its tile
// sums leave out the tile's pixels that no light reaches, which the reference's learning counts: "tile V" is, if
// anything, optimistic.)
// Usage: reference_oracle_bench SEQUENCE.json [K=8] [M=2] [TILES=25]   (prints one line per scheme: mean, median
// and 99th percentile over lit pixels of the one-sample relative variance, and the mean relative standard error it
// would leave at 256 samples a pixel).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "sim/reference/reference.h"  // NearestRankIndex
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/scene/sequence.h"
#include "tests/sim/reference/emitters_in_double.h"

namespace restir {
namespace {

// The frame's emitters as the brute-force check reads them, with what the oracle weighs them by.
struct Emitter : test::EmitterInDouble {
  double luminance = 0.0;  // of its radiance
  double power = 0.0;      // luminance × area (the defensive share's weight; π is common to all)
};

std::vector<Emitter> Emitters(const Sequence& seq, const FrameState& state) {
  std::vector<Emitter> out;
  for (const test::EmitterInDouble& d : test::CollectEmitters(seq, state)) {
    Emitter e;
    static_cast<test::EmitterInDouble&>(e) = d;
    e.luminance = Luminance(d.radiance);
    e.power = e.luminance * e.area;
    if (e.luminance > 0.0) out.push_back(e);
  }
  return out;
}

// One pixel's discretised integrand, per (triangle, cell) k = triangle × K² + cell.
struct PixelCells {
  std::vector<double> unshadowed, visible;      // Σ g over the cell's points, unshadowed and where unoccluded
  std::vector<double> visibleSquares;           // Σ g² over its unoccluded points
  std::vector<int8_t> probe;                    // its first point's ray: 1 arrived, 0 blocked, -1 none traced
  double total = 0.0, totalUnshadowed = 0.0;    // I and U
};

PixelCells TracePixel(const EmbreeScene& scene, const std::vector<Emitter>& emitters, const GBuffer& g, size_t i,
                      int K, int M, std::mt19937_64& rng) {
  const size_t cells = size_t(K) * K;
  PixelCells q;
  q.unshadowed.assign(emitters.size() * cells, 0.0);
  q.visible = q.visibleSquares = q.unshadowed;
  q.probe.assign(q.unshadowed.size(), -1);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const glm::dvec3 x(g.Position(i));
  const glm::dvec3 n = glm::normalize(glm::dvec3(g.GeometricNormal(i)));
  const double scale = std::max({double(g.errorScale[i]), std::abs(x.x), std::abs(x.y), std::abs(x.z), 1.0});
  const glm::dvec3 org = x + 4e-6 * scale * n;
  std::vector<ShadowRay> rays;
  std::vector<std::pair<size_t, double>> point;  // (k, g) per ray
  std::vector<uint8_t> occluded;
  for (size_t e = 0; e < emitters.size(); ++e) {
    const Emitter& L = emitters[e];
    if (!(glm::dot(L.normal, x - L.p0) > 0.0)) continue;
    rays.clear();
    point.clear();
    for (int a = 0; a < K; ++a)
      for (int b = 0; b < K; ++b)
        for (int j = 0; j < M; ++j) {
          const double u1 = (a + u01(rng)) / K, u2 = (b + u01(rng)) / K, s = std::sqrt(u1);
          const glm::dvec3 y = L.p0 + (1.0 - s) * L.e1 + u2 * s * L.e2;
          const glm::dvec3 d = y - x;
          const double d2 = glm::dot(d, d), dist = std::sqrt(d2);
          const double cosX = glm::dot(n, d) / dist, cosY = -glm::dot(L.normal, d) / dist;
          if (!(cosX > 0.0) || !(cosY > 0.0)) continue;
          const glm::dvec3 end = y + 4e-6 * (L.scale + dist) * L.normal;
          const glm::dvec3 dir = end - org;
          const double len = glm::length(dir);
          rays.push_back(ShadowRay{Vec3(org), Vec3(dir / len), static_cast<float>(len)});
          point.push_back({e * cells + size_t(a) * K + b, L.luminance * cosX * cosY / d2 * L.area / double(cells * M)});
        }
    occluded.resize(rays.size());
    if (!rays.empty()) scene.OccludedBatch(rays.data(), occluded.data(), rays.size());
    for (size_t r = 0; r < rays.size(); ++r) {
      const auto [k, gk] = point[r];
      q.unshadowed[k] += gk;
      if (q.probe[k] < 0) q.probe[k] = occluded[r] ? 0 : 1;
      if (!occluded[r]) q.visible[k] += gk, q.visibleSquares[k] += gk * gk;
    }
  }
  for (size_t k = 0; k < q.visible.size(); ++k) q.total += q.visible[k], q.totalUnshadowed += q.unshadowed[k];
  return q;
}

enum Scheme { kUnshadowed, kTileTile, kPixelTile, kPixelPixel, kTileCells, kPixelCells, kProbeCells, kSchemes };
const char* const kSchemeNames[kSchemes] = {"unshadowed",       "tile U, tile V", "pixel U, tile V", "pixel U, pixel V",
                                            "tile cells",       "pixel cells",    "probe cells"};

double Ratio(double a, double b) { return b > 0.0 ? a / b : 0.0; }

// The one-sample relative variance of pixel q under each scheme, given its tile's sums (each pixel's normalised by
// its own U).
void Variances(const PixelCells& q, const std::vector<double>& tileVisible, const std::vector<double>& tileUnshadowed,
               const std::vector<Emitter>& emitters, double totalPower, size_t cells, int M, double (&out)[kSchemes]) {
  const size_t E = emitters.size();
  std::vector<double> U(E, 0.0), V(E, 0.0), tU(E, 0.0), tV(E, 0.0);
  for (size_t k = 0; k < q.visible.size(); ++k) {
    U[k / cells] += q.unshadowed[k], V[k / cells] += q.visible[k];
    tU[k / cells] += tileUnshadowed[k], tV[k / cells] += tileVisible[k];
  }
  for (int s = 0; s < kSchemes; ++s) {
    std::vector<double> w(E, 0.0);
    double sum = 0.0;
    for (size_t e = 0; e < E; ++e) {
      double visibleShare = 1.0;
      if (s == kTileTile || s == kPixelTile || s == kTileCells) visibleShare = Ratio(tV[e], tU[e]);
      if (s == kPixelPixel || s == kPixelCells) visibleShare = Ratio(V[e], U[e]);
      if (s == kProbeCells) {  // the probes' share, shrunk towards the tile's by one pseudo-sample
        double probed = 0.0, arrived = 0.0;
        for (size_t c = 0; c < cells; ++c)
          if (q.probe[e * cells + c] >= 0) probed += 1.0, arrived += q.probe[e * cells + c];
        visibleShare = (arrived + Ratio(tV[e], tU[e])) / (probed + 1.0);
      }
      w[e] = (s == kTileTile ? tU[e] : U[e]) * visibleShare;
      sum += w[e];
    }
    double secondMoment = 0.0;
    for (size_t e = 0; e < E; ++e) {
      // As the reference mixes its tables: the defensive share beside a learned one, the defensive distribution
      // alone where nothing was learned (so that every scheme's probabilities sum to 1).
      const double share = emitters[e].power / totalPower;
      const double pe = sum > 0.0 ? 0.9 * w[e] / sum + 0.1 * share : share;
      std::vector<double> pc(cells, 1.0 / double(cells));
      if (s == kTileCells || s == kPixelCells || s == kProbeCells) {
        std::vector<double> r(cells, 0.0);
        double rs = 0.0;
        for (size_t c = 0; c < cells; ++c) {
          const size_t k = e * cells + c;
          r[c] = s == kTileCells    ? Ratio(tileVisible[k], tileUnshadowed[k])
                 : s == kPixelCells ? Ratio(q.visible[k], q.unshadowed[k])
                                    : (q.probe[k] > 0 ? 1.0 : 0.0);
          rs += r[c];
        }
        for (size_t c = 0; c < cells; ++c) pc[c] = rs > 0.0 ? 0.9 * r[c] / rs + 0.1 / double(cells) : 1.0 / double(cells);
      }
      for (size_t c = 0; c < cells; ++c) {
        const size_t k = e * cells + c;
        if (q.visibleSquares[k] > 0.0) secondMoment += q.visibleSquares[k] / (pe * pc[c] / M);
      }
    }
    out[s] = secondMoment / (q.total * q.total) - 1.0;
  }
}

}  // namespace
}  // namespace restir

int main(int argc, char** argv) {
  using namespace restir;
  if (argc < 2) {
    std::fprintf(stderr, "usage: reference_oracle_bench SEQUENCE.json [K=8] [M=2] [TILES=25]\n");
    return 2;
  }
  const int K = argc > 2 ? std::atoi(argv[2]) : 8, M = argc > 3 ? std::atoi(argv[3]) : 2;
  const int tilesWanted = argc > 4 ? std::atoi(argv[4]) : 25;
  if (K < 1 || M < 1 || tilesWanted < 1) {
    std::fprintf(stderr, "reference_oracle_bench: K, M and TILES must be positive\n");
    return 2;
  }
  const Sequence seq = LoadSequence(argv[1]);
  if (seq.environment.present || seq.sun.present) {
    std::fprintf(stderr, "reference_oracle_bench: %s has a sky; the oracle takes local lights only\n", argv[1]);
    return 2;
  }
  const FrameState state = Evaluate(seq, 0, seq.width, seq.height);
  EmbreeScene scene(seq);
  scene.Update(state);
  GBuffer g;
  TracePrimary(scene, state.camera, g);
  const std::vector<Emitter> emitters = Emitters(seq, state);
  double totalPower = 0.0;
  for (const Emitter& e : emitters) totalPower += e.power;
  const size_t cells = size_t(K) * K;
  // Tiles on an even grid over the screen.
  const int tilesX = seq.width / 8, tilesY = seq.height / 8;
  if (tilesX < 1 || tilesY < 1) {
    std::fprintf(stderr, "reference_oracle_bench: %s is smaller than one 8 x 8 tile\n", argv[1]);
    return 2;
  }
  const int side = static_cast<int>(std::ceil(std::sqrt(double(tilesWanted))));
  std::vector<std::pair<int, int>> tiles;
  for (int a = 0; a < side; ++a)
    for (int b = 0; b < side; ++b) tiles.push_back({(2 * a + 1) * tilesX / (2 * side), (2 * b + 1) * tilesY / (2 * side)});
  std::vector<double> variances[kSchemes];
  std::mutex mutex;
  tbb::parallel_for(size_t(0), tiles.size(), [&](size_t t) {
    std::mt19937_64 rng(0x0AC1E + t);
    std::vector<PixelCells> pixels;
    for (int y = tiles[t].second * 8; y < tiles[t].second * 8 + 8; ++y)
      for (int x = tiles[t].first * 8; x < tiles[t].first * 8 + 8; ++x) {
        const size_t i = size_t(y) * seq.width + x;
        if (!g.IsSurface(i) || g.lightId[i] >= 0 || seq.materials[g.materialId[i]].type != MaterialType::kDiffuse)
          continue;
        PixelCells q = TracePixel(scene, emitters, g, i, K, M, rng);
        if (q.total > 0.0) pixels.push_back(std::move(q));
      }
    std::vector<double> tileVisible(emitters.size() * cells, 0.0), tileUnshadowed(tileVisible.size(), 0.0);
    for (const PixelCells& q : pixels)
      for (size_t k = 0; k < tileVisible.size(); ++k)
        tileVisible[k] += q.visible[k] / q.totalUnshadowed, tileUnshadowed[k] += q.unshadowed[k] / q.totalUnshadowed;
    std::vector<double> out[kSchemes];
    for (const PixelCells& q : pixels) {
      double v[kSchemes];
      Variances(q, tileVisible, tileUnshadowed, emitters, totalPower, cells, M, v);
      for (int s = 0; s < kSchemes; ++s) out[s].push_back(v[s]);
    }
    std::lock_guard<std::mutex> lock(mutex);
    for (int s = 0; s < kSchemes; ++s) variances[s].insert(variances[s].end(), out[s].begin(), out[s].end());
  });
  std::printf("%s: %zu light triangles, %d x %d cells of %d points, %zu tiles, %zu lit pixels\n", argv[1],
              emitters.size(), K, K, M, tiles.size(), variances[0].size());
  if (variances[0].empty()) return 0;
  for (int s = 0; s < kSchemes; ++s) {
    std::vector<double> v = variances[s];
    std::sort(v.begin(), v.end());
    double mean = 0.0, meanSe = 0.0;
    for (double x : v) mean += x, meanSe += std::sqrt(std::max(0.0, x) / 256.0);
    const size_t rank = NearestRankIndex(v.size(), 0.99);  // as MeasureReferenceConvergence takes the 99th
    std::printf("  %-17s relative variance of one sample: mean %.4g, median %.4g, p99 %.4g; mean rel. se at 256: %.2f%%\n",
                kSchemeNames[s], mean / v.size(), v[v.size() / 2], v[rank], 100.0 * meanSe / v.size());
  }
  return 0;
}
