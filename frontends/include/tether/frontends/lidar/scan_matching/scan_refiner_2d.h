#pragma once
// Refining a scan's pose by nonlinear least squares: the ScanMatchSE2 factor
// (tether/factors/scan_match_se2.h) minimised alone with tether's own solver (Optimize,
// Levenberg-Marquardt over Eigen's LDLT: three unknowns). It converges to the minimum of the
// basin it starts in, hence the correlative matcher's guess (real_time_correlative_scan_matcher_2d.h).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"
#include "tether/factors/scan_match_se2.h"
#include "tether/solvers/solver_options.h"

namespace tether {
namespace lidar {

struct ScanRefinerOptions {
  ScanMatchWeights weights;  ///< the factor's weights (ScanMatchWeights: 1, 1 and 1)
  int max_iterations = 20;
  bool IsValid(std::string* why) const;
};

struct ScanRefinement {
  SE2d pose;
  SolverStatus status = SolverStatus::kInvalidInput;
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;  ///< the factor's whitened squared error
};

/// Minimises the scan-match cost of `points` (the scan's frame) on `grid` from `initial`, with
/// the regularisers pulling towards `guess` (the odometry prediction). Throws InvalidArgument
/// for invalid options or input (as ScanMatchSE2 does).
ScanRefinement RefineScanPose(const std::shared_ptr<const ProbabilityGrid>& grid, const SE2d& initial,
                              const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                              const ScanRefinerOptions& options = {});

}  // namespace lidar
}  // namespace tether
