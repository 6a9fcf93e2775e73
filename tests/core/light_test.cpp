// core/light.h's light groups (what the reference's light distributions select): quads cut as quad and grid lights
// are (A B C and A C D) pair into one group, whatever else does not; and a point drawn through a quad's group
// (a triangle by its area share, then uniformly on it) is uniform over the quadrilateral (chi-square).
#include "core/light.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/sampling.h"

namespace restir {
namespace {

std::vector<LightTriangle> Cut(const Vec3 (&q)[4], const Vec3& radiance, const Vec3& secondRadiance) {
  std::vector<LightTriangle> t(2);
  EXPECT_TRUE(MakeLightTriangle(q[0], q[1], q[2], radiance, t[0]));
  EXPECT_TRUE(MakeLightTriangle(q[0], q[2], q[3], secondRadiance, t[1]));
  return t;
}

TEST(LightGroups, QuadsPairAndNothingElseDoes) {
  const Vec3 L(3.0f, 2.0f, 1.0f);
  // A parallelogram far from the origin, tilted: one group, split by area, 1 / the whole area for both.
  const Vec3 c(1000.0f, 3.0f, -200.0f), u(0.4f, 0.1f, 0.0f), v(0.0f, 0.05f, 0.3f);
  const Vec3 square[4] = {c - u - v, c + u - v, c + u + v, c - u + v};
  std::vector<LightTriangle> tris = Cut(square, L, L);
  LightGroups g = MakeLightGroups(tris);
  ASSERT_EQ(g.first.size(), 1u);
  EXPECT_EQ(g.first[0], 0u);
  EXPECT_NEAR(g.split[0], tris[0].area / (tris[0].area + tris[1].area), 1e-6f);
  EXPECT_EQ(g.groupOf, (std::vector<uint32_t>{0, 0}));
  EXPECT_EQ(g.invArea[0], 1.0f / (tris[0].area + tris[1].area));
  EXPECT_EQ(g.invArea[1], g.invArea[0]);
  // A trapezoid: convex, unequal halves.
  const Vec3 trapezoid[4] = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(3, 0, 1), Vec3(1, 0, 1)};
  tris = Cut(trapezoid, L, L);
  g = MakeLightGroups(tris);
  ASSERT_EQ(g.first.size(), 1u);
  EXPECT_NEAR(g.split[0], 2.0f / 3.0f, 1e-6f);  // A B C has area 2 of the 3
  // Not pairs: another radiance, folded out of plane, a dart (not convex), a lone triangle, a degenerate one.
  EXPECT_EQ(MakeLightGroups(Cut(square, L, L * 0.5f)).first.size(), 2u);
  const Vec3 folded[4] = {square[0], square[1], square[2], square[3] + Vec3(0, 0.2f, 0)};
  EXPECT_EQ(MakeLightGroups(Cut(folded, L, L)).first.size(), 2u);
  const Vec3 dart[4] = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(1, 0, 1), Vec3(0, 0, 4)};
  EXPECT_EQ(MakeLightGroups(Cut(dart, L, L)).first.size(), 2u);
  tris = Cut(square, L, L);
  tris.insert(tris.begin(), tris[1]);  // a lone triangle first: the pair after it still pairs
  g = MakeLightGroups(tris);
  ASSERT_EQ(g.first.size(), 2u);
  EXPECT_EQ(g.split[0], 2.0f);
  EXPECT_EQ(g.first[1], 1u);
  // A sliver: convex, but its second half so thin (area 2e-9 of 8) that the area share rounds to 1 and the split
  // could never reach it: two groups, each triangle keeping its own probability.
  const Vec3 sliver[4] = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(4, 0, 4), Vec3(0, 0, 1e-9f)};
  tris = Cut(sliver, L, L);
  EXPECT_TRUE(FormsQuad(tris[0], tris[1]));
  EXPECT_EQ(tris[0].area / (tris[0].area + tris[1].area), 1.0f);
  EXPECT_EQ(MakeLightGroups(tris).first.size(), 2u);
  tris = Cut(square, L, L);
  tris.insert(tris.begin(), tris[1]);
  LightTriangle degenerate = tris[1];
  degenerate.area = 0.0f;
  EXPECT_EQ(MakeLightGroups({degenerate, tris[2]}).first.size(), 2u);
  // A grid of quads: one group each.
  std::vector<LightTriangle> grid;
  for (int i = 0; i < 6; ++i) {
    const Vec3 o(float(i), 3.0f, 0.0f);
    const Vec3 q[4] = {o, o + Vec3(0.5f, 0, 0), o + Vec3(0.5f, 0, 0.5f), o + Vec3(0, 0, 0.5f)};
    for (const LightTriangle& t : Cut(q, L, L)) grid.push_back(t);
  }
  EXPECT_EQ(MakeLightGroups(grid).first.size(), 6u);
}

// 2^20 points drawn through a trapezoid's group, binned on an 8 x 8 grid of its parameter square (each cell's area
// known in closed form): Pearson chi-square with 63 degrees of freedom below 140.1 (a false failure once in 1e7).
TEST(LightGroups, PointsDrawnThroughAQuadAreUniformOverIt) {
  const Vec3 q[4] = {Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(3, 0, 1), Vec3(1, 0, 1)};
  const std::vector<LightTriangle> tris = Cut(q, Vec3(1.0f), Vec3(1.0f));
  const LightGroups g = MakeLightGroups(tris);
  ASSERT_EQ(g.first.size(), 1u);
  const float cdf[1] = {1.0f};
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  constexpr int kBins = 8, kDraws = 1 << 20;
  std::vector<double> hits(kBins * kBins, 0.0);
  for (int k = 0; k < kDraws; ++k) {
    const uint32_t t = SampleSplitCdf(cdf, 1, g.first.data(), g.split.data(), u(rng));
    const Vec3 p = SampleTrianglePoint(tris[t], u(rng), u(rng));
    // The trapezoid is z in [0, 1], x from z to 4 - z: parameters (x - z) / (4 - 2z) and z.
    const float z = p.z, s = (p.x - z) / (4.0f - 2.0f * z);
    const int i = std::min(kBins - 1, static_cast<int>(s * kBins)), j = std::min(kBins - 1, static_cast<int>(z * kBins));
    hits[j * kBins + i] += 1.0;
  }
  // A cell between z0 and z1 covers (1/kBins) of the width at every z: area (1/kBins) ∫ (4 - 2z) dz.
  double chi2 = 0.0;
  for (int j = 0; j < kBins; ++j) {
    const double z0 = double(j) / kBins, z1 = double(j + 1) / kBins;
    const double area = (4.0 * (z1 - z0) - (z1 * z1 - z0 * z0)) / kBins;
    const double expected = kDraws * area / 3.0;  // the trapezoid's area is 3
    for (int i = 0; i < kBins; ++i) chi2 += (hits[j * kBins + i] - expected) * (hits[j * kBins + i] - expected) / expected;
  }
  EXPECT_LT(chi2, 140.1);
}

}  // namespace
}  // namespace restir
