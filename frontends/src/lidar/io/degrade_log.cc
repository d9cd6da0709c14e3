#include "tether/frontends/lidar/io/degrade_log.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <ostream>
#include <sstream>
#include <vector>

#include "tether/core/error.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace lidar {

namespace {

bool Fail(std::string* why, const std::string& what) {
  if (why != nullptr) *why = what;
  return false;
}

bool Share(double v) { return v >= 0 && v <= 1; }

// The random streams of scan i: its noise and its drops.
constexpr std::uint64_t kNoiseStream = 0;
constexpr std::uint64_t kDropStream = 1;
std::uint64_t StreamOf(std::size_t scan, std::uint64_t which) { return 2 * static_cast<std::uint64_t>(scan) + which; }
// The odometry drift's streams, apart from the others (so adding drift leaves the noise and the
// drops of a seed as they were).
std::uint64_t DriftStreamOf(std::size_t scan) { return (std::uint64_t{1} << 62) + static_cast<std::uint64_t>(scan); }

// The smallest float at or above `range_max` (infinity beyond the floats).
float NoReturn(double range_max) {
  if (!(range_max <= std::numeric_limits<float>::max())) return std::numeric_limits<float>::infinity();
  float f = static_cast<float>(range_max);
  if (static_cast<double>(f) < range_max) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// Beam j of `beams` over the field of the scan's n beams takes the nearest original beam.
void Resample(int beams, LaserScan* s) {
  const std::size_t n = s->ranges.size();
  const std::size_t m = static_cast<std::size_t>(beams);
  if (n < 2 || m == n) return;
  const double span = static_cast<double>(n - 1);
  std::vector<float> r(m);
  for (std::size_t j = 0; j < m; ++j) {
    const double at = static_cast<double>(j) * span / static_cast<double>(m - 1);
    r[j] = s->ranges[std::min(n - 1, static_cast<std::size_t>(std::lround(at)))];
  }
  s->angle_increment = s->angle_increment * span / static_cast<double>(m - 1);
  s->ranges = std::move(r);
}

void Degrade(const DegradeOptions& o, std::size_t index, LaserScan* s) {
  if (o.beams > 0) Resample(o.beams, s);
  if (o.max_range > 0 && o.max_range < s->range_max) {
    s->range_max = o.max_range;
    for (float& r : s->ranges) {
      if (std::isfinite(r) && r >= s->range_max) r = NoReturn(s->range_max);
    }
  }
  if (o.noise_sigma > 0) {
    RandomStream noise(o.seed, StreamOf(index, kNoiseStream));
    for (std::size_t i = 0; i < s->ranges.size(); ++i) {
      if (!s->Valid(i)) continue;
      const double r = std::max(s->range_min, s->ranges[i] + o.noise_sigma * noise.Normal());
      s->ranges[i] = r < s->range_max ? static_cast<float>(r) : NoReturn(s->range_max);
    }
  }
  if (o.drop_fraction > 0) {
    RandomStream drops(o.seed, StreamOf(index, kDropStream));
    for (std::size_t i = 0; i < s->ranges.size(); ++i) {
      if (!s->Valid(i) || !drops.Chance(o.drop_fraction)) continue;
      s->ranges[i] = drops.Chance(o.error_share) ? std::numeric_limits<float>::quiet_NaN() : NoReturn(s->range_max);
    }
  }
  if (o.drop_odometry) {
    s->odometry = SE2<double>();
    s->odometry_origin = OdometryOrigin::kNone;
  }
}

// "%.17g" of v (or "%.9g" for a float's range): what strtod reads back as the same number.
// A number that is not finite (a pose composed out of range) cannot be read back: refused.
void Number(std::ostream& out, double v, int digits = 17) {
  if (!std::isfinite(v)) {
    throw InvalidArgument("WriteCarmenLog: a number that is not finite (" + std::to_string(v) +
                          "; a pose or angle out of range) cannot be written to a CARMEN log");
  }
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
  out << ' ' << buffer;
}

void Pose(std::ostream& out, const SE2<double>& p) {
  Number(out, p.x());
  Number(out, p.y());
  Number(out, p.theta());
}

// laser_type start_angle fov angular_resolution max_range accuracy remission_mode n r1..rn 0.
void LaserFields(std::ostream& out, const LaserScan& s) {
  out << " 0";
  Number(out, s.angle_min);
  Number(out, s.angle_increment * static_cast<double>(s.ranges.size() > 0 ? s.ranges.size() - 1 : 0));
  Number(out, s.angle_increment);
  Number(out, s.range_max);
  out << " 0 0 " << s.ranges.size();
  // An invalid beam as the smallest float not below the maximum range (the reader keeps ranges
  // as floats: the maximum's nearest float may lie below it and read back valid); beyond the
  // floats, the maximum itself (it reads back as an infinite float).
  const float none = NoReturn(s.range_max);
  for (std::size_t i = 0; i < s.ranges.size(); ++i) {
    if (s.Valid(i)) {
      Number(out, s.ranges[i], 9);
    } else if (std::isfinite(none)) {
      Number(out, none, 9);
    } else {
      Number(out, s.range_max);
    }
  }
  out << " 0";  // no remissions
}

// Chains the kept scans' odometry steps again, each perturbed (DegradeOptions' odometry noise).
// `indices` are the kept scans' indices in the source log (their streams).
void DriftOdometry(const DegradeOptions& o, const std::vector<std::size_t>& indices, std::vector<LaserScan>* scans) {
  bool started = false;
  SE2<double> true_before, drifted_before;
  for (std::size_t k = 0; k < scans->size(); ++k) {
    LaserScan& s = (*scans)[k];
    if (s.odometry_origin == OdometryOrigin::kNone) continue;
    const SE2<double> truth = s.odometry;
    if (started) {
      const SE2<double> step = true_before.Inverse() * truth;
      const double length = step.translation().norm();
      RandomStream noise(o.seed, DriftStreamOf(indices[k]));
      const double sigma_t = o.odometry_translation_noise * length;
      const double sigma_r =
          o.odometry_rotation_noise * std::abs(step.theta()) + o.odometry_rotation_per_metre * length;
      const double dx = sigma_t * noise.Normal();
      const double dy = sigma_t * noise.Normal();
      const double dtheta = sigma_r * noise.Normal();
      const SE2<double> drifted_step(step.x() + dx, step.y() + dy, step.theta() + dtheta);
      s.odometry = drifted_before * drifted_step;
    }
    started = true;
    true_before = truth;
    drifted_before = s.odometry;
  }
}

}  // namespace

bool DegradeOptions::DriftsOdometry() const {
  return odometry_translation_noise > 0 || odometry_rotation_noise > 0 || odometry_rotation_per_metre > 0;
}

bool DegradeOptions::IsValid(std::string* why) const {
  if (beams < 0 || beams == 1) return Fail(why, "beams must be 0 (keep the scans') or at least 2");
  if (!(max_range >= 0) || !std::isfinite(max_range)) {
    return Fail(why, "max_range must be finite and not negative (0: keep the scans')");
  }
  if (!(noise_sigma >= 0) || !std::isfinite(noise_sigma))
    return Fail(why, "noise_sigma must be finite and not negative");
  if (!Share(drop_fraction)) return Fail(why, "drop_fraction must be in [0, 1]");
  if (!Share(error_share)) return Fail(why, "error_share must be in [0, 1]");
  if (keep_every < 1) return Fail(why, "keep_every must be at least 1 (1 keeps every scan)");
  if (!(kidnap_at >= 0) || !std::isfinite(kidnap_at) || !(kidnap_seconds >= 0) || !std::isfinite(kidnap_seconds)) {
    return Fail(why, "kidnap_at and kidnap_seconds must be finite and not negative (kidnap_seconds 0: no kidnap)");
  }
  if (!std::isfinite(kidnap_offset.x()) || !std::isfinite(kidnap_offset.y()) || !std::isfinite(kidnap_offset.theta())) {
    return Fail(why, "kidnap_offset must be finite");
  }
  for (const double v : {odometry_translation_noise, odometry_rotation_noise, odometry_rotation_per_metre}) {
    if (!(v >= 0) || !std::isfinite(v)) {
      return Fail(why,
                  "the odometry noise (translation, rotation, rotation per metre) must be finite and not negative");
    }
  }
  return true;
}

bool DegradePreset(const std::string& name, DegradeOptions* options) {
  if (name != "lds") return false;
  DegradeOptions o;
  o.seed = options->seed;
  o.beams = 360;
  o.max_range = 6.0;
  o.noise_sigma = 0.02;
  o.drop_fraction = 0.05;
  o.keep_every = 2;
  *options = o;
  return true;
}

std::string DegradePresetNames() { return "lds"; }

LidarLog DegradeLog(const LidarLog& log, const DegradeOptions& options, std::size_t* kidnap_scan) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("lidar degrade: " + why);
  if (options.first_scan >= log.scans.size()) {
    throw InvalidArgument("lidar degrade: the first scan kept (" + std::to_string(options.first_scan) +
                          ") is beyond the log's " + std::to_string(log.scans.size()) +
                          " scans; give a smaller first scan");
  }
  LidarLog out;
  out.path = log.path;
  out.format = log.format;
  const std::size_t step = static_cast<std::size_t>(options.keep_every);
  double first = INFINITY, last = -INFINITY;
  std::vector<std::size_t> indices;
  const double cut_from = log.scans[options.first_scan].stamp + options.kidnap_at;
  const double cut_to = cut_from + options.kidnap_seconds;
  std::size_t after_cut = SIZE_MAX;  // the first kept scan after the cut
  SE2<double> carried;               // the odometry after the cut in the logged odometry's terms
  for (std::size_t i = options.first_scan; i < log.scans.size(); i += step) {
    if (options.max_scans > 0 && out.scans.size() >= options.max_scans) break;
    LaserScan s = log.scans[i];
    if (options.Kidnaps()) {
      if (s.stamp >= cut_from && s.stamp < cut_to) continue;
      if (s.stamp >= cut_to && after_cut == SIZE_MAX) {
        after_cut = out.scans.size();
        // Continue from the last scan before the cut (or the first after it), then the offset.
        const SE2<double> before = out.scans.empty() ? s.odometry : out.scans.back().odometry;
        carried = before * options.kidnap_offset * s.odometry.Inverse();
      }
      if (after_cut != SIZE_MAX) {
        if (!options.kidnap_keep_odometry) s.odometry = carried * s.odometry;
        if (options.kidnap_close_gap) {
          s.stamp -= options.kidnap_seconds;
          s.logger_stamp -= options.kidnap_seconds;
        }
      }
    }
    indices.push_back(i);
    Degrade(options, i, &s);
    first = std::min(first, s.stamp);
    last = std::max(last, s.stamp);
    if (s.odometry_origin == OdometryOrigin::kClamped) ++out.clamped_odometry;
    out.scans.push_back(std::move(s));
  }
  if (kidnap_scan != nullptr) *kidnap_scan = std::min(after_cut, out.scans.size());
  if (options.drop_odometry) return out;
  if (options.DriftsOdometry()) DriftOdometry(options, indices, &out.scans);
  // The messages would be the logged odometry's, not the scans' (drifted, or carried across a
  // kidnap), or, with the stamps moved over a kidnap's cut, interpolate across it: dropped; each
  // scan carries its own.
  if (options.DriftsOdometry() || (options.Kidnaps() && (!options.kidnap_keep_odometry || options.kidnap_close_gap))) {
    return out;
  }
  // The messages within [first, last] and the nearest one outside on either side.
  const std::vector<StampedPose2>& track = log.odometry.Sorted();
  const auto begin =
      std::lower_bound(track.begin(), track.end(), first, [](const StampedPose2& p, double t) { return p.stamp < t; });
  const auto end =
      std::upper_bound(track.begin(), track.end(), last, [](double t, const StampedPose2& p) { return t < p.stamp; });
  const auto from = begin == track.begin() ? begin : begin - 1;
  const auto to = end == track.end() ? end : end + 1;
  for (auto it = from; it != to; ++it) out.odometry.Add(it->stamp, it->pose);
  return out;
}

void WriteCarmenLog(std::ostream& out, const LidarLog& log, bool with_odometry, const std::string& comment) {
  if (!comment.empty()) {
    std::istringstream lines(comment);
    std::string line;
    while (std::getline(lines, line)) out << "# " << line << "\n";
  }
  const std::vector<StampedPose2> none;
  const std::vector<StampedPose2>& track = with_odometry ? log.odometry.Sorted() : none;
  // ODOM lines carry a logger time too: the scans' offset between the two clocks.
  const double logger_offset = log.scans.empty() ? 0 : log.scans.front().logger_stamp - log.scans.front().stamp;
  std::size_t next = 0;
  const auto odom_until = [&](double stamp) {
    for (; next < track.size() && track[next].stamp <= stamp; ++next) {
      out << "ODOM";
      Pose(out, track[next].pose);
      out << " 0 0 0";  // tv rv accel
      Number(out, track[next].stamp);
      out << " tether";
      Number(out, track[next].stamp + logger_offset);
      out << "\n";
    }
  };
  for (const LaserScan& s : log.scans) {
    odom_until(s.stamp);
    if (with_odometry && s.odometry_origin != OdometryOrigin::kNone) {
      out << "ROBOTLASER1";
      LaserFields(out, s);
      Pose(out, s.odometry * s.laser_in_robot);
      Pose(out, s.odometry);
      out << " 0 0 0 0 0";  // tv rv forward_safety_dist side_safety_dist turn_axis
    } else {
      out << "RAWLASER1";
      LaserFields(out, s);
    }
    Number(out, s.stamp);
    out << " tether";
    Number(out, s.logger_stamp);
    out << "\n";
  }
  odom_until(INFINITY);
  if (!out) throw IoError("writing a CARMEN log failed (the stream is in error)");
}

}  // namespace lidar
}  // namespace tether
