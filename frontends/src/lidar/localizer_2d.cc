#include "tether/frontends/lidar/localizer_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"
#include "tether/frontends/lidar/sensor/voxel_filter.h"

namespace tether {
namespace lidar {

namespace {

const LocalizationOptions& Checked(const LocalizationOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("LocalizationOptions: " + why);
  return o;
}

// How the points (robot frame) at `pose` fit the grid: the share of them whose cell or a cell
// next to it is known, and the mean over those of the largest probability among the cell and its
// eight neighbours (0 where none). A cell's slack: a wall one or two cells thick is missed by a
// point 20 m away whose heading is off by a tenth of a degree, and the fit of a right pose
// should not depend on the scanner's reach.
struct Fit {
  double known = 0;
  double score = 0;
};
Fit FitOf(const ProbabilityGrid& grid, const SE2d& pose, const std::vector<Eigen::Vector2d>& points) {
  Fit f;
  if (points.empty()) return f;
  std::vector<ProbabilityGrid::Cell> cells;
  grid.CellsOf(pose, points, &cells);
  double sum = 0;
  long known = 0;
  for (const ProbabilityGrid::Cell& c : cells) {
    std::uint16_t best = ProbabilityGrid::kUnknownValue;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) best = std::max(best, grid.Value(c + ProbabilityGrid::Cell(dx, dy)));
    }
    if (best == ProbabilityGrid::kUnknownValue) continue;
    ++known;
    sum += grid.ValueToProbability(best);
  }
  f.known = static_cast<double>(known) / static_cast<double>(cells.size());
  f.score = known > 0 ? sum / static_cast<double>(known) : 0;
  return f;
}

bool Near(const SE2d& a, const SE2d& b, double translation, double rotation) {
  return (a.translation() - b.translation()).norm() <= translation &&
         std::abs(WrapAngle(a.theta() - b.theta())) <= rotation;
}

}  // namespace

LocalSlamOptions LocalizationOptions::DefaultLocalOptions() {
  LocalSlamOptions o;
  o.keep_submaps = 3;
  return o;
}

bool LocalizationOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  std::string inner;
  if (!local.IsValid(&inner)) return fail("local matching: " + inner);
  if (!mask.IsValid(&inner)) return fail("body mask: " + inner);
  if (!search.IsValid(&inner)) return fail("search: " + inner);
  if (!refine.IsValid(&inner)) return fail("refine: " + inner);
  if (keep_submaps < 1) return fail("keep_submaps must be at least 1");
  if (global_every_n_scans < 1) return fail("global_every_n_scans must be at least 1");
  if (!(global_min_score > 0 && global_min_score < 1)) return fail("global_min_score must lie in (0, 1)");
  if (!(global_rival_ratio >= 0 && global_rival_ratio <= 1)) return fail("global_rival_ratio must lie in [0, 1]");
  for (double v : {global_rival_distance, global_rival_angle, confirm_translation, confirm_rotation,
                   max_correction_translation, max_correction_rotation}) {
    if (!(std::isfinite(v) && v > 0)) {
      return fail(
          "global_rival_distance, global_rival_angle, confirm_translation, confirm_rotation and max_correction_* "
          "must be positive and finite");
    }
  }
  if (!(std::isfinite(global_angular_step) && global_angular_step > 0 && global_angular_step < 1)) {
    return fail("global_angular_step must lie in (0, 1) rad");
  }
  for (double v : {global_search_voxel_size, global_max_range, confirm_min_travel, confirm_min_turn}) {
    if (!(std::isfinite(v) && v >= 0)) {
      return fail(
          "global_search_voxel_size, global_max_range, confirm_min_travel and confirm_min_turn must be finite and "
          "not negative");
    }
  }
  if (confirm_max_scans < 1) return fail("confirm_max_scans must be at least 1");
  if (confirm_still_candidates < 0) return fail("confirm_still_candidates must not be negative (0: never)");
  if (!(track_min_score > 0 && track_min_score < 1)) return fail("track_min_score must lie in (0, 1)");
  if (!(min_known_share > 0 && min_known_share <= 1)) return fail("min_known_share must lie in (0, 1]");
  if (lost_after_scans < 1 || resume_after_scans < 1) {
    return fail("lost_after_scans and resume_after_scans must be at least 1");
  }
  if (has_initial_pose &&
      !(std::isfinite(initial_pose.x()) && std::isfinite(initial_pose.y()) && std::isfinite(initial_pose.theta()))) {
    return fail("initial_pose must be finite");
  }
  return true;
}

std::string LocalizationReport::Summary() const {
  std::ostringstream s;
  s << "localised " << localized << " of " << scans << " scans ("
    << (scans > 0 ? FormatFixed(100.0 * static_cast<double>(localized) / static_cast<double>(scans), 1) : "-") << "%), "
    << tracked << " fitted to the map, " << outside << " beyond it; ";
  if (first_fix_scan < 0) {
    s << "no fix";
  } else {
    s << "first fix at scan " << first_fix_scan + 1 << " (t = " << FormatFixed(first_fix_seconds, 1) << " s)";
  }
  s << "; " << fixes << " fixes, " << losses << " losses\n";
  s << "global localisation: " << global_searches << " searches (" << FormatFixed(global_seconds, 2) << " s), "
    << candidates << " candidates, " << ambiguous << " ambiguous\n";
  const double rt = localized_seconds > 0 ? logged_localized_seconds / localized_seconds : 0;
  s << "time " << FormatFixed(total_seconds, 2) << " s for " << FormatFixed(logged_seconds, 1) << " s of log";
  if (localized_seconds > 0) s << "; once localised " << FormatFixed(rt, 1) << "x real time";
  s << "\n";
  return s.str();
}

Localizer2D::Localizer2D(const LidarState& state, const LocalizationOptions& options)
    : options_(Checked(options)), map_(state.map) {
  if (map_ == nullptr) throw InvalidArgument("Localizer2D: the state has no map");
  ProbabilityGrid::Cell lo, hi;
  if (!map_->KnownBounds(&lo, &hi)) throw InvalidArgument("Localizer2D: the state's map knows no cell");
  const Eigen::Vector2d a = map_->CellCenter(lo), b = map_->CellCenter(hi);
  map_center_ = SE2d(0.5 * (a.x() + b.x()), 0.5 * (a.y() + b.y()), 0);
  map_half_side_ = 0.5 * std::max(b.x() - a.x(), b.y() - a.y()) + map_->resolution();
  matcher_ = std::make_unique<FastCorrelativeScanMatcher2D>(*map_, options_.search);
  LocalSlamOptions local = options_.local;
  local.keep_submaps = options_.keep_submaps;
  options_.local = local;
  local_ = std::make_unique<LocalSlam2D>(local);
}

Localizer2D::~Localizer2D() = default;

void Localizer2D::Lose() {
  if (mode_ != Mode::kGlobal) ++report_.losses;
  mode_ = Mode::kGlobal;
  candidates_.clear();
  misses_ = 0;
  streak_ = 0;
  since_global_ = 0;
  if (local_ == nullptr) local_ = std::make_unique<LocalSlam2D>(options_.local);
}

std::vector<Eigen::Vector2d> Localizer2D::MatchingPoints(const LaserScan& scan) const {
  std::vector<Eigen::Vector2d> points = ScanToPoints(scan, options_.local.limits);
  for (Eigen::Vector2d& p : points) p = scan.laser_in_robot * p;
  const double voxel = options_.local.matching_voxel_size;
  return voxel > 0 && !points.empty() ? VoxelFilter(points, voxel) : points;
}

bool Localizer2D::GlobalSearch(long scan, const SE2d& local, const std::vector<Eigen::Vector2d>& points,
                               LocalizedScan* out) {
  const auto t0 = std::chrono::steady_clock::now();
  out->global = true;
  ++report_.global_searches;
  std::vector<Eigen::Vector2d> near;
  for (const Eigen::Vector2d& p : points) {
    if (options_.global_max_range <= 0 || p.norm() <= options_.global_max_range) near.push_back(p);
  }
  const std::vector<Eigen::Vector2d> search =
      options_.global_search_voxel_size > 0 ? VoxelFilter(near, options_.global_search_voxel_size) : near;
  FastMatch m;
  if (!search.empty()) {
    m = matcher_->MatchChecked(map_center_, search, options_.global_min_score, options_.global_rival_distance,
                               options_.global_rival_angle, options_.global_rival_ratio, map_half_side_, M_PI,
                               options_.global_angular_step);
  }
  report_.global_seconds += SecondsSince(t0);
  if (!m.found) return false;
  if (m.ambiguous) {
    ++report_.ambiguous;
    return false;
  }
  SE2d pose = m.pose;
  const ScanRefinement r = RefineScanPose(map_, m.pose, m.pose, points, options_.refine);
  if (r.status == SolverStatus::kConverged || r.status == SolverStatus::kMaxIterations) pose = r.pose;
  ++report_.candidates;
  const Candidate c{scan, local, pose * local.Inverse()};
  // Confirmed by an earlier candidate from another view that places the frame alike; or, a
  // robot that stands still, by confirm_still_candidates alike from the one view.
  bool confirmed = false;
  int alike = 1;
  for (const Candidate& e : candidates_) {
    const SE2d moved = e.local.Inverse() * c.local;
    const bool other_view = moved.translation().norm() >= options_.confirm_min_travel ||
                            std::abs(moved.theta()) >= options_.confirm_min_turn;
    if (scan - e.scan > options_.confirm_max_scans ||
        !Near(e.placement * c.local, c.placement * c.local, options_.confirm_translation, options_.confirm_rotation)) {
      continue;
    }
    confirmed = confirmed || other_view;
    ++alike;
  }
  confirmed = confirmed || (options_.confirm_still_candidates > 0 && alike >= options_.confirm_still_candidates);
  candidates_.push_back(c);
  if (candidates_.size() > 64) candidates_.erase(candidates_.begin());
  if (!confirmed) return false;
  mode_ = Mode::kDeadReckoning;
  placement_ = c.placement;
  candidates_.clear();
  out->fix = true;
  ++report_.fixes;
  return true;
}

bool Localizer2D::Fits(const SE2d& predicted, const std::vector<Eigen::Vector2d>& points, LocalizedScan* out) const {
  out->pose = predicted;
  out->outside = false;
  if (points.empty()) return false;
  // Where the map does not know where most points fall (the robot beyond the mapped area),
  // there is nothing to fit: that is no sign of being lost.
  const Fit before = FitOf(*map_, predicted, points);
  out->score = before.score;
  if (before.known < options_.min_known_share) {
    out->outside = true;
    return false;
  }
  const ScanRefinement r = RefineScanPose(map_, predicted, predicted, points, options_.refine);
  if (r.status != SolverStatus::kConverged && r.status != SolverStatus::kMaxIterations) return false;
  if (!Near(r.pose, predicted, options_.max_correction_translation, options_.max_correction_rotation)) return false;
  const Fit after = FitOf(*map_, r.pose, points);
  if (after.known < options_.min_known_share || after.score < options_.track_min_score) return false;
  out->pose = r.pose;
  out->score = after.score;
  return true;
}

SE2d Localizer2D::Predict(const LaserScan& scan, const std::vector<Eigen::Vector2d>& points, bool* by_odometry) const {
  const bool odometry = scan.odometry_origin != OdometryOrigin::kNone && last_has_odometry_;
  *by_odometry = odometry;
  if (!odometry) return PredictByScans(points);
  // The odometry's motion, checked by a scan-to-scan match from it: where the two scans say the
  // robot moved otherwise (a wheel that slipped, a sign that flipped), the scans' motion.
  const SE2d motion = last_odometry_.Inverse() * scan.odometry;
  if (!options_.local.scan_to_scan || last_points_.empty() || points.empty()) return last_pose_ * motion;
  const ScanToScanMatch m = MatchScanToScan(last_points_, points, motion, options_.local.scan_to_scan_options);
  return last_pose_ * (m.ok ? m.motion : motion);
}

SE2d Localizer2D::PredictByScans(const std::vector<Eigen::Vector2d>& points) const {
  // The motion from the scan before by a scan-to-scan match from constant motion and from none,
  // the second taken where it pairs clearly more points (as local SLAM does).
  const SE2d motion = has_before_last_ ? before_last_pose_.Inverse() * last_pose_ : SE2d();
  if (!options_.local.scan_to_scan || last_points_.empty() || points.empty()) return last_pose_ * motion;
  const ScanToScanOptions& o = options_.local.scan_to_scan_options;
  const ScanToScanMatch moving = MatchScanToScan(last_points_, points, motion, o);
  const ScanToScanMatch still = MatchScanToScan(last_points_, points, SE2d(), o);
  const bool take_still = still.ok && (!moving.ok || still.pairs * 10 > moving.pairs * 11);
  const ScanToScanMatch& m = take_still ? still : moving;
  return last_pose_ * (m.ok ? m.motion : motion);
}

void Localizer2D::AddByLocalSlam(const LaserScan& scan, LocalizedScan* out) {
  LocalScanResult r = local_->AddScan(scan);
  if (r.kidnapped) {
    // Local SLAM cannot go on from where it was; neither can the fix.
    local_ = std::make_unique<LocalSlam2D>(options_.local);
    r = local_->AddScan(scan);
    Lose();
  }
  if (report_.scans == 0 && options_.has_initial_pose) {
    mode_ = Mode::kDeadReckoning;
    placement_ = options_.initial_pose * r.pose.Inverse();
    out->fix = true;
    ++report_.fixes;
  }
  if (mode_ == Mode::kGlobal && (since_global_ == 0 || since_global_ >= options_.global_every_n_scans) &&
      !r.matching.empty()) {
    since_global_ = 0;
    GlobalSearch(out->scan, r.pose, r.matching, out);
  }
  ++since_global_;
  if (mode_ != Mode::kDeadReckoning) return;
  out->localized = true;
  ++report_.dead_reckoned;
  out->tracked = Fits(placement_ * r.pose, r.matching, out);
  if (out->tracked) placement_ = out->pose * r.pose.Inverse();
  if (!out->outside) misses_ = out->tracked ? 0 : misses_ + 1;
  streak_ = out->tracked ? streak_ + 1 : 0;
  if (misses_ >= options_.lost_after_scans) {
    Lose();
    out->localized = false;
  } else if (streak_ >= options_.resume_after_scans) {
    mode_ = Mode::kTracking;  // the map tracks again; local SLAM rests
    local_.reset();
  }
}

LocalizedScan Localizer2D::AddScan(const LaserScan& input) {
  const std::string why = ScanProblem(input);
  if (!why.empty()) throw InvalidArgument("Localizer2D::AddScan: scan " + std::to_string(report_.scans) + ": " + why);
  const auto t0 = std::chrono::steady_clock::now();
  LaserScan scan = input;
  if (!options_.mask.empty()) ApplyBodyMask(options_.mask, &scan);
  LocalizedScan out;
  out.scan = report_.scans;
  out.stamp = scan.stamp;
  if (report_.scans == 0) first_stamp_ = scan.stamp;
  std::vector<Eigen::Vector2d> points = MatchingPoints(scan);
  if (mode_ == Mode::kTracking) {
    bool by_odometry = false;
    SE2d predicted = Predict(scan, points, &by_odometry);
    out.localized = true;
    out.tracked = Fits(predicted, points, &out);
    if (!out.tracked && by_odometry) {
      // The odometry can be wrong where the scans are not (a wheel that slipped, a sign that
      // flipped): the scans' own motion next, and where that fits neither, local SLAM from it.
      LocalizedScan by_scans = out;
      predicted = PredictByScans(points);
      if (Fits(predicted, points, &by_scans)) {
        out = by_scans;
        out.tracked = true;
      }
    }
    if (!out.tracked) {
      // Local SLAM carries the poses from the prediction on.
      local_ = std::make_unique<LocalSlam2D>(options_.local);
      const LocalScanResult r = local_->AddScan(scan);
      placement_ = predicted * r.pose.Inverse();
      mode_ = Mode::kDeadReckoning;
      misses_ = out.outside ? 0 : 1;
      streak_ = 0;
    }
  } else {
    AddByLocalSlam(scan, &out);
  }
  if (out.localized) {
    before_last_pose_ = last_pose_;
    has_before_last_ = has_last_;
    last_pose_ = out.pose;
    has_last_ = true;
  } else {
    has_last_ = has_before_last_ = false;
  }
  last_has_odometry_ = scan.odometry_origin != OdometryOrigin::kNone;
  last_odometry_ = scan.odometry;
  if (!points.empty()) last_points_ = std::move(points);
  if (out.fix && report_.first_fix_scan < 0) {
    report_.first_fix_scan = out.scan;
    report_.first_fix_seconds = scan.stamp - first_stamp_;
  }
  ++report_.scans;
  report_.localized += out.localized;
  report_.tracked += out.tracked;
  report_.outside += out.outside;
  const double seconds = SecondsSince(t0);
  report_.total_seconds += seconds;
  if (out.localized && last_localized_) {
    report_.localized_seconds += seconds;
    report_.logged_localized_seconds += scan.stamp - last_stamp_;
  }
  report_.logged_seconds = scan.stamp - first_stamp_;
  last_localized_ = out.localized;
  last_stamp_ = scan.stamp;
  return out;
}

void Localizer2D::Run(const LidarLog& log, long start_scan, long max_scans, int repeat, long progress_every,
                      const std::function<void(long)>& progress) {
  const long total = static_cast<long>(log.scans.size());
  const long from = std::clamp(start_scan, 0L, total);
  const long to = max_scans > 0 ? std::min(total, from + max_scans) : total;
  if (to <= from) return;
  const double span =
      log.scans[static_cast<std::size_t>(to - 1)].stamp - log.scans[static_cast<std::size_t>(from)].stamp;
  const double step = to - from > 1 ? span / static_cast<double>(to - from - 1) : 0.1;
  long done = 0;
  for (int pass = 0; pass < std::max(repeat, 1); ++pass) {
    for (long i = from; i < to; ++i) {
      LaserScan scan = log.scans[static_cast<std::size_t>(i)];
      scan.stamp += pass * (span + step);
      try {
        results_.push_back(AddScan(scan));
      } catch (const Error& e) {
        throw ParseError(ScanLocation(log, log.scans[static_cast<std::size_t>(i)]) + ": scan " + std::to_string(i) +
                         ": " + e.what());
      }
      ++done;
      if (progress && progress_every > 0 && done % progress_every == 0) progress(done);
    }
  }
}

std::vector<StampedPose2> Localizer2D::Trajectory() const {
  std::vector<StampedPose2> t;
  for (const LocalizedScan& r : results_) {
    if (r.localized) t.push_back(StampedPose2{r.stamp, r.pose});
  }
  return t;
}

std::vector<LidarOutput> Localizer2D::OutputNames() {
  return {{"poses.tum", "localised poses", ""},
          {"localization.csv", "every scan's result", ""},
          {"localization.png", "localisation picture", ""}};
}

std::string Localizer2D::Picture() const {
  // The saved map in grey; each localised scan's position a dot: blue where it fitted the map,
  // orange where local SLAM carried it; each fix a red cross.
  const OccupancyImage image = RenderOccupancy(*map_);
  std::vector<std::uint8_t> rgb(3 * image.pixels.size());
  for (std::size_t i = 0; i < image.pixels.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = image.pixels[i];
  const auto dot = [&](const Eigen::Vector2d& p, int radius, bool cross, std::uint8_t r, std::uint8_t g,
                       std::uint8_t b) {
    const int cx = static_cast<int>(std::floor((p.x() - image.origin.x()) / image.resolution));
    const int cy = image.height - 1 - static_cast<int>(std::floor((p.y() - image.origin.y()) / image.resolution));
    for (int dy = -radius; dy <= radius; ++dy) {
      for (int dx = -radius; dx <= radius; ++dx) {
        if (cross && std::abs(dx) != std::abs(dy)) continue;
        const int x = cx + dx, y = cy + dy;
        if (x < 0 || y < 0 || x >= image.width || y >= image.height) continue;
        const std::size_t k =
            3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x));
        rgb[k] = r;
        rgb[k + 1] = g;
        rgb[k + 2] = b;
      }
    }
  };
  for (const LocalizedScan& r : results_) {
    if (!r.localized || !r.pose.translation().allFinite()) continue;
    if (r.tracked) {
      dot(r.pose.translation(), 1, false, 30, 90, 230);
    } else {
      dot(r.pose.translation(), 1, false, 240, 140, 0);
    }
  }
  for (const LocalizedScan& r : results_) {
    if (r.fix && r.pose.translation().allFinite()) dot(r.pose.translation(), 5, true, 220, 0, 0);
  }
  return PngBytesRgb(image.width, image.height, rgb);
}

std::vector<LidarOutput> Localizer2D::Outputs() const {
  std::vector<LidarOutput> out = OutputNames();
  std::ostringstream tum;
  WriteTum(tum, Trajectory());
  out[0].bytes = tum.str();
  std::ostringstream csv;
  csv.precision(10);
  csv << "scan,stamp,localized,x,y,theta,tracked,outside,score,fix,global\n";
  for (const LocalizedScan& r : results_) {
    csv << r.scan + 1 << ',' << FormatFixed(r.stamp, 6) << ',' << r.localized << ',' << r.pose.x() << ',' << r.pose.y()
        << ',' << r.pose.theta() << ',' << r.tracked << ',' << r.outside << ',' << r.score << ',' << r.fix << ','
        << r.global << '\n';
  }
  out[1].bytes = csv.str();
  out[2].bytes = Picture();
  return out;
}

}  // namespace lidar
}  // namespace tether
