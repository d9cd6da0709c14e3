#pragma once
// Scan-to-scan matching: the motion between two consecutive scans by point-to-line ICP, the
// prediction of local SLAM where a log has no odometry (local_slam_2d.h).
//
// Matching a scan against a submap from a weak prediction (constant velocity) stalls: a
// submap's hits lie where its own scans' beams ended, so a new scan scores a little higher at
// the pose those scans were taken from than at its own, and with no odometry to say the robot
// moved, the match stays behind. Between two scans there is no such bias: each point of the
// new scan is paired with the line through its nearest point of the scan before and that
// point's neighbours in beam order, and the motion minimises the robust point-to-line
// distances, with a weak pull towards the guess so that a corridor (where the motion along
// it is not seen) keeps the guess's motion along it.
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
  /// Huber on the point-to-line distance (m).
  double huber = 0.03;
  /// The pull towards the guess: weights (1/m, 1/rad) on the motion's difference from it,
  /// against a weight of 1 per pair on the distances (m).
  double guess_translation_weight = 0.5;
  double guess_rotation_weight = 0.5;
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
};

/// The motion from `previous` to `current` (each a scan's points in its robot frame, in beam
/// order), starting at `guess`. Not ok where fewer than min_pairs pairs were found. Throws
/// InvalidArgument for invalid options.
ScanToScanMatch MatchScanToScan(const std::vector<Eigen::Vector2d>& previous,
                                const std::vector<Eigen::Vector2d>& current, const SE2d& guess,
                                const ScanToScanOptions& options = {});

}  // namespace lidar
}  // namespace tether
