#include "tether/frontends/lidar/mapping/local_slam_2d.h"

#include <chrono>
#include <cmath>
#include <cstdint>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"

namespace tether {
namespace lidar {

namespace {

// The 0.1 m cell of a point, as one key.
std::int64_t OverlapCell(const Eigen::Vector2d& p) {
  const std::int64_t x = static_cast<std::int64_t>(std::floor(p.x() * 10));
  const std::int64_t y = static_cast<std::int64_t>(std::floor(p.y() * 10));
  // Shifted as unsigned: a negative cell index shifted left is undefined behaviour.
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(x) << 32) ^
                                   (static_cast<std::uint64_t>(y) & 0xffffffffu));
}

// The relocation search (LocalSlam2D::Relocate): rotations in 0.5 degree steps all the way
// round, and a best with a rival within 90% of its score 1 m or 0.1 rad away is not taken (the
// global search's rules, ConstraintBuilderOptions::global_*).
constexpr double kRelocateAngularStep = 0.00872664625997165;
constexpr double kRelocateRivalDistance = 1;
constexpr double kRelocateRivalAngle = 0.1;
constexpr double kRelocateRivalRatio = 0.9;

double MeanProbability(const ProbabilityGrid& grid, const SE2d& pose, const std::vector<Eigen::Vector2d>& points,
                       double unknown) {
  double sum = 0;
  for (const Eigen::Vector2d& p : points) sum += grid.Probability(grid.CellOf(pose * p), unknown);
  return sum / static_cast<double>(points.size());
}

LocalSlamOptions Checked(const LocalSlamOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("LocalSlamOptions: " + why);
  return options;
}

}  // namespace

bool LocalSlamOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(matching_voxel_size) && matching_voxel_size >= 0)) {
    if (why != nullptr) {
      *why = "matching_voxel_size is " + FormatDouble(matching_voxel_size) + "; it must be finite and not negative";
    }
    return false;
  }
  if (!(min_match_probability >= 0 && min_match_probability <= 1)) {
    if (why != nullptr)
      *why = "min_match_probability is " + FormatDouble(min_match_probability) + "; it must lie in [0, 1]";
    return false;
  }
  for (double v : {insert_min_distance, insert_min_angle, insert_max_seconds, still_distance, still_angle}) {
    if (!(std::isfinite(v) && v >= 0)) {
      if (why != nullptr) *why = "the motion filter's and still_* thresholds must be finite and not negative";
      return false;
    }
  }
  for (double v : {weak_prediction_linear_window, weak_prediction_angular_window, weak_prediction_translation_weight,
                   scan_to_scan_translation_weight, imu_rotation_weight}) {
    if (!(std::isfinite(v) && v >= 0)) {
      if (why != nullptr) {
        *why =
            "the weak_prediction_* options, scan_to_scan_translation_weight and imu_rotation_weight must be finite and "
            "not negative";
      }
      return false;
    }
  }
  if (keep_submaps < 0) {
    if (why != nullptr) *why = "keep_submaps must not be negative (0: keep every submap)";
    return false;
  }
  return submaps.IsValid(why) && correlative.IsValid(why) && refiner.IsValid(why) &&
         scan_to_scan_options.IsValid(why) && kidnap.IsValid(why);
}

LocalSlam2D::LocalSlam2D(const LocalSlamOptions& options)
    : options_(Checked(options)), submaps_(options.submaps), kidnap_(options.kidnap) {}

bool LocalSlam2D::Relocate(const std::shared_ptr<const ProbabilityGrid>& grid,
                           const std::vector<Eigen::Vector2d>& matching, double before, SE2d* pose) const {
  const KidnapOptions& k = options_.kidnap;
  const std::size_t f = static_cast<std::size_t>(k.filter_size);
  if (k.relocate_window <= 0 || before <= 0 || matching.empty() || trajectory_.size() < f) return false;
  // The last pose before the scan that broke (the detector's window holds f scans, this one
  // the last): the robot was known there.
  const SE2d centre = trajectory_[trajectory_.size() - f].pose;
  FastMatcherOptions search;
  search.linear_search_window = k.relocate_window;
  search.angular_search_window = M_PI;
  const FastCorrelativeScanMatcher2D matcher(*grid, search);
  const FastMatch m = matcher.MatchChecked(centre, matching, k.relocate_min_score, kRelocateRivalDistance,
                                           kRelocateRivalAngle, kRelocateRivalRatio, -1, M_PI, kRelocateAngularStep);
  if (!m.found || m.ambiguous || m.on_edge) return false;
  const SE2d refined = RefineScanPose(grid, m.pose, m.pose, matching, options_.refiner).pose;
  if (1 - MeanProbability(*grid, refined, matching, 0.5) > k.relocate_max_rise * before) return false;
  *pose = refined;
  return true;
}

SE2d LocalSlam2D::ConstantVelocity() const {
  const std::size_t n = trajectory_.size();
  if (n < 2) return trajectory_.back().pose;
  const SE2d& a = trajectory_[n - 2].pose;
  const SE2d& b = trajectory_[n - 1].pose;
  return b * (a.Inverse() * b);
}

bool LocalSlam2D::WeakMatch(const CorrelativeMatch& m, const SE2d& predicted, const ProbabilityGrid& grid) const {
  if (m.mean_probability < options_.min_match_probability) return true;
  const Eigen::Vector2d d = SO2d(-predicted.theta()) * (m.pose.translation() - predicted.translation());
  const double edge = options_.correlative.linear_search_window - 0.5 * grid.resolution();
  return std::abs(d.x()) >= edge || std::abs(d.y()) >= edge ||
         std::abs(WrapAngle(m.pose.theta() - predicted.theta())) >=
             options_.correlative.angular_search_window - 0.5 * m.angular_step;
}

InsertedSubmaps LocalSlam2D::FinishTrajectory() {
  kidnapped_ = true;
  return submaps_.FinishActive();
}

LocalScanResult LocalSlam2D::AddScan(const LaserScan& scan) {
  if (kidnapped_) {
    throw InvalidArgument(
        "LocalSlam2D::AddScan: a kidnap was declared or the trajectory finished; start a new LocalSlam2D "
        "for the scans after it");
  }
  LocalScanResult result;
  result.stamp = scan.stamp;
  const bool has_odometry = scan.odometry_origin != OdometryOrigin::kNone;
  result.scan_only = !has_odometry;
  // Points in the robot's frame.
  std::vector<Eigen::Vector2d> points = ScanToPoints(scan, options_.limits);
  for (Eigen::Vector2d& p : points) p = scan.laser_in_robot * p;
  auto t0 = std::chrono::steady_clock::now();
  Eigen::Matrix2d degenerate = Eigen::Matrix2d::Zero();
  if (trajectory_.empty()) {
    result.predicted = has_odometry ? scan.odometry : SE2d();
  } else {
    result.predicted = trajectory_.back().pose;
    if (!has_odometry) {
      // Constant motion per scan, then the motion from the scan before by scan-to-scan
      // matching from it and from no motion.
      result.predicted = ConstantVelocity();
      const SE2d& last = trajectory_.back().pose;
      // The IMU's turn since the scan before, where both have a heading.
      result.imu_turn = scan.has_imu_yaw && last_has_imu_yaw_;
      const double turn = result.imu_turn ? scan.imu_yaw - last_imu_yaw_ : 0;
      ScanToScanOptions s2s = options_.scan_to_scan_options;
      if (result.imu_turn) {
        const SE2d motion = last.Inverse() * result.predicted;
        result.predicted = last * SE2d(motion.x(), motion.y(), turn);
        s2s.guess_rotation_weight = std::max(s2s.guess_rotation_weight, options_.imu_rotation_weight);
      }
      if (options_.scan_to_scan && !last_points_.empty() && !points.empty()) {
        const ScanToScanMatch m =
            MatchMovingOrStill(last_points_, points, last.Inverse() * result.predicted, turn, s2s);
        if (m.ok) {
          result.predicted = last * m.motion;
          result.scan_to_scan = true;
          // What the match did not see, in the map frame (from the previous scan's).
          const Eigen::Matrix2d r = last.rotation().matrix();
          degenerate = r * m.degenerate * r.transpose();
        }
      }
    } else if (last_has_odometry_) {
      const SE2d motion = last_odometry_.Inverse() * scan.odometry;
      result.predicted = result.predicted * motion;
      result.still =
          motion.translation().norm() < options_.still_distance && std::abs(motion.theta()) < options_.still_angle;
    }
  }
  result.scan_to_scan_seconds = SecondsSince(t0);
  last_odometry_ = scan.odometry;
  last_has_odometry_ = has_odometry;
  last_imu_yaw_ = scan.imu_yaw;
  last_has_imu_yaw_ = scan.has_imu_yaw;
  result.pose = result.predicted;
  // A scan-only scan whose prediction is constant velocity alone (no scan-to-scan match).
  const bool weak_prediction = result.scan_only && !result.scan_to_scan;

  result.matching =
      options_.matching_voxel_size > 0 && !points.empty() ? VoxelFilter(points, options_.matching_voxel_size) : points;
  const std::vector<Eigen::Vector2d>& matching = result.matching;
  const std::shared_ptr<const Submap2D> target = submaps_.matching_submap();
  if (target != nullptr && !points.empty() && !result.still) {
    result.matching_points = static_cast<int>(matching.size());
    t0 = std::chrono::steady_clock::now();
    SE2d start = result.predicted;
    if (options_.use_correlative_matcher) {
      CorrelativeMatcherOptions correlative = options_.correlative;
      if (result.scan_to_scan) {
        correlative.translation_delta_cost_weight =
            std::max(correlative.translation_delta_cost_weight, options_.scan_to_scan_translation_weight);
      }
      CorrelativeMatch m = MatchCorrelative(*target->grid(), result.predicted, matching, correlative);
      result.correlative_candidates = m.candidates;
      if (weak_prediction && WeakMatch(m, result.predicted, *target->grid())) {
        CorrelativeMatcherOptions wide = options_.correlative;
        wide.linear_search_window = std::max(wide.linear_search_window, options_.weak_prediction_linear_window);
        wide.angular_search_window = std::max(wide.angular_search_window, options_.weak_prediction_angular_window);
        wide.translation_delta_cost_weight = options_.weak_prediction_translation_weight;
        m = MatchCorrelative(*target->grid(), result.predicted, matching, wide);
        result.correlative_candidates += m.candidates;
        result.widened = true;
      }
      start = m.pose;
      result.correlative_score = m.score;
    }
    result.correlative_seconds = SecondsSince(t0);
    t0 = std::chrono::steady_clock::now();
    // The refinement's regularisers pull towards the prediction, or, where the prediction was
    // too weak to search around, towards the wide search's best.
    SE2d refined =
        RefineScanPose(target->grid(), start, result.widened ? start : result.predicted, matching, options_.refiner)
            .pose;
    if (!degenerate.isZero()) {
      // Along what the scan-to-scan match did not see, the submap sees no more (the same
      // points): the match keeps the prediction's translation there, so that neither the
      // submap's preference for its own scans' poses nor its ripples move the pose along a
      // corridor (ScanToScanOptions::degenerate_information; off by default).
      refined = SE2d(SO2d(refined.theta()),
                     refined.translation() - degenerate * (refined.translation() - result.predicted.translation()));
    }
    result.refine_seconds = SecondsSince(t0);
    result.matched = true;
    result.match_probability =
        MeanProbability(*target->grid(), refined, matching, options_.correlative.unknown_probability);
    result.trusted = result.match_probability >= options_.min_match_probability;
    const ProbabilityGrid& grid = *target->grid();
    // Unknown cells read 0.5 in the cost: the same mean where the matcher's unknown is 0.5 too.
    result.match_cost =
        1 - (options_.correlative.unknown_probability == 0.5 ? result.match_probability
                                                             : MeanProbability(grid, refined, matching, 0.5));
    int hits = 0;
    for (const Eigen::Vector2d& p : matching) {
      hits += grid.Probability(grid.CellOf(refined * p), 0) >= options_.kidnap.hit_probability;
    }
    const double n = static_cast<double>(matching.size());
    result.hit_fraction = hits / n;
    // The share of the points within a cell or so of the scan before's (both at their poses).
    if (!last_cells_.empty()) {
      int near = 0;
      for (const Eigen::Vector2d& p : matching) {
        const Eigen::Vector2d q = refined * p;
        bool found = false;
        for (int dx = -1; dx <= 1 && !found; ++dx) {
          for (int dy = -1; dy <= 1 && !found; ++dy) {
            found = last_cells_.count(OverlapCell(q + Eigen::Vector2d(0.1 * dx, 0.1 * dy))) != 0;
          }
        }
        near += found;
      }
      result.overlap = near / n;
    }
    result.kidnap = kidnap_.Add(result.match_cost, result.overlap);
    if (result.kidnap.detected && options_.kidnap.detect) {
      if (Relocate(target->grid(), matching, result.kidnap.before, &refined)) {
        // Lost, not carried off: the scan fits the submap near where the robot last was.
        result.kidnap.relocated = true;
        result.trusted = true;
        result.match_probability = MeanProbability(grid, refined, matching, options_.correlative.unknown_probability);
        result.match_cost = 1 - MeanProbability(grid, refined, matching, 0.5);
        kidnap_.Reset();
      } else {
        result.kidnapped = kidnapped_ = true;
        result.pose = refined;
        return result;
      }
    }
    // A scan whose prediction is constant velocity alone has nothing of its own to fall back to
    // (it repeats the match before): it keeps its match however weak.
    if (result.trusted || weak_prediction) result.pose = refined;
  }
  const SE2d moved = inserted_any_ ? last_inserted_.pose.Inverse() * result.pose : SE2d();
  const bool insert = !inserted_any_ || moved.translation().norm() >= options_.insert_min_distance ||
                      std::abs(moved.theta()) >= options_.insert_min_angle ||
                      scan.stamp - last_inserted_.stamp >= options_.insert_max_seconds;
  trajectory_.push_back(StampedPose2{scan.stamp, result.pose});
  if (options_.keep_submaps > 0 && trajectory_.size() > 64) {
    trajectory_.erase(trajectory_.begin(), trajectory_.end() - 2);  // bounded: the last two predict
  }
  if (!points.empty()) last_points_ = points;
  if (!matching.empty()) {
    last_cells_.clear();
    for (const Eigen::Vector2d& p : matching) last_cells_.insert(OverlapCell(result.pose * p));
  }
  if (!insert) return result;
  inserted_any_ = true;
  last_inserted_ = trajectory_.back();
  result.inserted = true;
  t0 = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector2d> in_map(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) in_map[i] = result.pose * points[i];
  result.inserted_into = submaps_.InsertScan(result.pose, result.pose * scan.laser_in_robot.translation(), in_map);
  if (options_.keep_submaps > 0) submaps_.KeepNewest(options_.keep_submaps);
  result.insert_seconds = SecondsSince(t0);
  return result;
}

}  // namespace lidar
}  // namespace tether
