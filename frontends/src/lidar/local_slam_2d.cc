#include "tether/frontends/lidar/local_slam_2d.h"

#include <chrono>
#include <cmath>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/voxel_filter.h"

namespace tether {
namespace lidar {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

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
  return submaps.IsValid(why) && correlative.IsValid(why) && refiner.IsValid(why);
}

LocalSlam2D::LocalSlam2D(const LocalSlamOptions& options) : options_(Checked(options)), submaps_(options.submaps) {}

LocalScanResult LocalSlam2D::AddScan(const LaserScan& scan) {
  LocalScanResult result;
  result.stamp = scan.stamp;
  const bool has_odometry = scan.odometry_origin != OdometryOrigin::kNone;
  if (trajectory_.empty()) {
    result.predicted = has_odometry ? scan.odometry : SE2d();
  } else {
    result.predicted = trajectory_.back().pose;
    if (has_odometry && last_has_odometry_) {
      const SE2d motion = last_odometry_.Inverse() * scan.odometry;
      result.predicted = result.predicted * motion;
      result.still =
          motion.translation().norm() < options_.still_distance && std::abs(motion.theta()) < options_.still_angle;
    }
  }
  last_odometry_ = scan.odometry;
  last_has_odometry_ = has_odometry;
  result.pose = result.predicted;

  // Points in the robot's frame.
  std::vector<Eigen::Vector2d> points = ScanToPoints(scan, options_.limits);
  for (Eigen::Vector2d& p : points) p = scan.laser_in_robot * p;
  result.matching =
      options_.matching_voxel_size > 0 && !points.empty() ? VoxelFilter(points, options_.matching_voxel_size) : points;
  const std::vector<Eigen::Vector2d>& matching = result.matching;
  const std::shared_ptr<const Submap2D> target = submaps_.matching_submap();
  if (target != nullptr && !points.empty() && !result.still) {
    result.matching_points = static_cast<int>(matching.size());
    auto t0 = std::chrono::steady_clock::now();
    SE2d start = result.predicted;
    if (options_.use_correlative_matcher) {
      const CorrelativeMatch m = MatchCorrelative(*target->grid(), result.predicted, matching, options_.correlative);
      start = m.pose;
      result.correlative_score = m.score;
      result.correlative_candidates = m.candidates;
    }
    result.correlative_seconds = SecondsSince(t0);
    t0 = std::chrono::steady_clock::now();
    const SE2d refined = RefineScanPose(target->grid(), start, result.predicted, matching, options_.refiner).pose;
    result.refine_seconds = SecondsSince(t0);
    result.matched = true;
    result.match_probability =
        MeanProbability(*target->grid(), refined, matching, options_.correlative.unknown_probability);
    result.trusted = result.match_probability >= options_.min_match_probability;
    if (result.trusted) result.pose = refined;
  }
  const SE2d moved = inserted_any_ ? last_inserted_.pose.Inverse() * result.pose : SE2d();
  const bool insert = !inserted_any_ || moved.translation().norm() >= options_.insert_min_distance ||
                      std::abs(moved.theta()) >= options_.insert_min_angle ||
                      scan.stamp - last_inserted_.stamp >= options_.insert_max_seconds;
  trajectory_.push_back(StampedPose2{scan.stamp, result.pose});
  if (!insert) return result;
  inserted_any_ = true;
  last_inserted_ = trajectory_.back();
  result.inserted = true;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector2d> in_map(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) in_map[i] = result.pose * points[i];
  result.inserted_into = submaps_.InsertScan(result.pose, result.pose * scan.laser_in_robot.translation(), in_map);
  result.insert_seconds = SecondsSince(t0);
  return result;
}

}  // namespace lidar
}  // namespace tether
