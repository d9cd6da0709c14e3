#pragma once
// Which loop closures the LiDAR pose graph adds (Hess et al. 2016, section V): scans searched
// against finished submaps, the search, and the second opinion a match needs.
//
// - A scan against a finished submap it is not in, searched by branch and bound
//   (fast_correlative_scan_matcher_2d.h) in the window around the pose the graph estimates,
//   refined by the scan-match factor (scan_refiner_2d.h). Searched: every
//   search_every_n_scans-th scan against the finished submaps within max_search_distance of it
//   (SearchScan), and every earlier such scan against a submap when it is finished
//   (FinishSubmap).
// - The window (and the search distance) widens with the graph distance between the scan and
//   the submap (search_window_growth): a place reached again only after a long loop is
//   searched wider. The graph: submaps that share a scan (AddScan) or a loop closure.
// - A match becomes a loop closure once a second match of another scan to the same submap
//   agrees with it (confirm_*).
// - Searches run on `threads` background threads. TakeClosures waits for every search started
//   and reads their results in the order the searches were started: the closures do not depend
//   on the number of threads or their timing.
// - Trajectories (a kidnap, LidarSlam2D): StartTrajectory() begins a new one, whose scans and
//   submaps have no link to the others. Trajectory 0 is joined (the map everything is placed
//   in); another becomes joined with its first confirmed closure to a joined submap. Until
//   then, its sampled scans are searched globally against every finished joined submap: the
//   window covers the submap's whole known area at every rotation (global_search_*), since
//   where it lies relative to them is not known; those scans are searched so again against
//   every joined submap finished later, as long as their trajectory is not joined (a trajectory
//   that ended before it joined can still join). Scans of a joined trajectory are not searched
//   against unjoined submaps, nor unjoined trajectories against each other.
// The builder reads the graph's current estimates (GraphEstimates) where it places a search;
// the graph (pose_graph_2d.h) adds the closures it takes as constraints.
#include <Eigen/Core>
#include <algorithm>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"

namespace tether {
namespace lidar {

/// Branch and bound's window for loop closures: 12 m x 12 m x 30 degrees (FastMatcherOptions
/// has 7 m x 7 m). On fr079 the corridor after the door sits 4 m off the first pass, beyond a
/// 3.5 m half window: 5 m brings fr079 from 0.303 m to 0.087 m, Intel and aces unchanged
/// within the run-to-run spread, at 30% more time (benchmarks/RESULTS.md, "LiDAR V").
/// Cartographer searches +-7 m and +-30 degrees. 6 m against 5 m (benchmarks/RESULTS.md, "LiDAR
/// IX"): on fr079 local SLAM follows the odometry forward at 303-308 s where the robot backs
/// out of a door, 4-5 m off, and with 5 m whether a closure then reaches across depended on
/// the smallest change (3 of 5 correlative weights from 0.5 to 2.5 left the first 250 s 4-9 m
/// off the rest); with 6 m all three tried close it, at 15% more search time.
inline FastMatcherOptions PoseGraphSearchOptions() {
  FastMatcherOptions o;
  o.linear_search_window = 6;
  return o;
}

/// The machine's cores (std::thread::hardware_concurrency; 1 where it cannot tell).
inline int DefaultSearchThreads() { return std::max(1, static_cast<int>(std::thread::hardware_concurrency())); }

/// What the loop-closure search does (PoseGraphOptions holds these too).
struct ConstraintBuilderOptions {
  FastMatcherOptions search = PoseGraphSearchOptions();  ///< the window: 12 m x 12 m x 30 degrees
  double min_score = 0.55;                               ///< a search's best must score above this (mean probability)
  /// A match whose best candidate lies on the search window's edge is dropped (the score may
  /// rise beyond it). A match is ambiguous, and dropped, where another candidate of its window
  /// at least rival_distance (m) away or rival_angle (rad) turned scores above rival_ratio
  /// times its score (a corridor that matches anywhere along it). rival_ratio 0 keeps
  /// ambiguous matches.
  double rival_ratio = 0.9;
  double rival_distance = 0.3;
  double rival_angle = 0.035;
  /// m, from the scan to the submap's origin (estimates). 8 m against 15 m on the benchmark
  /// logs (benchmarks/RESULTS.md, "LiDAR IV"): half the searches on Intel and aces, the same
  /// precision (94.0% and 98.7% against 94.0% and 97.9%), 0.0444 m against 0.0431 m on Intel.
  double max_search_distance = 8;
  /// The window widens with how far apart the scan and the submap are in the graph, as the
  /// drift between them can grow: its half side (and the search distance above) grows by
  /// search_window_growth metres per metre of graph distance, up to max_search_window. Graph
  /// distance: the shortest path from a submap that holds the scan to the searched submap,
  /// through submaps that share a scan or are joined by a loop closure, each step the
  /// distance between their origins (estimates). A revisit after a long loop that no closure
  /// shortened is searched wide; a place revisited often stays at search's window.
  /// aces returns to its start after 175 m with 7 m of drift, beyond the 5 m half window
  /// (benchmarks/RESULTS.md, "LiDAR VI"). 0: a fixed window.
  /// Up to 20 m, and the rotations below growing too, against up to 10 m at a fixed 15 degrees
  /// (benchmarks/RESULTS.md, "LiDAR X"): mit-killian, whose loops run hundreds of metres, from
  /// 91.3% of its closures kept and 13 stretches the self-check found misplaced (its long
  /// corridors crossing where they should meet) to 93.1% and none; Intel, aces and fr079 the
  /// same relation errors (0.0158, 0.0368, 0.0416 m) in about the same time. Growing 0.05 m
  /// per m (and 0.003 rad) closed mit-killian as well but cost fr079 44% more time.
  double search_window_growth = 0.02;
  double max_search_window = 20;  ///< m, half side (never below search.linear_search_window)
  /// The window's rotations widen the same way: search_angle_growth radians per metre of graph
  /// distance, up to max_search_angle (0: fixed at search.angular_search_window).
  double search_angle_growth = 0.0015;          ///< rad per m (15 degrees more at 175 m)
  double max_search_angle = 0.523598775598299;  ///< rad (30 degrees)
  /// Branch and bound scores a scan's points thinned by a voxel filter of this edge (m; 0: the
  /// points as given); the refinement after it uses them all. 0.2 m against the 5 cm matching
  /// points: a search about half as costly with the same maps within the run-to-run spread
  /// (benchmarks/RESULTS.md, "LiDAR VI"). It was 0.1 m while a best pushed to within the rival
  /// distance of the window's edge still counted as a match: on 0.2 m voxels the synthetic
  /// corridor then kept closures 5 m off the truth ("LiDAR V").
  double search_voxel_size = 0.2;
  /// Every 10th scan, as in every figure of benchmarks/RESULTS.md (every 3rd would search about
  /// three times as often, for closures a few scans from those found).
  int search_every_n_scans = 10;
  /// A scan is also searched where the robot travelled this far (m, by local SLAM) since the
  /// last searched scan, before search_every_n_scans more scans came (0: by count only). On the
  /// benchmark logs 10 scans cover 0.4-1.1 m and 3 m is never reached, so they search as before
  /// (the same files); a log recorded only where the robot moved a metre is searched every third
  /// scan instead of every tenth. 2 m put one of fr079's relations above 1 m on the low-cost
  /// scanner (every other scan: 10 scans cover 2 m), 3 m none (benchmarks/RESULTS.md, "LiDAR
  /// XIII").
  double search_every_metres = 3;
  ScanRefinerOptions refine;
  /// A match becomes a loop closure only once a second one confirms it: a match of another
  /// scan to the same submap, at most confirm_max_scans scans away, that local SLAM moved at
  /// least confirm_min_translation (m) or turned confirm_min_rotation (rad) from it (the same
  /// view again is no second opinion), such that the relative pose of the two scans the two
  /// matches imply lies within confirm_translation (m) and confirm_rotation (rad) of local
  /// SLAM's. Both are added then; a match no other confirms is never added. A false match in
  /// a building of look-alike rooms and corridors seldom has a partner that agrees with it.
  /// confirm_translation 0: every match is added as found.
  double confirm_translation = 0.2;
  double confirm_rotation = 0.0175;
  int confirm_max_scans = 200;
  double confirm_min_translation = 0.1;
  double confirm_min_rotation = 0.05;
  /// A scan of a trajectory not yet joined is searched against every finished joined submap
  /// (every rotation, the whole submap) where it is sampled and at least
  /// global_search_every_n_scans scans came since the last scan searched so; its best must
  /// score above global_min_score (a look-alike room elsewhere scores well too).
  /// The window: the submap's origin +- (the farthest its own scans were taken from it +
  /// global_search_margin), at every rotation, in steps of global_angular_step (rad; coarser
  /// than a windowed search's: 0.5 degrees moves a point 20 m away by 17 cm, and the
  /// refinement after it corrects that; the rule of the windowed search would take thousands of
  /// rotations for a scanner reaching 80 m).
  int global_search_every_n_scans = 30;
  double global_min_score = 0.6;
  double global_search_margin = 2;  ///< m
  /// A scan whose global matches (in one batch) put it in places of the map further apart than
  /// this (m, rad) is ambiguous: none of them is taken (look-alike rooms).
  double global_rival_distance = 1;
  double global_rival_angle = 0.1;
  /// A trajectory not yet joined joins once confirmed closures to two joined submaps whose
  /// origins lie at least this far apart (m) place it alike: one room confirms a match to a
  /// room like it; the corridor outside it does not. Alike: the motion between their two scans
  /// that the closures imply is local SLAM's within global_rival_* plus the drift local SLAM
  /// may have gathered between them, join_drift (m per m driven) and join_drift_angle (rad per
  /// m driven): the trajectory is not optimised before it joins. Local SLAM's drift against
  /// the optimised runs (95th percentile over stretches of 20-150 m): 1.1-1.6% and 0.04-0.11
  /// rad on intel and aces, up to 20% on fr079 at its odometry's fault (benchmarks/RESULTS.md).
  double join_min_separation = 5;
  double join_drift = 0.02;
  double join_drift_angle = 0.0005;
  double global_angular_step = 0.00872664625997165;  ///< rad (0.5 degrees)
  /// Background search threads (0: search in the caller's thread); by default the machine's
  /// cores. The result does not depend on it.
  int threads = DefaultSearchThreads();
  bool IsValid(std::string* why) const;
};

struct LoopClosure {
  int scan = 0;
  int submap = 0;
  SE2d relative;  ///< the scan in the submap's frame
  double score = 0;
};

struct ConstraintBuilderStats {
  long searches = 0;
  long found = 0;             ///< searches above min_score, neither ambiguous nor on the edge
  long ambiguous = 0;         ///< searches above min_score dropped as ambiguous (rival_ratio)
  long on_edge = 0;           ///< searches above min_score dropped: the best on the window's edge
  long unconfirmed = 0;       ///< found matches no other has confirmed (not added, so far)
  double search_seconds = 0;  ///< summed over the searches (all threads)
  double found_seconds = 0;   ///< summed over the searches that found one
  long global_searches = 0;   ///< of the searches, global ones (a trajectory not yet joined)
  double global_seconds = 0;  ///< summed over them
  double wait_seconds = 0;    ///< TakeClosures waiting for searches
};

/// The graph's current estimates (its global frame) of scan i and submap j, read on the
/// caller's thread where a search is placed.
struct GraphEstimates {
  std::function<SE2d(int)> scan;
  std::function<SE2d(int)> submap;
};

class ConstraintBuilder2D {
 public:
  /// Throws InvalidArgument for invalid options or a missing estimate function.
  ConstraintBuilder2D(const ConstraintBuilderOptions& options, GraphEstimates estimates);
  /// Waits for every search started to end.
  ~ConstraintBuilder2D();
  ConstraintBuilder2D(const ConstraintBuilder2D&) = delete;
  ConstraintBuilder2D& operator=(const ConstraintBuilder2D&) = delete;

  /// The next submap (index = submaps so far), as local SLAM builds it. Throws InvalidArgument
  /// for a null one.
  void AddSubmap(std::shared_ptr<const Submap2D> submap);
  /// The next scan (index = scans so far): its pose in local SLAM's frame, its points (the
  /// robot's frame) and the submaps it is tied to, which are joined to each other in the graph.
  /// Throws InvalidArgument for a submap not added.
  void AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points, const std::vector<int>& submaps);
  /// The scans and submaps added from now on belong to a new trajectory (not joined), whose
  /// local poses are in a frame of their own.
  void StartTrajectory();
  /// Submap j is finished: searches every sampled scan so far that it does not hold against
  /// it, where they lie near enough. Throws InvalidArgument where j was not added or its
  /// submap is not finished; nothing where j is already marked finished.
  void FinishSubmap(int j);
  /// Marks submap j finished without searching anything against it (a submap of a saved map,
  /// whose closures were found when it was made): later scans are searched against it as against
  /// any finished submap. Throws as FinishSubmap.
  void RestoreFinishedSubmap(int j);
  /// Scan i, if sampled (every search_every_n_scans-th since the last sampled one, or sooner
  /// after search_every_metres of travel), against every finished submap near it that does
  /// not hold it. Throws InvalidArgument for a scan not added.
  void SearchScan(int i);
  /// Waits for every search started so far and returns, in the order the searches were
  /// started, the matches that became loop closures with them (a match found now, or an earlier
  /// one a match found now confirms). Their submaps are joined in the graph.
  std::vector<LoopClosure> TakeClosures();

  int scan_count() const { return static_cast<int>(scans_.size()); }
  int submap_count() const { return static_cast<int>(submaps_.size()); }
  int trajectory_count() const { return static_cast<int>(joined_.size()); }
  int scan_trajectory(int i) const { return scans_.at(static_cast<std::size_t>(i)).trajectory; }
  int submap_trajectory(int j) const { return submaps_.at(static_cast<std::size_t>(j)).trajectory; }
  /// The submaps scan i was added with.
  const std::vector<int>& scan_submaps(int i) const { return scans_.at(static_cast<std::size_t>(i)).submaps; }
  /// Whether trajectory t is joined (trajectory 0, or joined by a closure TakeClosures gave).
  bool joined(int t) const { return joined_.at(static_cast<std::size_t>(t)); }
  bool finished(int j) const { return submaps_[static_cast<std::size_t>(j)].finished; }
  /// Whether scan i is sampled for the search (search_every_n_scans, search_every_metres).
  bool sampled(int i) const { return scans_.at(static_cast<std::size_t>(i)).sampled; }
  const ConstraintBuilderStats& stats() const { return stats_; }
  const ConstraintBuilderOptions& options() const { return options_; }

 private:
  struct ScanNode {
    SE2d local_pose;
    std::vector<Eigen::Vector2d> points;
    std::vector<Eigen::Vector2d> search_points;  ///< points through search_voxel_size (empty: points)
    std::vector<int> submaps;
    bool sampled = false;  ///< searched against the finished submaps near it
    bool global = false;   ///< searched globally (its trajectory not joined then)
    int trajectory = 0;
  };
  // A finished submap's matcher, built by the first search that needs it (on a search
  // thread, where there are any: the precomputation grids take a while on a large submap).
  struct LazyMatcher {
    std::once_flag once;
    std::unique_ptr<FastCorrelativeScanMatcher2D> matcher;
  };
  struct SubmapNode {
    std::shared_ptr<const Submap2D> submap;
    std::unique_ptr<LazyMatcher> matcher;  // made when finished
    bool finished = false;
    int trajectory = 0;
    double reach = 0;  ///< the farthest its own scans lie from its origin (m)
  };
  struct Search {
    int scan = 0, submap = 0;
    SE2d guess;  // the scan in the submap's grid frame
    // What the search reads (stable while it runs: finished submaps, scans in a deque).
    LazyMatcher* matcher = nullptr;
    std::shared_ptr<const ProbabilityGrid> grid;
    SE2d submap_local;
    const std::vector<Eigen::Vector2d>* points = nullptr;
    const std::vector<Eigen::Vector2d>* search_points = nullptr;
    double window = 0;  // half side of the translations searched (m)
    double angle = -1;  // half the rotations searched (rad)
    bool global = false;
    double step = -1;  // the rotation step (negative: the matcher's)
    bool done = false, found = false, ambiguous = false, on_edge = false;
    LoopClosure result;
    double seconds = 0;
  };
  // A match found, and whether it became a loop closure (confirmed).
  struct Candidate {
    LoopClosure closure;
    bool added = false;
  };

  /// Drops the global matches of a scan that disagree with each other (global_rival_*).
  void DropGlobalRivals(std::deque<std::unique_ptr<Search>>* done) const;
  /// Whether two matches to the same submap confirm each other (confirm_* options).
  bool Agree(const LoopClosure& a, const LoopClosure& b) const;
  /// Makes candidate c a loop closure (into `out`) and joins its submaps; one that would join
  /// a trajectory waits in HoldJoin.
  void Confirm(int c, std::vector<LoopClosure>* out);
  /// Closures a and b of one trajectory not yet joined place it alike (join_drift).
  bool PlaceAlike(const LoopClosure& a, const LoopClosure& b) const;
  /// Holds a confirmed closure of trajectory t (not joined) to a joined submap until another,
  /// to a submap join_min_separation away, places t alike; then gives every held closure that
  /// agrees (into `out`) and marks t joined.
  void HoldJoin(int t, const LoopClosure& l, std::vector<LoopClosure>* out);
  /// global_guess: a global search from that guess (the submap's grid frame), else a windowed
  /// one around the estimates.
  void StartSearch(int scan, int submap, double window, double angle, const SE2d* global_guess = nullptr);
  /// Whether scan k is searched against submap j around the estimates: the same trajectory,
  /// or both joined.
  bool Windowed(int k, int j) const;
  /// Scan k against the whole of submap j at every rotation.
  void StartGlobalSearch(int k, int j);
  /// Scan k against submap j where they lie near enough for the window of their graph distance.
  void SearchNear(int k, int j, double distance);
  void Link(int a, int b);
  /// Graph distances from the given submaps to every submap (infinity where no path).
  std::vector<double> GraphDistances(const std::vector<int>& from) const;
  /// The search window's half side for a scan whose submaps lie `distance` from the submap.
  double Window(double distance) const;
  /// The search's half range of rotations for the same.
  double Angle(double distance) const;
  void RunSearch(Search* s) const;
  void Worker();

  ConstraintBuilderOptions options_;
  GraphEstimates estimates_;
  std::deque<ScanNode> scans_;  // a deque: searches hold pointers to the points
  std::deque<SubmapNode> submaps_;
  std::vector<std::vector<int>> links_;  ///< per submap: submaps sharing a scan or a loop closure
  std::vector<Candidate> candidates_;    // every match found, in search order
  std::unordered_map<int, std::vector<int>> candidates_of_submap_;
  long confirmed_ = 0;  // candidates that became loop closures
  ConstraintBuilderStats stats_;
  int last_sampled_ = 0;                                          ///< the last scan sampled for the search
  double travel_since_sampled_ = 0;                               ///< m, by local SLAM since then
  std::vector<bool> joined_{true};                                ///< per trajectory
  std::unordered_map<int, std::vector<LoopClosure>> held_joins_;  ///< per trajectory not joined
  bool trajectory_started_ = true;                                ///< the next scan is its trajectory's first
  int last_global_ = -1;                                          ///< the last scan searched globally

  // Searches in the order started; the workers take them from `queue_`.
  std::deque<std::unique_ptr<Search>> searches_;
  std::deque<Search*> queue_;
  std::mutex mutex_;
  std::condition_variable work_, finished_;
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace lidar
}  // namespace tether
