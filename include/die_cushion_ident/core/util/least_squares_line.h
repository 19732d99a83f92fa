#pragma once

#include <cmath>
#include <limits>

namespace die_cushion_ident {

/// The least-squares line y = y_mean + slope (x - x_mean) through the points with a finite y; the sums are
/// taken about the means (a stamp of 1.7e9 s as x loses nothing). `slope` is NaN with fewer than two points
/// or no spread in x.
struct LeastSquaresLine {
  double points = 0.0;
  double x_mean = 0.0, y_mean = 0.0;
  double slope = std::numeric_limits<double>::quiet_NaN();
  double at(double x) const { return y_mean + slope * (x - x_mean); }
};

/// `for_each_point(visit)` calls visit(x, y) for every point, in the same order each time (it is called
/// twice: for the means, then for the sums about them).
template <typename ForEachPoint>
LeastSquaresLine fitLeastSquaresLine(ForEachPoint for_each_point) {
  LeastSquaresLine line;
  for_each_point([&](double x, double y) {
    if (!std::isfinite(y)) return;
    line.points += 1.0;
    line.x_mean += (x - line.x_mean) / line.points;
    line.y_mean += (y - line.y_mean) / line.points;
  });
  double sxx = 0.0, sxy = 0.0;
  for_each_point([&](double x, double y) {
    if (!std::isfinite(y)) return;
    const double dx = x - line.x_mean;
    sxx += dx * dx;
    sxy += dx * (y - line.y_mean);
  });
  if (line.points >= 2.0 && sxx > 0.0) line.slope = sxy / sxx;
  return line;
}

}  // namespace die_cushion_ident
