#pragma once
// Scan-to-scan matching: the motion between two consecutive scans by point-to-line ICP, the
// prediction of local SLAM where a log has no odometry (local_slam_2d.h).
//
// Matching a scan against a submap from a weak prediction (constant velocity) stalls: a
// submap's hits lie where its own scans' beams ended, so a new scan scores a little higher at
// the pose those scans were taken from than at its own, and with no odometry to say the robot
// moved, the match stays behind. Between two scans there is no such bias: each point of the
// new scan is paired with the line through its nearest point of the scan before and that
// point's neighbours in beam order (or the line fitted to the neighbours within
// normal_radius), and the motion minimises the robust point-to-line distances, with a weak
// pull towards the guess so that a corridor (where the motion along it is not seen) keeps the
// guess's motion along it.
//
// Near the robot the next points each way lie 1-3 cm apart, and a range noise of 1 cm tilts the
// line through them by tens of degrees: the pairs of a corridor's walls seem to see along it
// (aces without odometry: 12-27 of 150 pairs' worth, against 2-3 with lines fitted over 0.2 m).
// The pairs' normal equations (`information`) say what a match saw, and DegenerateTranslations
// what it did not; both mean something only with fitted lines (benchmarks/RESULTS.md,
// "LiDAR XI").
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/se2.h"

namespace tether {
namespace lidar {

struct ScanToScanOptions {
  int max_iterations = 30;
  /// Pairs farther apart than this are dropped (m): the first iterations, then the last ones.
  double max_pair_distance = 0.5;
  double final_pair_distance = 0.2;
  /// Neighbours in beam order farther apart than this do not make a line (m).
  double max_neighbour_gap = 0.3;
  /// A point's line: fitted to its neighbours in beam order within this distance (m); 0 (the
  /// default): the line through the next point each way. Without odometry, 0.2 against 0:
  /// aces 1.40 m against 1.66 m, the simulated office 0.011 m against 0.021 m, Intel 0.0160 m
  /// against 0.0161 m, fr079 0.0319 m both, but Intel with a low-cost scanner 0.0456 m against
  /// 0.0416 m (benchmarks/RESULTS.md, "LiDAR XI"); with odometry the match is not used.
  double normal_radius = 0;
  /// Huber on the point-to-line distance (m).
  double huber = 0.03;
  /// The pull towards the guess: weights (1/m, 1/rad) on the motion's difference from it,
  /// against a weight of 1 per pair on the distances (m).
  double guess_translation_weight = 0.5;
  double guess_rotation_weight = 0.5;
  /// Degeneracy (pairs): a direction of translation whose information from the pairs (the
  /// rotation marginalised; each pair adds at most its normal's square) is below this keeps
  /// the guess's motion exactly (a stiff pull along it), and local SLAM keeps the prediction's
  /// translation along it in the submap match too. 0: off (the default); it needs fitted lines
  /// (normal_radius), or the noise hides every degenerate direction. In a simulated
  /// featureless corridor 5 holds a scan-only run to 0.24 m over 14 m where without it local
  /// SLAM stalls (14 m behind); on aces it also carries the pose on where the robot stops in a
  /// corridor, and the short relations get worse (benchmarks/RESULTS.md, "LiDAR XI").
  double degenerate_information = 0;
  /// Fewer pairs than this: no match.
  int min_pairs = 20;
  bool IsValid(std::string* why) const;
};

struct ScanToScanMatch {
  bool ok = false;
  SE2d motion;    ///< the current scan's pose in the previous scan's frame
  int pairs = 0;  ///< pairs in the last iteration
  int iterations = 0;
  double rms = 0;  ///< root mean square point-to-line distance of the pairs (m)
  /// The pairs' normal equations at the last iteration (x, y, theta of the motion; without the
  /// pull towards the guess).
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  /// The projector onto the translations the pairs did not see (the previous scan's frame;
  /// zero where every direction was seen), which kept the guess's motion.
  Eigen::Matrix2d degenerate = Eigen::Matrix2d::Zero();
};

/// The projector onto the directions of translation whose information (the rotation
/// marginalised out of `information`, normal equations in x, y, theta) is below
/// min_information: zero, one direction (v v^T) or both (the identity).
Eigen::Matrix2d DegenerateTranslations(const Eigen::Matrix3d& information, double min_information);

/// The motion from `previous` to `current` (each a scan's points in its robot frame, in beam
/// order), starting at `guess`. Not ok where fewer than min_pairs pairs were found. Throws
/// InvalidArgument for invalid options.
ScanToScanMatch MatchScanToScan(const std::vector<Eigen::Vector2d>& previous,
                                const std::vector<Eigen::Vector2d>& current, const SE2d& guess,
                                const ScanToScanOptions& options = {});

/// The motion of a robot without odometry from the scan before: matched from `moving` (the
/// constant-motion guess) and from standing still (turned by `turn`, an IMU's, else 0); the
/// still match is taken only where it pairs clearly more points (10%): along a corridor both
/// pair alike and the scans cannot tell, and taking no motion there stalled local SLAM while
/// the robot drove on (aces 62-80 s, benchmarks/RESULTS.md "LiDAR X"). Not ok where neither
/// matched.
ScanToScanMatch MatchMovingOrStill(const std::vector<Eigen::Vector2d>& previous,
                                   const std::vector<Eigen::Vector2d>& current, const SE2d& moving, double turn,
                                   const ScanToScanOptions& options = {});

}  // namespace lidar
}  // namespace tether
