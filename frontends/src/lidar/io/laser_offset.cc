#include "tether/frontends/lidar/io/laser_offset.h"

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "tether/core/error.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"

namespace tether {
namespace lidar {

bool LaserOffsetOptions::IsValid(std::string* why) const {
  const bool ok = std::isfinite(min_turn) && min_turn > 0 && std::isfinite(max_translation) && max_translation >= 0 &&
                  max_scans_per_turn >= 1 && max_turns >= 1 && std::isfinite(max_rms) && max_rms > 0 &&
                  min_pairs >= 3 && std::isfinite(max_range) && max_range >= 0;
  if (!ok && why != nullptr) {
    *why =
        "min_turn, max_rms must be positive, max_translation and max_range not negative, max_scans_per_turn at "
        "least 1, min_pairs at least 3";
  }
  return ok;
}

namespace {

struct Turn {
  SE2d odometry;  // the robot's motion over the turn
  SE2d laser;     // the laser's, matched scan to scan
};

// Residual of a turn's translation for the offset o.
Eigen::Vector2d Residual(const Turn& t, const Eigen::Vector2d& o) {
  const double c = std::cos(t.odometry.theta()), s = std::sin(t.odometry.theta());
  const Eigen::Vector2d moved(c * o.x() - s * o.y() - o.x(), s * o.x() + c * o.y() - o.y());
  return t.laser.translation() - (t.odometry.translation() + moved);
}

}  // namespace

LaserOffsetEstimate EstimateLaserOffset(const LidarLog& log, const LaserOffsetOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("LaserOffsetOptions: " + why);
  const RangeLimits limits{0, options.max_range};
  std::vector<Turn> turns;
  const std::size_t n = log.scans.size();
  ScanToScanOptions match;
  match.guess_translation_weight = 0;
  match.guess_rotation_weight = 0;
  const SO2d laser_heading(log.scans.empty() ? 0.0 : log.scans.front().laser_in_robot.theta());
  for (std::size_t i = 0; i + 1 < n && static_cast<int>(turns.size()) < options.max_turns; i += 3) {
    const LaserScan& a = log.scans[i];
    if (a.odometry_origin == OdometryOrigin::kNone) continue;
    std::size_t j = i + 1;
    const std::size_t last = std::min(n - 1, i + static_cast<std::size_t>(options.max_scans_per_turn));
    while (j < last && std::abs((a.odometry.Inverse() * log.scans[j].odometry).theta()) < options.min_turn) ++j;
    const LaserScan& b = log.scans[j];
    if (b.odometry_origin == OdometryOrigin::kNone) continue;
    const SE2d motion = a.odometry.Inverse() * b.odometry;
    if (std::abs(motion.theta()) < options.min_turn || motion.translation().norm() > options.max_translation) continue;
    const std::vector<Eigen::Vector2d> pa = ScanToPoints(a, limits), pb = ScanToPoints(b, limits);
    if (pa.empty() || pb.empty()) continue;
    // The guess: the laser's motion with the laser at the robot's centre.
    const ScanToScanMatch m = MatchScanToScan(pa, pb, motion, match);
    if (!m.ok || m.rms > options.max_rms || m.pairs < options.min_pairs) continue;
    // The laser's motion with its translation in the robot's axes (a laser turned on the robot).
    turns.push_back(Turn{motion, SE2d(SO2d(m.motion.theta()), laser_heading * m.motion.translation())});
  }
  LaserOffsetEstimate e;
  e.turns = static_cast<int>(turns.size());
  if (turns.empty()) return e;
  // Normal equations of laser - odometry = (R - I) o.
  Eigen::Matrix2d h = Eigen::Matrix2d::Zero();
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  for (const Turn& t : turns) {
    const double c = std::cos(t.odometry.theta()), s = std::sin(t.odometry.theta());
    Eigen::Matrix2d a;
    a << c - 1, -s, s, c - 1;
    h += a.transpose() * a;
    g += a.transpose() * (t.laser.translation() - t.odometry.translation());
  }
  const Eigen::Vector2d o = h.ldlt().solve(g);
  e.x = o.x();
  e.y = o.y();
  const Eigen::Vector2d at_log = log.scans.front().laser_in_robot.translation();
  double sum = 0, sum_log = 0;
  for (const Turn& t : turns) {
    sum += Residual(t, o).squaredNorm();
    sum_log += Residual(t, at_log).squaredNorm();
  }
  e.rms = std::sqrt(sum / static_cast<double>(turns.size()));
  e.rms_at_log = std::sqrt(sum_log / static_cast<double>(turns.size()));
  return e;
}

}  // namespace lidar
}  // namespace tether
