#pragma once
// A LiDAR run's self-check: does each part of the trajectory fit the map the other parts made?
//
// Loop closures that agree with the final solution say only that the solution kept them; a
// stretch of the trajectory pulled onto the wrong place by a wrong closure (or never pulled
// back by a missed one) agrees with itself. So the check compares each sampled scan, at its
// final pose, with reference grids built from the scans taken at other times: the scans cut
// into parts of `part_scans` consecutive scans, each part inserted into its own coarse grid
// at the final poses, and a scan compared only with the parts at least `min_separation_scans`
// scans away (its own stretch would agree with it however wrong the stretch is). A point of
// the scan is judged where such a part knows its cell, and fits where one of them has an
// occupied cell within one cell of it; a scan is judged where at least `min_points` of its
// points are, and fits where at least `fit_fraction` of them fit. A place visited once is
// not judged. Runs of consecutive misfit samples are reported as misplaced stretches.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/se2.h"

namespace tether {
namespace lidar {

struct SelfCheckOptions {
  int sample_every = 10;           ///< check every N-th scan (0: no check)
  double resolution = 0.1;         ///< the reference grids' cells (m)
  double max_range = 10;           ///< points farther from the laser are left out (m; 0: none)
  int part_scans = 100;            ///< consecutive scans per reference grid
  int min_separation_scans = 300;  ///< a part is a reference for scans at least this far from all of its own
  int min_points = 30;             ///< points a scan needs judged to be judged
  double fit_fraction = 0.7;       ///< share of judged points that must fit
  int min_stretch = 3;             ///< consecutive judged misfit samples that make a stretch
  bool IsValid(std::string* why) const;
};

struct ScanFit {
  long scan = 0;
  int judged = 0;   ///< points on cells a reference knows
  int fitting = 0;  ///< of those, next to an occupied cell
  bool fits = false;
};

struct MisfitStretch {
  long first_scan = 0, last_scan = 0;  ///< the first and last misfit sample
  int samples = 0;
};

struct SelfCheckResult {
  long sampled = 0;             ///< scans sampled
  std::vector<ScanFit> judged;  ///< the sampled scans that could be judged, in scan order
  long fitting = 0;             ///< judged scans that fit
  std::vector<MisfitStretch> stretches;
  /// fitting / judged (1 where none was judged).
  double FitShare() const;
};

/// Checks scans at `laser_poses` (the laser's pose of each scan, final) with their points
/// (`points[i]`, the laser's frame). Throws InvalidArgument for invalid options or sizes that
/// differ.
SelfCheckResult CheckSelfConsistency(const std::vector<SE2d>& laser_poses,
                                     const std::vector<const std::vector<Eigen::Vector2d>*>& points,
                                     const SelfCheckOptions& options = {});

}  // namespace lidar
}  // namespace tether
