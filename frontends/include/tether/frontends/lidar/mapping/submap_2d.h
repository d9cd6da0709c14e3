#pragma once
// Submaps: probability grids that each hold a fixed number of consecutive scans.
//
// Two submaps are active at a time and overlap: every scan goes into both; a new submap starts
// when the newer one holds half its scans, and the older one is finished (frozen: no further
// insertion, an error if tried) when it holds all of them. So the submap scans are matched
// against (the older active one) always holds at least half a submap's scans once the first
// half is in, and every finished submap is complete for loop closure.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"

namespace tether {
namespace lidar {

struct SubmapOptions {
  double resolution = 0.05;  ///< m per cell
  /// Scans in a finished submap (a new submap starts every max(1, N / 2) scans).
  int scans_per_submap = 90;
  /// A submap is also finished once the robot travelled this far (m) between its first and its
  /// last scan (a new one starts at half of it), whichever comes first; 0: scans only. Where
  /// scans come densely (the motion filter inserts one each 0.2 m or 1 degree) 90 scans span at
  /// most about 27 m and the cap never applies; where each scan moved a metre (a log recorded
  /// with a coarse motion filter, a slow scanner on a fast robot), 90 scans would span 90 m,
  /// and a loop inside one submap could neither be closed nor kept out of its grid.
  double max_submap_travel = 30;
  double min_probability = ProbabilityGrid::kDefaultMinProbability;  ///< clamp (0.12)
  double max_probability = ProbabilityGrid::kDefaultMaxProbability;  ///< clamp (0.97)
  GridInsertOptions insert;
  bool IsValid(std::string* why) const;
};

class Submap2D {
 public:
  /// A submap whose local pose (its origin in the local map frame) is `local_pose`; its grid
  /// is in the local map frame, with the lattice anchored at the pose's translation.
  Submap2D(const SE2d& local_pose, const SubmapOptions& options);

  const SE2d& local_pose() const { return local_pose_; }
  int num_scans() const { return num_scans_; }
  /// The distance the robot travelled between the submap's first and last scan (m).
  double travel() const { return travel_; }
  bool finished() const { return finished_; }
  /// The grid, for matching (shared with the factors that read it).
  std::shared_ptr<const ProbabilityGrid> grid() const { return grid_; }

  /// Inserts a scan (points and sensor origin in the local map frame). Throws
  /// InvalidArgument if the submap is finished.
  void InsertScan(const ProbabilityGridInserter& inserter, const Eigen::Vector2d& origin,
                  const std::vector<Eigen::Vector2d>& points, InsertedCells* cells = nullptr);
  /// A finished submap read back (a saved state, lidar_state.h): its local pose, its grid (in
  /// the local map frame) and the scans it held. Throws InvalidArgument for a null grid or a
  /// negative count.
  static std::shared_ptr<Submap2D> Restored(const SE2d& local_pose, std::shared_ptr<ProbabilityGrid> grid,
                                            int num_scans);
  /// Freezes the submap.
  void Finish() {
    finished_ = true;
    grid_->ShrinkToKnown();
  }

 private:
  SE2d local_pose_;
  std::shared_ptr<ProbabilityGrid> grid_;
  int num_scans_ = 0;
  double travel_ = 0;
  bool finished_ = false;
  friend class ActiveSubmaps2D;
};

/// Submaps a scan went into: each one's index in ActiveSubmaps2D::submaps() (the order of
/// creation) and the submap.
using InsertedSubmaps = std::vector<std::pair<int, std::shared_ptr<const Submap2D>>>;

class ActiveSubmaps2D {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit ActiveSubmaps2D(const SubmapOptions& options);

  /// Inserts a scan taken at `scan_pose` (points and sensor origin in the local map frame)
  /// into the active submaps, starting a submap at scan_pose where one is due and finishing
  /// the older one once it is full.
  /// Returns the submaps the scan went into.
  InsertedSubmaps InsertScan(const SE2d& scan_pose, const Eigen::Vector2d& origin,
                             const std::vector<Eigen::Vector2d>& points);

  /// Finishes the active submaps (a trajectory ends: they will take no more scans) and returns
  /// them as InsertScan does; the next scan starts a new submap.
  InsertedSubmaps FinishActive();
  /// The submap to match the next scan against: the older active one (null before any scan).
  std::shared_ptr<const Submap2D> matching_submap() const;
  /// The active submaps, older first (at most two).
  const std::vector<std::shared_ptr<Submap2D>>& active() const { return active_; }
  /// Every submap made so far, in order of creation (finished ones and active ones), less the
  /// ones KeepNewest dropped: submaps()[k] has index dropped() + k.
  const std::vector<std::shared_ptr<Submap2D>>& submaps() const { return submaps_; }
  /// Drops all but the newest `n` submaps (n >= 1; the active ones are always kept), so that a
  /// run that never ends holds a bounded map (localisation). Indices go on counting.
  void KeepNewest(int n);
  int dropped() const { return dropped_; }
  const SubmapOptions& options() const { return options_; }

 private:
  SubmapOptions options_;
  ProbabilityGridInserter inserter_;
  std::vector<std::shared_ptr<Submap2D>> active_;
  std::vector<std::shared_ptr<Submap2D>> submaps_;
  int dropped_ = 0;        // submaps KeepNewest dropped
  bool start_new_ = true;  // the next scan starts a submap
  bool any_scan_ = false;
  Eigen::Vector2d last_position_ = Eigen::Vector2d::Zero();  // the last inserted scan's
};

}  // namespace lidar
}  // namespace tether
