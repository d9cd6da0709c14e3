#pragma once
// ScanMatchSE2: how well a 2D laser scan fits a probability grid at a pose, with regularisers
// towards an initial guess (the local scan matching of Hess et al. 2016, section IV.C).
//
// One key, the scan's pose T = (t, theta) in the grid's (map) frame. With h_k the scan's points
// in the scan's own frame and M_smooth the bicubic interpolation of the grid
// (grid_interpolation.h), the error is
//   e_k     = 1 - M_smooth(T h_k)          k = 0 .. N-1
//   e_N+0,1 = t - t_guess                  (map frame, m)
//   e_N+2   = wrap(theta - theta_guess)    (rad)
// (an unknown cell reads as weights.unknown_probability, 0.5) and the noise model is diagonal: occupied_space / sqrt(N)
// on every point's row (the scan's total weight does not depend on its size), translation on the two translation rows
// and rotation on the last. The Jacobians are analytic (the interpolation's gradient, chained through the box-plus t +
// R dt, theta + dtheta).
//
// The factor shares the grid (shared_ptr) and reads it whenever it is evaluated: give it a grid
// that no longer changes (a finished submap's) or accept that it follows the grid.
//
// Registered as a built-in type without a g2o tag: a file would have to hold the grid, so g2o
// files cannot carry the factor and writing a graph holding one is an error that says so
// (the pose graph stores the match's result as a pose-pose constraint instead).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/registry.h"
#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"

namespace tether {

/// Weights of the scan-match factor's rows (square roots of information). Cartographer's 2D
/// local matcher uses 1, 10 and 40 with a motion extrapolator's guess; with raw odometry as the
/// guess those regularisers hold the pose at the odometry (Intel: 3.1 m relation error against
/// 0.17 m with 1 and 1, docs/lidar_mapping.md), hence 1, 1 and 1.
struct ScanMatchWeights {
  double occupied_space = 1.0;  ///< all points together (each row: occupied_space / sqrt(N))
  double translation = 1.0;     ///< per metre of distance from the guess
  double rotation = 1.0;        ///< per radian from the guess
  /// What M_smooth reads in a cell no scan has seen: 0.5, the prior (neither hit nor free).
  /// The grid's minimum (Cartographer's choice) makes free cells (0.49 after one miss) far
  /// more attractive than unseen ones, so a scan's points are drawn off a sparsely hit wall
  /// into the free space before it (docs/lidar_mapping.md has the measurements).
  double unknown_probability = 0.5;
  /// True where the weights are finite and positive and unknown_probability lies in [0, 1];
  /// otherwise says which is not.
  bool IsValid(std::string* why) const;
};

class ScanMatchSE2 : public Factor {
 public:
  static constexpr const char* kTypeName = "ScanMatchSE2";

  /// Throws InvalidArgument for a null grid, no points, a point or guess that is not finite,
  /// or invalid weights.
  ScanMatchSE2(Key pose, std::shared_ptr<const ProbabilityGrid> grid, std::vector<Eigen::Vector2d> points,
               const SE2d& guess, const ScanMatchWeights& weights = {});

  std::string type_name() const override { return kTypeName; }
  int residual_dim() const override { return static_cast<int>(points_.size()) + 3; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE2}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<ScanMatchSE2>(*this); }

  const std::shared_ptr<const ProbabilityGrid>& grid() const { return grid_; }
  const std::vector<Eigen::Vector2d>& points() const { return points_; }
  const SE2d& guess() const { return guess_; }
  const ScanMatchWeights& weights() const { return weights_; }

 private:
  std::shared_ptr<const ProbabilityGrid> grid_;
  std::vector<Eigen::Vector2d> points_;
  SE2d guess_;
  ScanMatchWeights weights_;
};

/// Registers ScanMatchSE2 (no g2o tag; the entry's dim is 3, the regularisers' rows: a factor
/// has 3 + N rows). Called by RegisterBuiltinFactors.
void RegisterScanMatchFactor(Registry& registry);

}  // namespace tether
