#include "tether/factors/grid_interpolation.h"

#include <cmath>

namespace tether {

namespace {

// Catmull-Rom cubic through f[0..3] sampled at -1, 0, 1, 2, at t in [0, 1): value and d/dt.
inline void Cubic(const double* f, double t, double* value, double* derivative) {
  const double a = f[2] - f[0];
  const double b = 2 * f[0] - 5 * f[1] + 4 * f[2] - f[3];
  const double c = -f[0] + 3 * f[1] - 3 * f[2] + f[3];
  *value = f[1] + 0.5 * t * (a + t * (b + t * c));
  *derivative = 0.5 * (a + t * (2 * b + 3 * t * c));
}

}  // namespace

double InterpolateProbability(const ProbabilityGrid& grid, const Eigen::Vector2d& p, Eigen::Vector2d* gradient) {
  return InterpolateProbability(grid, p, gradient, grid.min_probability());
}

double InterpolateProbability(const ProbabilityGrid& grid, const Eigen::Vector2d& p, Eigen::Vector2d* gradient,
                              double unknown_probability) {
  // Continuous cell coordinates with the cells' centres at integers.
  const Eigen::Vector2d u = (p - grid.origin()) / grid.resolution() - Eigen::Vector2d::Constant(0.5);
  const double fx = std::floor(u.x()), fy = std::floor(u.y());
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  const double tx = u.x() - fx, ty = u.y() - fy;
  double rows[4], row_dx[4];
  for (int j = 0; j < 4; ++j) {
    double f[4];
    for (int i = 0; i < 4; ++i)
      f[i] = grid.Probability(ProbabilityGrid::Cell(ix - 1 + i, iy - 1 + j), unknown_probability);
    Cubic(f, tx, &rows[j], &row_dx[j]);
  }
  double value, dy;
  Cubic(rows, ty, &value, &dy);
  if (gradient != nullptr) {
    double dx, unused;
    Cubic(row_dx, ty, &dx, &unused);
    *gradient = Eigen::Vector2d(dx, dy) / grid.resolution();
  }
  return value;
}

}  // namespace tether
