#include "core/portable_math.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace restir {
namespace {

// |got − want| in units of the last place of want (its spacing at want's magnitude; the smallest normal's below it).
double UlpsApart(double got, double want) {
  const double spacing =
      std::max(std::nextafter(std::fabs(want), std::numeric_limits<double>::infinity()) - std::fabs(want),
               std::numeric_limits<double>::min());
  return std::fabs(got - want) / spacing;
}

// Against glibc's sin and cos over [−64, 64] (a million points, and the quarter turns' neighbourhoods, where the
// reduction cancels): within 2 units in the last place of the larger of the two results' magnitude (sin near a
// multiple of π is as accurate as the reduced argument, 1e-20 absolute).
TEST(PortableSinCos, AgreesWithLibmToTheLastPlaces) {
  double worst = 0.0;
  auto check = [&](double x) {
    double s, c;
    PortableSinCos(x, s, c);
    const double scale = std::max(std::fabs(std::sin(x)), std::fabs(std::cos(x)));
    const double ds = std::fabs(s - std::sin(x)) / (scale * std::numeric_limits<double>::epsilon());
    const double dc = std::fabs(c - std::cos(x)) / (scale * std::numeric_limits<double>::epsilon());
    worst = std::max(worst, std::max(ds, dc));
    ASSERT_LE(ds, 2.0) << "sin " << x;
    ASSERT_LE(dc, 2.0) << "cos " << x;
  };
  for (int i = 0; i <= 1000000; ++i) check(-64.0 + 128.0 * i / 1000000.0);
  for (int k = -40; k <= 40; ++k)
    for (double d : {0.0, 1e-300, 1e-12, -1e-12, 1e-6, -1e-6, 0.785, -0.785}) check(k * 1.5707963267948966 + d);
  for (double x : {0.0, 1e-300, -1e-300, 1e-8}) {
    double s, c;
    PortableSinCos(x, s, c);
    EXPECT_EQ(s, x);  // sin x = x to the last bit for tiny x
    EXPECT_EQ(c, 1.0);
  }
  RecordProperty("worst_epsilons", std::to_string(worst));
}

// Against glibc's atan2 over every quadrant, from 1e-300 to 1e300 in magnitude and near the axes and diagonals,
// within 4 units in the last place; the signed zeros as libm gives them.
TEST(PortableAtan2, AgreesWithLibmToTheLastPlaces) {
  for (int i = 0; i <= 200000; ++i) {
    const double phi = -3.14159265358979 + 6.28318530717958 * i / 200000.0;
    for (double r : {1e-300, 1e-10, 1.0, 3.7e5, 1e300}) {
      const double y = r * std::sin(phi), x = r * std::cos(phi);
      ASSERT_LE(UlpsApart(PortableAtan2(y, x), std::atan2(y, x)), 4.0) << y << " " << x;
    }
  }
  for (double t : {0.0, 1e-300, 1e-17, 1e-9, 0.41421356237309503, 0.41421356237309509, 0.999999999, 1.0, 1.0000001,
                   1e9, 1e300}) {
    for (double sy : {1.0, -1.0})
      for (double sx : {1.0, -1.0})
        ASSERT_LE(UlpsApart(PortableAtan2(sy * t, sx * 1.0), std::atan2(sy * t, sx * 1.0)), 4.0) << t;
  }
  for (double y : {0.0, -0.0})
    for (double x : {0.0, -0.0, 1.0, -1.0}) {
      EXPECT_EQ(PortableAtan2(y, x), std::atan2(y, x)) << y << " " << x;
      EXPECT_EQ(std::signbit(PortableAtan2(y, x)), std::signbit(std::atan2(y, x))) << y << " " << x;
    }
}

}  // namespace
}  // namespace restir
