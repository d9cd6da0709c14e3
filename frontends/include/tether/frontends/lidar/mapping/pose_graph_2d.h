#pragma once
// The LiDAR front-end's pose graph (Hess et al. 2016, section V): a node per scan and per
// submap, fed to tether's incremental smoother while the scans stream in.
//
// - Local constraints: each scan to every submap it was inserted into, the relative pose local
//   SLAM gave it (submap local pose^-1 * scan local pose), BetweenSE2 with local_*_sigma.
// - Loop closures: a scan against a finished submap it is not in, searched by branch and bound
//   (fast_correlative_scan_matcher_2d.h) in the window around the pose the graph estimates,
//   refined by the scan-match factor (scan_refiner_2d.h), and added as a BetweenSE2 with a Huber
//   loss (loop_*_sigma, huber_delta) marked as a loop closure. Searched: every
//   search_every_n_scans-th scan against the finished submaps within max_search_distance of it,
//   and every earlier such scan against a submap when it is finished. The window (and the
//   search distance) widens with the graph distance between the scan and the submap
//   (search_window_growth): a place reached again only after a long loop is searched wider.
//   A match is added once a second match of another scan to the same submap agrees with it
//   (confirm_*).
// - The smoother gets the new nodes and factors every update_every_n_scans scans; in between,
//   ScanPose gives a new scan's estimate as the last one's composed with local SLAM's motion.
// - Searches run on `threads` background threads. Their results are applied in the order the
//   searches were started, at fixed scan counts (every apply_every_n_scans scans, waiting for
//   every search started before that scan, and in that scan's smoother update) and at
//   Finish(): the result does not depend on the number of threads or their timing.
// Keys: scan i is Symbol('s', i), submap j Symbol('m', j); a prior holds the first scan.
#include <Eigen/Core>
#include <algorithm>
#include <condition_variable>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "tether/core/key.h"
#include "tether/core/se2.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {
namespace lidar {

inline Key ScanKey(int i) { return Symbol('s', static_cast<std::uint64_t>(i)); }
inline Key SubmapKey(int j) { return Symbol('m', static_cast<std::uint64_t>(j)); }

/// The smoother settings of the pose graph. Its estimate between loop closures only places the
/// search windows, and Finish() solves to the batch optimum all the same, so it re-linearises
/// less than the smoother's defaults (a step beyond 0.05, no sigma rule, no extra rounds for
/// many small steps) and stops back substitution below 1e-6: the optimisation takes half the
/// time (Intel 19.9 s against 40 s) with the same maps within the run-to-run spread; iSAM2's
/// 0.1 and 1e-3 cut it to 11.8 s but moved fr079's closures enough to give 0.72 m against
/// 0.28 m (benchmarks/RESULTS.md, "LiDAR V").
inline SmootherOptions PoseGraphSmootherOptions() {
  SmootherOptions o;
  o.relinearize_threshold = 0.05;
  o.relinearize_sigmas = std::numeric_limits<double>::infinity();
  o.iterate_share = 1;
  o.wildfire_threshold = 1e-6;
  return o;
}

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

struct PoseGraphOptions {
  /// The local constraints' sigmas: looser than the loop closures', as measured on Intel
  /// (benchmarks/RESULTS.md, "LiDAR IV": 0.05 m / 0.02 rad gave 90.7% precision and 0.050 m,
  /// 0.1 m / 0.04 rad 94.0% and 0.043 m, 0.02 m / 0.01 rad 70.9% and 0.088 m).
  double local_translation_sigma = 0.1;  ///< m
  double local_rotation_sigma = 0.04;    ///< rad
  /// Consecutive scans are also tied to each other by local SLAM's relative pose between
  /// them, with these sigmas (both 0: no such constraint). Local SLAM's relative pose between
  /// neighbouring scans is far better than 0.1 m: tied, the loop closures cannot pull single
  /// scans out of line. 0.01 m / 0.002 rad against none, quadratic ties, every 10th scan searched
  /// (benchmarks/RESULTS.md, "LiDAR VII"): Intel 0.0355 -> 0.0282 m and 0.337 -> 0.289 deg,
  /// aces 0.0738 -> 0.0711 m and 0.490 -> 0.414 deg, fr079 0.0915 -> 0.0889 m and 0.869 ->
  /// 0.823 deg; the stiffer solution keeps fewer loop closures within 20 cm and 1 deg (89.4%,
  /// 50.0%, 84.5% against 91.8%, 63.0%, 86.9%).
  double consecutive_translation_sigma = 0.01;  ///< m
  double consecutive_rotation_sigma = 0.002;    ///< rad
  bool loop_closure = true;
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
  /// benchmark logs 10 scans cover 0.4-1.1 m and 2 m is rarely reached, so they search as
  /// before; a log thinned to every other scan, or recorded only where the robot moved a metre,
  /// is searched as densely in space as they are instead of every 10-20 m.
  double search_every_metres = 2;
  ScanRefinerOptions refine;
  double loop_translation_sigma = 0.05;  ///< m
  double loop_rotation_sigma = 0.02;     ///< rad
  double huber_delta = 1;                ///< on the whitened error's norm
  /// A Huber loss (this delta on the whitened error) on the local and consecutive ties too
  /// (0: none, quadratic): where local SLAM slipped, the closures that say so can pull the
  /// ties across the slip apart instead of losing against them. Every 10th scan searched
  /// (benchmarks/RESULTS.md, "LiDAR VII"), 0.25 against quadratic ties: Intel 0.0282 ->
  /// 0.0187 m, aces 0.0711 -> 0.0510 m, fr079 0.0889 -> 0.0341 m, precision 89.4 -> 95.5%,
  /// 50.0 -> 87.8%, 84.5 -> 98.9%. 0.1 tears Intel and aces (relation errors up to 5 m); without
  /// the consecutive ties 0.25 tears aces.
  double local_huber_delta = 0.25;
  int apply_every_n_scans = 30;
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
  /// The scans' nodes and ties reach the smoother together, every update_every_n_scans scans
  /// (at the scans whose index it divides, before their searches start), and with the loop
  /// closures applied at that scan; in between, a new scan's estimate is the last one's
  /// composed with local SLAM's motion. Every update re-solves the part of the graph the change
  /// touches, and that part holds the submaps' large separators. 10 against 1 (every 10th scan
  /// searched, benchmarks/RESULTS.md "LiDAR VIII"): Intel's optimisation 39.6 -> 20.5 s, the
  /// relation errors within the run-to-run spread (Intel 0.0187 -> 0.0185 m, aces 0.0510 ->
  /// 0.0506 m, fr079 0.0341 m both).
  int update_every_n_scans = 10;
  /// Background search threads (0: search in AddScan's thread); by default the machine's
  /// cores. The result does not depend on it.
  int threads = DefaultSearchThreads();
  SmootherOptions smoother = PoseGraphSmootherOptions();
  bool IsValid(std::string* why) const;
};

struct LoopClosure {
  int scan = 0;
  int submap = 0;
  SE2d relative;  ///< the scan in the submap's frame
  double score = 0;
};

struct PoseGraphStats {
  long searches = 0;
  long found = 0;               ///< searches above min_score, neither ambiguous nor on the edge
  long ambiguous = 0;           ///< searches above min_score dropped as ambiguous (rival_ratio)
  long on_edge = 0;             ///< searches above min_score dropped: the best on the window's edge
  long unconfirmed = 0;         ///< found matches no other has confirmed (not added, so far)
  double search_seconds = 0;    ///< summed over the searches (all threads)
  double found_seconds = 0;     ///< summed over the searches that found one
  double optimize_seconds = 0;  ///< the smoother's updates and Finish
  long updates = 0;             ///< smoother updates (before Finish)
  double finish_seconds = 0;    ///< Finish's solve
  double wait_seconds = 0;      ///< AddScan and Finish waiting for searches
};

class PoseGraph2D {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit PoseGraph2D(const PoseGraphOptions& options = {});
  ~PoseGraph2D();
  PoseGraph2D(const PoseGraph2D&) = delete;
  PoseGraph2D& operator=(const PoseGraph2D&) = delete;

  /// The next scan (index = scans so far): its pose from local SLAM, its points (the robot's
  /// frame) and the submaps it was inserted into (index in the order of creation, and the
  /// submap, as ActiveSubmaps2D::InsertScan gives them). Submaps must come with increasing
  /// indices; a finished one stays finished. A scan in no submap (the motion filter left it
  /// out, or no points) is tied to the submaps the last scan with any went into, by the local
  /// poses (before any submap: to the previous scan). Throws InvalidArgument for a null submap
  /// or one that skips an index.
  void AddScan(const SE2d& local_pose, std::vector<Eigen::Vector2d> points, const InsertedSubmaps& inserted_into);
  /// Waits for every search, applies the results and solves the graph to convergence.
  void Finish();

  int scan_count() const { return static_cast<int>(scans_.size()); }
  /// Whether scan i was sampled for the loop-closure search (search_every_n_scans, search_every_metres).
  bool sampled(int i) const { return scans_.at(static_cast<std::size_t>(i)).sampled; }
  int submap_count() const { return static_cast<int>(submaps_.size()); }
  /// The current estimates (global frame: the first scan's local pose).
  SE2d ScanPose(int i) const;
  SE2d SubmapPose(int j) const;
  const std::vector<LoopClosure>& loop_closures() const { return closures_; }
  /// The graph and its estimate with plain ids, as g2o tools expect them: scan i is i, submap
  /// j is scan_count() + j (the loop closures keep their Huber loss and mark).
  void Export(FactorGraph* graph, Values* values) const;
  const PoseGraphStats& stats() const { return stats_; }
  const IncrementalSmoother& smoother() const { return smoother_; }

 private:
  struct ScanNode {
    SE2d local_pose;
    std::vector<Eigen::Vector2d> points;
    std::vector<Eigen::Vector2d> search_points;  ///< points through search_voxel_size (empty: points)
    std::vector<int> submaps;
    bool sampled = false;  ///< searched against the finished submaps near it
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
    bool done = false, found = false, ambiguous = false, on_edge = false;
    LoopClosure result;
    double seconds = 0;
  };

  // A match found, and whether it was added as a loop closure (confirmed).
  struct Candidate {
    LoopClosure closure;
    bool added = false;
  };
  /// Whether two matches to the same submap confirm each other (confirm_* options).
  bool Agree(const LoopClosure& a, const LoopClosure& b) const;
  /// Adds candidate c as a loop closure (to the factors waiting for the next update).
  void AddClosure(int c);
  /// A node's estimate: the smoother's, or its initial value while it waits for an update.
  SE2d Pose(Key k) const;
  /// Hands the waiting nodes and factors to the smoother.
  void Flush();
  void StartSearch(int scan, int submap, double window, double angle);
  /// Scan k against submap j where they lie near enough for the window of their graph distance.
  void SearchNear(int k, int j, double distance);
  /// Marks submap j finished and searches every sampled scan before `before` near it.
  void SearchNewlyFinished(int j, int before);
  void Link(int a, int b);
  /// Graph distances from the given submaps to every submap (infinity where no path).
  std::vector<double> GraphDistances(const std::vector<int>& from) const;
  /// The search window's half side for a scan whose submaps lie `distance` from the submap.
  double Window(double distance) const;
  /// The search's half range of rotations for the same.
  double Angle(double distance) const;
  void RunSearch(Search* s) const;
  /// Waits for every search started so far and adds the loop closures found to the waiting
  /// factors; true where it added any.
  bool ApplyFinishedSearches();
  void Worker();
  SE2d GlobalFromLocal() const;

  PoseGraphOptions options_;
  IncrementalSmoother smoother_;
  FactorGraph pending_graph_;  // waiting for the next update
  Values pending_values_;
  std::deque<ScanNode> scans_;  // a deque: searches hold pointers to the points
  std::deque<SubmapNode> submaps_;
  std::vector<LoopClosure> closures_;
  std::vector<Candidate> candidates_;  // every match found, in search order
  std::unordered_map<int, std::vector<int>> candidates_of_submap_;
  std::vector<int> active_;              ///< the submaps the last scan given any went into
  int last_sampled_ = 0;                 ///< the last scan sampled for the loop-closure search
  double travel_since_sampled_ = 0;      ///< m, by local SLAM since then
  std::vector<std::vector<int>> links_;  ///< per submap: submaps sharing a scan or a loop closure
  PoseGraphStats stats_;

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
