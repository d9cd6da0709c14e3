#include "tether/frontends/lidar/rbpf_slam_2d.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/parallel_for.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"
#include "tether/frontends/localization/resampling.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace lidar {

namespace {

constexpr double kUnknown = 0.5;  // what an unknown cell reads in the likelihood

bool Fail(std::string* why, const std::string& w) {
  if (why != nullptr) *why = w;
  return false;
}

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0; }

// The points (robot frame) moved to `pose` (map frame).
std::vector<Eigen::Vector2d> Transformed(const SE2d& pose, const std::vector<Eigen::Vector2d>& points) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(points.size());
  for (const Eigen::Vector2d& p : points) out.push_back(pose * p);
  return out;
}

// likelihood_points * mean log P over the points at `pose`, on a dense window.
double LogLikelihood(const ProbabilityGrid& grid, const SE2d& pose, const std::vector<Eigen::Vector2d>& points,
                     double effective, std::vector<ProbabilityGrid::Cell>* cells) {
  grid.CellsOf(pose, points, cells);
  double sum = 0;
  for (const ProbabilityGrid::Cell& c : *cells) sum += std::log(grid.Probability(c, kUnknown));
  return effective * sum / static_cast<double>(std::max<std::size_t>(1, points.size()));
}

double LogSumExp(const std::vector<double>& v) {
  double top = -std::numeric_limits<double>::infinity();
  for (double x : v) top = std::max(top, x);
  if (!std::isfinite(top)) return top;
  double s = 0;
  for (double x : v) s += std::exp(x - top);
  return top + std::log(s);
}

}  // namespace

bool RbpfSlamOptions::IsValid(std::string* why) const {
  std::string w;
  if (particles < 1 || particles > 100000) return Fail(why, "particles must lie in 1..100000");
  if (!PositiveFinite(resolution)) return Fail(why, "resolution must be positive and finite");
  if (!(std::isfinite(limits.min_range) && limits.min_range >= 0 && std::isfinite(limits.max_range) &&
        limits.max_range >= 0)) {
    return Fail(why, "limits must be finite and not negative");
  }
  if (!PositiveFinite(max_range)) return Fail(why, "max_range must be positive and finite");
  if (!(std::isfinite(matching_voxel_size) && matching_voxel_size >= 0)) {
    return Fail(why, "matching_voxel_size must be finite and not negative");
  }
  if (!(std::isfinite(linear_update) && linear_update >= 0 && std::isfinite(angular_update) && angular_update >= 0)) {
    return Fail(why, "linear_update and angular_update must be finite and not negative");
  }
  if (!motion.IsValid(&w)) return Fail(why, "motion: " + w);
  if (!correlative.IsValid(&w)) return Fail(why, "correlative: " + w);
  if (!insert.IsValid(&w)) return Fail(why, "insert: " + w);
  if (!(min_known_fraction >= 0 && min_known_fraction <= 1)) return Fail(why, "min_known_fraction must lie in [0, 1]");
  if (!PositiveFinite(proposal_step) || !PositiveFinite(proposal_angle)) {
    return Fail(why, "proposal_step and proposal_angle must be positive and finite");
  }
  if (!PositiveFinite(likelihood_points)) return Fail(why, "likelihood_points must be positive and finite");
  if (!(resample_fraction >= 0 && resample_fraction <= 1)) return Fail(why, "resample_fraction must lie in [0, 1]");
  if (threads < 0) return Fail(why, "threads must be 0 (every core) or more");
  if (!scan_to_scan.IsValid(&w)) return Fail(why, "scan_to_scan: " + w);
  if (!(std::isfinite(odometry_check_translation) && odometry_check_translation >= 0 &&
        std::isfinite(odometry_check_rotation) && odometry_check_rotation >= 0)) {
    return Fail(why, "odometry_check_translation and odometry_check_rotation must be finite and not negative");
  }
  return true;
}

std::string RbpfSlamReport::Summary() const {
  std::ostringstream s;
  s << "scans " << scans;
  if (scan_to_scan > 0) s << " (no odometry: " << scan_to_scan << " moved by scan-to-scan matching)";
  if (odometry_overruled > 0) s << " (" << odometry_overruled << " odometry steps overruled by the scans)";
  s << ", processed " << processed << " (" << matched << " particle matches), resamplings " << resamplings
    << ", lowest effective sample size " << min_effective << "\n";
  s << "maps: " << distinct_tiles << " distinct tiles, " << tile_bytes / (1024.0 * 1024.0) << " MB\n";
  s << "time " << seconds << " s";
  if (logged_seconds > 0 && seconds > 0) s << " (" << logged_seconds / seconds << "x real time)";
  s << "\n";
  return s.str();
}

RbpfSlam2D::RbpfSlam2D(const RbpfSlamOptions& options)
    : options_(options),
      inserter_(options.insert, ProbabilityGrid::kDefaultMinProbability, ProbabilityGrid::kDefaultMaxProbability) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("RbpfSlamOptions: " + why);
  if (options_.limits.max_range == 0 || options_.limits.max_range > options_.max_range) {
    options_.limits.max_range = options_.max_range;
  }
  particles_.assign(static_cast<std::size_t>(options_.particles),
                    Particle{SE2d(), 0.0, TiledProbabilityGrid(options_.resolution), nullptr});
}

void RbpfSlam2D::AddScan(const LaserScan& scan) {
  const std::string problem = ScanProblem(scan);
  if (!problem.empty()) throw InvalidArgument("RbpfSlam2D::AddScan: " + problem);
  const bool has_odometry = scan.odometry_origin != OdometryOrigin::kNone;
  if (!stamps_.empty() && has_odometry == scan_only_) {
    throw InvalidArgument(
        std::string("RbpfSlam2D::AddScan: the scan ") +
        (has_odometry ? "has odometry, the scans before had none" : "has no odometry, the scans before had some") +
        "; a log is run with odometry throughout or without it throughout");
  }
  const auto t0 = std::chrono::steady_clock::now();
  SE2d odometry = scan.odometry;
  if (!has_odometry) {
    // Scan-only: the odometry is the chain of scan-to-scan matches (from constant motion, or
    // standing still where that pairs clearly more points), as local SLAM predicts such scans.
    std::vector<Eigen::Vector2d> points = ScanToPoints(scan, options_.limits);
    for (Eigen::Vector2d& p : points) p = scan.laser_in_robot * p;
    if (!stamps_.empty() && !previous_points_.empty() && !points.empty()) {
      const ScanToScanMatch m = MatchMovingOrStill(previous_points_, points, last_motion_, 0, options_.scan_to_scan);
      if (m.ok) last_motion_ = m.motion;
      ++report_.scan_to_scan;
    }
    scan_odometry_ = stamps_.empty() ? SE2d() : scan_odometry_ * last_motion_;
    odometry = scan_odometry_;
    if (!points.empty()) previous_points_ = std::move(points);
    scan_only_ = true;
  }
  const long index = static_cast<long>(stamps_.size());
  stamps_.push_back(scan.stamp);
  report_.scans = index + 1;
  report_.logged_seconds = scan.stamp - stamps_.front();
  const SE2d delta = last_odometry_.Inverse() * odometry;
  const bool due = !started_ || delta.translation().norm() >= options_.linear_update ||
                   std::abs(delta.theta()) >= options_.angular_update;
  if (due) {
    Process(index, odometry, scan);
    processed_before_.push_back(index);
    since_processed_.push_back(SE2d());
  } else {
    processed_before_.push_back(processed_before_.back());
    since_processed_.push_back(delta);
  }
  report_.seconds += SecondsSince(t0);
}

void RbpfSlam2D::Run(const LidarLog& log, long max_scans) {
  ForEachScan(log, max_scans, [this](const LaserScan& scan) { AddScan(scan); });
}

std::vector<LidarOutput> RbpfSlam2D::OutputNames() {
  return {{"trajectory.tum", "trajectory", ""},
          {"map.pgm", "map image", ""},
          {"map.yaml", "map description", ""},
          {"map.png", "map picture", ""}};
}

std::vector<LidarOutput> RbpfSlam2D::Outputs() const {
  std::vector<LidarOutput> out = OutputNames();
  std::ostringstream s;
  WriteTum(s, Trajectory());
  out[0].bytes = s.str();
  const OccupancyImage image = RenderOccupancy(Map());
  out[1].bytes = PgmBytes(image);
  out[2].bytes = MapYaml(image, "map.pgm");
  out[3].bytes = PngBytes(image);
  return out;
}

void RbpfSlam2D::Process(long scan, const SE2d& odometry, const LaserScan& s) {
  std::vector<Eigen::Vector2d> points = ScanToPoints(s, options_.limits);
  for (Eigen::Vector2d& p : points) p = s.laser_in_robot * p;
  const std::vector<Eigen::Vector2d> matching =
      options_.matching_voxel_size > 0 ? VoxelFilter(points, options_.matching_voxel_size) : points;
  if (!started_) {
    // Every particle starts at the first scan's odometry pose with the same first map.
    Particle& first = particles_.front();
    first.pose = odometry;
    inserter_.Insert(&first.map, (odometry * s.laser_in_robot).translation(), Transformed(odometry, points));
    first.path = std::make_shared<const Node>(Node{odometry, scan, nullptr});
    for (std::size_t i = 1; i < particles_.size(); ++i) particles_[i] = first;
    started_ = true;
    last_odometry_ = odometry;
    processed_points_ = points;
    ++report_.processed;
    return;
  }
  MaybeResample();
  // The odometry's motion since the last processed scan, unless the scans say otherwise.
  SE2d delta = last_odometry_.Inverse() * odometry;
  if (!scan_only_ && options_.odometry_check_translation > 0 && !processed_points_.empty() && !points.empty()) {
    // Matched from the odometry's motion and from standing still: only where both reach the same
    // motion did the scans see it (along a corridor each keeps its start's motion along it).
    const ScanToScanMatch from_odometry = MatchScanToScan(processed_points_, points, delta, options_.scan_to_scan);
    const ScanToScanMatch from_still = MatchScanToScan(processed_points_, points, SE2d(), options_.scan_to_scan);
    const SE2d agree = from_odometry.motion.Inverse() * from_still.motion;
    const SE2d d = delta.Inverse() * from_odometry.motion;
    if (from_odometry.ok && from_still.ok && agree.translation().norm() < 0.02 && std::abs(agree.theta()) < 0.01 &&
        (d.translation().norm() > options_.odometry_check_translation ||
         std::abs(d.theta()) > options_.odometry_check_rotation)) {
      delta = from_odometry.motion;
      ++report_.odometry_overruled;
    }
  }
  if (!points.empty()) processed_points_ = points;
  const localization::OdometryMotion motion = localization::DecomposeOdometry(SE2d(), delta);
  std::vector<char> matched(particles_.size(), 0);
  const std::uint64_t step = ++steps_;
  ParallelFor(particles_.size(), options_.threads, [&](std::size_t i) {
    bool m = false;
    Step(&particles_[i], motion, s.laser_in_robot, points, matching, scan,
         step * static_cast<std::uint64_t>(particles_.size()) + i, &m);
    matched[i] = m ? 1 : 0;
  });
  for (char m : matched) report_.matched += m;
  last_odometry_ = odometry;
  ++report_.processed;
}

void RbpfSlam2D::Step(Particle* p, const localization::OdometryMotion& motion, const SE2d& laser,
                      const std::vector<Eigen::Vector2d>& points, const std::vector<Eigen::Vector2d>& matching,
                      long scan, std::uint64_t stream, bool* matched) const {
  RandomStream random(options_.seed, stream);
  const localization::OdometryMotionModel& model = options_.motion;
  // The motion without noise, its spread, and a sample of it.
  const double a1 = p->pose.theta() + motion.rot1;
  const SE2d mean(p->pose.x() + motion.trans * std::cos(a1), p->pose.y() + motion.trans * std::sin(a1),
                  a1 + motion.rot2);
  const Eigen::Vector3d sig = model.Sigmas(motion);
  const double sigma_xy = std::max(sig[1], 0.01), sigma_theta = std::max(std::hypot(sig[0], sig[2]), 0.005);
  const SE2d sampled = model.Sample(p->pose, motion, &random);
  // A window of the particle's map around the scan at the sampled pose, as a dense grid.
  const double margin = options_.correlative.linear_search_window + 2 * options_.proposal_step + 1.0;
  Eigen::Vector2d lo = sampled.translation(), hi = lo;
  for (const Eigen::Vector2d& q : Transformed(sampled, matching)) {
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const auto window = std::make_shared<const ProbabilityGrid>(p->map.Window(
      p->map.CellOf(lo - Eigen::Vector2d::Constant(margin)), p->map.CellOf(hi + Eigen::Vector2d::Constant(margin))));
  std::vector<ProbabilityGrid::Cell> cells;
  window->CellsOf(sampled, matching, &cells);
  std::size_t known = 0;
  for (const ProbabilityGrid::Cell& c : cells) known += window->IsKnown(c) ? 1 : 0;
  SE2d centre = sampled;
  if (!matching.empty() && static_cast<double>(known) >= options_.min_known_fraction * matching.size()) {
    const CorrelativeMatch c = MatchCorrelative(*window, sampled, matching, options_.correlative);
    // The refinement pulled towards the search's best, not the sample: the motion enters the
    // proposal below, and the match is to find the scan's likelihood peak.
    const ScanRefinement r = RefineScanPose(window, c.pose, c.pose, matching, options_.refiner);
    centre = r.pose.translation().allFinite() && std::isfinite(r.pose.theta()) ? r.pose : c.pose;
    *matched = true;
  }
  // The improved proposal from 27 poses around the centre.
  std::vector<SE2d> poses;
  std::vector<double> log_w;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dt = -1; dt <= 1; ++dt) {
        const SE2d x(centre.x() + dx * options_.proposal_step, centre.y() + dy * options_.proposal_step,
                     centre.theta() + dt * options_.proposal_angle);
        const Eigen::Vector2d e = x.translation() - mean.translation();
        const double et = WrapAngle(x.theta() - mean.theta());
        const double motion_log =
            -0.5 * (e.squaredNorm() / (sigma_xy * sigma_xy) + et * et / (sigma_theta * sigma_theta));
        poses.push_back(x);
        log_w.push_back(LogLikelihood(*window, x, matching, options_.likelihood_points, &cells) + motion_log);
      }
    }
  }
  const double eta = LogSumExp(log_w);
  Eigen::Vector3d mu = Eigen::Vector3d::Zero();
  std::vector<double> w(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    w[k] = std::isfinite(eta) ? std::exp(log_w[k] - eta) : 1.0 / static_cast<double>(poses.size());
    mu += w[k] * Eigen::Vector3d(poses[k].x(), poses[k].y(), WrapAngle(poses[k].theta() - centre.theta()));
  }
  Eigen::Matrix3d cov =
      Eigen::Vector3d(std::pow(0.25 * options_.proposal_step, 2), std::pow(0.25 * options_.proposal_step, 2),
                      std::pow(0.25 * options_.proposal_angle, 2))
          .asDiagonal();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Eigen::Vector3d d =
        Eigen::Vector3d(poses[k].x(), poses[k].y(), WrapAngle(poses[k].theta() - centre.theta())) - mu;
    cov += w[k] * d * d.transpose();
  }
  const Eigen::Matrix3d l = cov.llt().matrixL();
  const Eigen::Vector3d n(random.Normal(), random.Normal(), random.Normal());
  const Eigen::Vector3d x = mu + l * n;
  p->pose = SE2d(x.x(), x.y(), WrapAngle(centre.theta() + x.z()));
  if (std::isfinite(eta)) p->log_weight += eta;
  inserter_.Insert(&p->map, (p->pose * laser).translation(), Transformed(p->pose, points));
  p->path = std::make_shared<const Node>(Node{p->pose, scan, std::move(p->path)});
}

void RbpfSlam2D::MaybeResample() {
  // A resampled particle shares its parent's map tiles and path.
  const double neff = SelectiveResample(&particles_, options_.resample_fraction,
                                        [this] { return RandomStream(options_.seed, ~steps_).Uniform(); });
  if (neff < 0) return;
  report_.min_effective = report_.resamplings == 0 ? neff : std::min(report_.min_effective, neff);
  ++report_.resamplings;
}

std::vector<double> RbpfSlam2D::weights() const {
  std::vector<double> log_w;
  for (const Particle& p : particles_) log_w.push_back(p.log_weight);
  return NormalizedFromLogs(log_w);
}

int RbpfSlam2D::best_particle() const {
  int best = 0;
  for (std::size_t i = 1; i < particles_.size(); ++i) {
    if (particles_[i].log_weight > particles_[static_cast<std::size_t>(best)].log_weight) best = static_cast<int>(i);
  }
  return best;
}

int RbpfSlam2D::ParticleIndex(int particle) const {
  if (particle < 0) return best_particle();
  if (particle >= particle_count()) {
    throw InvalidArgument("RbpfSlam2D: no particle " + std::to_string(particle) + " (there are " +
                          std::to_string(particle_count()) + "; -1 for the heaviest)");
  }
  return particle;
}

std::vector<StampedPose2> RbpfSlam2D::Trajectory(int particle) const {
  particle = ParticleIndex(particle);
  const Particle& p = particles_.at(static_cast<std::size_t>(particle));
  std::vector<SE2d> at(stamps_.size());
  for (const Node* n = p.path.get(); n != nullptr; n = n->parent.get()) at[static_cast<std::size_t>(n->scan)] = n->pose;
  std::vector<StampedPose2> out;
  out.reserve(stamps_.size());
  for (std::size_t i = 0; i < stamps_.size(); ++i) {
    out.push_back(StampedPose2{stamps_[i], at[static_cast<std::size_t>(processed_before_[i])] * since_processed_[i]});
  }
  return out;
}

ProbabilityGrid RbpfSlam2D::Map(int particle) const {
  particle = ParticleIndex(particle);
  return particles_.at(static_cast<std::size_t>(particle)).map.ToGrid();
}

const RbpfSlamReport& RbpfSlam2D::report() const {
  std::vector<const void*> tiles;
  for (const Particle& p : particles_) p.map.TileAddresses(&tiles);
  std::sort(tiles.begin(), tiles.end());
  report_.distinct_tiles = static_cast<std::size_t>(std::unique(tiles.begin(), tiles.end()) - tiles.begin());
  report_.tile_bytes = report_.distinct_tiles * TiledProbabilityGrid::kTileBytes;
  return report_;
}

}  // namespace lidar
}  // namespace tether
