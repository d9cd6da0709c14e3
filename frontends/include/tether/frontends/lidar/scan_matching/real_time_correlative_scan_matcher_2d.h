#pragma once
// The real-time correlative scan matcher (Olson 2009; Hess et al. 2016, section IV.C's initial
// guess): an exhaustive search over a small window of translations (steps of one grid cell) and
// rotations (steps of delta_theta) around a guess, each candidate scored by the mean of the
// grid's probabilities at the cells of the moved scan points, weighted down with its distance
// from the guess. The best candidate is the start of the nonlinear refinement
// (scan_refiner_2d.h), which alone finds only the minimum of the basin it starts in.
//
// Rotations are enumerated once each (the scan rotated, its points' cells computed); the
// translations then only add an integer offset to the cells, so a candidate costs one lookup
// per point.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

struct CorrelativeMatcherOptions {
  /// Half the side of the square of translations searched around the guess (m).
  double linear_search_window = 0.1;
  /// Half the range of rotations searched around the guess (rad; 20 degrees).
  double angular_search_window = 0.349065850398865915;
  /// The rotation step (rad); 0: arccos(1 - r^2 / (2 d^2)), r the resolution and d the
  /// farthest point, so that no point moves by more than one cell between steps.
  double angular_step = 0;
  /// A candidate's score is mean probability times exp(-(w_t |dt| + w_r |dtheta|)^2), dt in m
  /// and dtheta in rad from the guess (0: no preference for the guess). w_r 1 (a 10 degree
  /// turn costs 3% of the score) against 0.1 (0.03%): relations error with loop closures on
  /// Intel 0.041 m against 0.044, aces 0.127 against 0.173, fr079 0.26 against 0.97
  /// (benchmarks/RESULTS.md, "LiDAR V"). w_t 2 (a candidate 5 cm off costs 1% of the score)
  /// against 0.1: in a corridor whose walls match anywhere along it, the candidates where the
  /// submap's own scans were taken score a little higher, and with no preference the matches
  /// stalled there while the robot drove on (aces at 63-86 s: 0.25 m a relation lost); aces
  /// 0.0503 -> 0.0368 m, Intel 0.0190 -> 0.0158 m (RESULTS.md, "LiDAR IX").
  double translation_delta_cost_weight = 2;
  double rotation_delta_cost_weight = 1.0;
  /// What an unknown cell scores: 0.5, as in the scan-match factor (ScanMatchWeights).
  double unknown_probability = 0.5;
  bool IsValid(std::string* why) const;
};

struct CorrelativeMatch {
  SE2d pose;                    ///< the best candidate
  double score = 0;             ///< its weighted score
  double mean_probability = 0;  ///< its mean probability (unweighted)
  long candidates = 0;          ///< candidates scored
  double angular_step = 0;      ///< the rotation step used (rad)
};

/// Searches around `guess` (the scan's pose in the grid's frame) for the pose that best fits
/// `points` (the scan's points in its own frame). Throws InvalidArgument for invalid options,
/// no points, or points or a guess that are not finite.
CorrelativeMatch MatchCorrelative(const ProbabilityGrid& grid, const SE2d& guess,
                                  const std::vector<Eigen::Vector2d>& points,
                                  const CorrelativeMatcherOptions& options = {});

}  // namespace lidar
}  // namespace tether
