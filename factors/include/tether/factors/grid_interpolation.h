#pragma once
// M_smooth: the bicubic interpolation of a probability grid, a smooth function of position
// that the scan-match factor minimises over.
//
// The samples are the cells' probabilities at the cells' centres (unknown cells read as
// `unknown_probability`: the grid's minimum unless given); between them, cubic convolution with the Catmull-Rom kernel
// (Keys' a = -1/2) along x and then along y. The result passes through the samples, is
// continuous with a continuous gradient, and reproduces linear functions exactly.
#include <Eigen/Core>

#include "tether/factors/probability_grid.h"

namespace tether {

/// M_smooth(p) for a point p in the grid's (map) frame; where `gradient` is not null, also
/// dM/dp in 1/m.
double InterpolateProbability(const ProbabilityGrid& grid, const Eigen::Vector2d& p,
                              Eigen::Vector2d* gradient = nullptr);
double InterpolateProbability(const ProbabilityGrid& grid, const Eigen::Vector2d& p, Eigen::Vector2d* gradient,
                              double unknown_probability);

}  // namespace tether
