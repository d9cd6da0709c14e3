#include "tether/frontends/localization/mcl_localization_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace localization {

namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The map as an RGB image (free white, occupied black, unknown grey), rows top first.
std::vector<std::uint8_t> MapRgb(const OccupancyMap2D& map) {
  std::vector<std::uint8_t> rgb(3 * static_cast<std::size_t>(map.width()) * static_cast<std::size_t>(map.height()));
  for (int j = 0; j < map.height(); ++j)
    for (int i = 0; i < map.width(); ++i) {
      const CellState s = map.State(i, j);
      const std::uint8_t v = s == CellState::kFree ? 255 : (s == CellState::kOccupied ? 0 : 200);
      const std::size_t k = 3 * (static_cast<std::size_t>(map.height() - 1 - j) * map.width() + i);
      rgb[k] = rgb[k + 1] = rgb[k + 2] = v;
    }
  return rgb;
}

struct Painter {
  const OccupancyMap2D& map;
  std::vector<std::uint8_t>* rgb;
  void Dot(const Eigen::Vector2d& p, const std::uint8_t c[3], int radius = 0) const {
    int i, j;
    if (!map.CellOf(p, &i, &j)) return;
    for (int dj = -radius; dj <= radius; ++dj)
      for (int di = -radius; di <= radius; ++di) {
        const int x = i + di, y = j + dj;
        if (x < 0 || y < 0 || x >= map.width() || y >= map.height()) continue;
        const std::size_t k = 3 * (static_cast<std::size_t>(map.height() - 1 - y) * map.width() + x);
        std::copy(c, c + 3, rgb->begin() + static_cast<std::ptrdiff_t>(k));
      }
  }
  void Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const std::uint8_t c[3]) const {
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.5 * map.resolution()))));
    if (n > 100000) return;  // a jump across the map: not drawn
    for (int s = 0; s <= n; ++s) Dot(a + (b - a) * (static_cast<double>(s) / n), c);
  }
};

}  // namespace

bool MclRunOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (!filter.IsValid(why)) return false;
  if (has_initial_pose &&
      (!std::isfinite(initial_pose.x()) || !std::isfinite(initial_pose.y()) || !std::isfinite(initial_pose.theta()))) {
    return fail("the initial pose must be finite");
  }
  if (!(initial_sigma.array() > 0).all() || !initial_sigma.allFinite()) {
    return fail("the initial pose's sigmas must be positive and finite");
  }
  if (!(start_time >= 0) || !std::isfinite(start_time)) return fail("start_time must be 0 or more, finite");
  if (snapshots < 0) return fail("snapshots must be 0 or more");
  for (const long s : snapshot_scans) {
    if (s < 1) return fail("snapshot scans count from 1");
  }
  return true;
}

MclLocalization2D::MclLocalization2D(std::shared_ptr<const OccupancyMap2D> map, const MclRunOptions& options)
    : map_(map), options_(options), filter_(map, options.filter) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("MclLocalization2D: " + why);
}

const MclStep& MclLocalization2D::AddScan(const lidar::LaserScan& scan, long scan_number) {
  if (scan.odometry_origin == lidar::OdometryOrigin::kNone) {
    throw InvalidArgument(
        "the scan has no odometry: Monte Carlo localisation moves its particles by the robot's odometry (a log "
        "with odometry, or a bag with an odometry topic: --odom-topic)");
  }
  const std::string problem = lidar::ScanProblem(scan);
  if (!problem.empty()) throw InvalidArgument(problem);
  const auto start = std::chrono::steady_clock::now();
  if (!started_) {
    started_ = true;
    if (options_.has_initial_pose) {
      filter_.InitializeGaussian(options_.initial_pose, options_.initial_sigma.cwiseAbs2().asDiagonal());
    } else {
      filter_.InitializeGlobal();
    }
  }
  const std::size_t particles = filter_.particles().size();
  MclStepRecord record{scan_number, scan.stamp, filter_.AddScan(scan)};
  report_.total_seconds += Seconds(start);
  ++report_.scans;
  if (record.step.updated) {
    ++report_.updates;
    report_.update_seconds += Seconds(start);
    report_.injected += record.step.injected;
    report_.redrawn += record.step.redrawn;
    const std::size_t beams =
        SelectBeams(scan, options_.filter.max_beams, options_.filter.model == MeasurementModelType::kBeam,
                    options_.filter.range_cap)
            .angles.size();
    report_.particle_beams += static_cast<double>(particles) * static_cast<double>(beams);
  }
  report_.final_particles = static_cast<int>(filter_.particles().size());
  const bool wanted = std::find(options_.snapshot_scans.begin(), options_.snapshot_scans.end(), scan_number) !=
                      options_.snapshot_scans.end();
  if (wanted || (snapshots_.empty() && record.step.updated && options_.snapshot_scans.empty())) {
    snapshots_.push_back({scan_number, filter_.particles(), record.step.estimate.pose});
  }
  steps_.push_back(record);
  report_.logged_seconds = steps_.back().stamp - steps_.front().stamp;
  return steps_.back().step;
}

void MclLocalization2D::Run(const lidar::LidarLog& log, long max_scans, long progress_every,
                            const std::function<void(long)>& progress) {
  if (log.scans.empty()) return;
  const double first = log.scans.front().stamp;
  std::size_t begin = 0;
  while (begin < log.scans.size() && log.scans[begin].stamp - first < options_.start_time) ++begin;
  report_.skipped = static_cast<long>(begin);
  std::size_t end = log.scans.size();
  if (max_scans > 0) end = std::min(end, begin + static_cast<std::size_t>(max_scans));
  if (options_.snapshot_scans.empty() && options_.snapshots > 1 && end > begin) {
    for (int k = 1; k < options_.snapshots; ++k) {  // the first update is always one
      options_.snapshot_scans.push_back(static_cast<long>(begin + (end - begin - 1) * k / (options_.snapshots - 1)) +
                                        1);
    }
    // The first update comes first; keep it by adding it here as scan begin + 1.
    options_.snapshot_scans.insert(options_.snapshot_scans.begin(), static_cast<long>(begin) + 1);
  }
  for (std::size_t k = begin; k < end; ++k) {
    try {
      AddScan(log.scans[k], static_cast<long>(k) + 1);
    } catch (const InvalidArgument& e) {
      throw ParseError(lidar::ScanLocation(log, log.scans[k]) + ": " + e.what());
    }
    if (progress && progress_every > 0 && (k - begin + 1) % static_cast<std::size_t>(progress_every) == 0) {
      progress(static_cast<long>(k - begin + 1));
    }
  }
}

std::vector<lidar::StampedPose2> MclLocalization2D::Trajectory() const {
  std::vector<lidar::StampedPose2> out;
  out.reserve(steps_.size());
  for (const MclStepRecord& r : steps_) out.push_back({r.stamp, r.step.estimate.pose});
  return out;
}

std::string MclRunReport::Summary() const {
  std::ostringstream s;
  s << "scans: " << scans << " localised";
  if (skipped > 0) s << " (" << skipped << " before the start time skipped)";
  s << ", " << updates << " filter updates\n";
  s << "particles at the end: " << final_particles << "; random particles injected " << injected
    << ", re-drawn by the costmap " << redrawn << "\n";
  const double rate = total_seconds > 0 ? particle_beams / update_seconds : 0;
  s << "time: " << FormatDouble(std::round(total_seconds * 1000) / 1000) << " s for "
    << FormatDouble(std::round(logged_seconds * 10) / 10) << " s of log ("
    << FormatDouble(std::round(total_seconds > 0 ? logged_seconds / total_seconds : 0)) << "x real time); "
    << FormatDouble(std::round(rate / 1e5) / 10) << " million particle-beams a second in the updates\n";
  return s.str();
}

LocalizationError CompareWithReference(const std::vector<lidar::StampedPose2>& estimate,
                                       const std::vector<lidar::StampedPose2>& reference, double converged_metres,
                                       double converged_radians, double tolerance) {
  LocalizationError e;
  // Both in log order: matched in order, so that scans sharing a stamp (logs whose stamps
  // bunch) meet their own reference pose.
  std::vector<std::pair<double, double>> errors;  // position, heading
  std::vector<double> stamps;
  std::size_t j = 0;
  for (const lidar::StampedPose2& p : estimate) {
    std::size_t k = j;
    while (k < reference.size() && reference[k].stamp < p.stamp - tolerance) ++k;
    if (k == reference.size() || reference[k].stamp > p.stamp + tolerance) continue;
    j = k + 1;
    const double d = (p.pose.translation() - reference[k].pose.translation()).norm();
    const double h = std::abs(std::remainder(p.pose.theta() - reference[k].pose.theta(), 2 * 3.14159265358979323846));
    errors.emplace_back(d, h);
    stamps.push_back(p.stamp);
  }
  e.matched = static_cast<long>(errors.size());
  if (errors.empty()) return e;
  for (const auto& x : errors) {
    e.mean_error += x.first / static_cast<double>(errors.size());
    e.mean_heading_error += x.second / static_cast<double>(errors.size());
    e.max_error = std::max(e.max_error, x.first);
  }
  long first = static_cast<long>(errors.size());
  while (first > 0 && errors[static_cast<std::size_t>(first - 1)].first <= converged_metres &&
         errors[static_cast<std::size_t>(first - 1)].second <= converged_radians) {
    --first;
  }
  if (first < static_cast<long>(errors.size())) {
    e.converged_index = first;
    e.converged_stamp = stamps[static_cast<std::size_t>(first)];
    const double n = static_cast<double>(errors.size() - static_cast<std::size_t>(first));
    for (std::size_t k = static_cast<std::size_t>(first); k < errors.size(); ++k) {
      e.mean_error_converged += errors[k].first / n;
      e.mean_heading_error_converged += errors[k].second / n;
    }
  }
  return e;
}

std::vector<lidar::LidarOutput> MclLocalization2D::OutputNames() {
  return {{"trajectory.tum", "pose stream", ""}, {"mcl_steps.csv", "per-scan record", ""}, {"mcl.png", "picture", ""}};
}

std::vector<lidar::LidarOutput> MclLocalization2D::Outputs() const {
  std::vector<lidar::LidarOutput> out = OutputNames();
  std::ostringstream tum;
  lidar::WriteTum(tum, Trajectory());
  out[0].bytes = tum.str();
  std::ostringstream csv;
  csv << "scan,stamp,x,y,theta,sigma_x,sigma_y,sigma_theta,cluster_weight,clusters,updated,particles,injected,"
         "redrawn,log_w_avg,log_w_slow,log_w_fast\n";
  for (const MclStepRecord& r : steps_) {
    const MclStep& s = r.step;
    const PoseEstimate& e = s.estimate;
    csv << r.scan << "," << FormatDouble(r.stamp) << "," << FormatDouble(e.pose.x()) << "," << FormatDouble(e.pose.y())
        << "," << FormatDouble(e.pose.theta()) << "," << FormatDouble(std::sqrt(e.covariance(0, 0))) << ","
        << FormatDouble(std::sqrt(e.covariance(1, 1))) << "," << FormatDouble(std::sqrt(e.covariance(2, 2))) << ","
        << FormatDouble(e.cluster_weight) << "," << e.clusters << "," << (s.updated ? 1 : 0) << "," << s.particles
        << "," << s.injected << "," << s.redrawn << "," << FormatDouble(s.w_avg) << "," << FormatDouble(s.w_slow) << ","
        << FormatDouble(s.w_fast) << "\n";
  }
  out[1].bytes = csv.str();
  std::vector<std::uint8_t> rgb = MapRgb(*map_);
  const Painter paint{*map_, &rgb};
  static const std::uint8_t kClouds[4][3] = {{230, 80, 40}, {40, 160, 60}, {160, 60, 200}, {230, 160, 0}};
  for (std::size_t s = 0; s < snapshots_.size(); ++s) {
    for (const Particle& p : snapshots_[s].particles) paint.Dot({p.x, p.y}, kClouds[s % 4]);
  }
  static const std::uint8_t kPath[3] = {30, 90, 230};
  for (std::size_t k = 1; k < steps_.size(); ++k) {
    paint.Line(steps_[k - 1].step.estimate.pose.translation(), steps_[k].step.estimate.pose.translation(), kPath);
  }
  for (std::size_t s = 0; s < snapshots_.size(); ++s)
    paint.Dot(snapshots_[s].estimate.translation(), kClouds[s % 4], 2);
  out[2].bytes = lidar::PngBytesRgb(map_->width(), map_->height(), rgb);
  return out;
}

}  // namespace localization
}  // namespace tether
