#pragma once
// Unseen laser logs from the ones we have: a log degraded as a cheaper scanner or a poorer
// robot would record it (fewer beams, shorter range, noisier ranges, missing returns, a lower
// scan rate, no odometry), deterministic for a seed, and written back as a CARMEN log.
//
//   tether::lidar::DegradeOptions o;
//   tether::lidar::DegradePreset("lds", &o);  // a low-cost 360-degree scanner
//   o.seed = 7;
//   const tether::lidar::LidarLog worse = tether::lidar::DegradeLog(log, o);
//   tether::lidar::WriteCarmenLog(file, worse, /*with_odometry=*/!o.drop_odometry);
//
// docs/lidar.md, "Degraded logs", has the details and the `tether lidar-degrade` command.
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <string>

#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

/// How DegradeLog changes a log. The defaults change nothing.
struct DegradeOptions {
  /// Resample every scan to this many beams over its field of view (the first and the last
  /// beam stay on its edges; each new beam takes the range of the nearest original beam, so
  /// more beams than the scan has repeat ranges). 0 keeps the scan's beams; else at least 2.
  int beams = 0;
  /// Metres: the scans' maximum range becomes at most this; beams at or beyond it become no
  /// return. 0 keeps the scans' own.
  double max_range = 0;
  /// Metres: Gaussian noise of this standard deviation added to every valid range (a range
  /// pushed below the scan's minimum is set to the minimum; one pushed to the maximum or beyond
  /// becomes no return).
  double noise_sigma = 0;
  /// The share of valid beams (after the noise) made invalid, each independently, in [0, 1].
  double drop_fraction = 0;
  /// Of the dropped beams, the share made an error reading (NaN in memory) rather than no
  /// return (the scan's maximum range), in [0, 1]. A CARMEN log has no NaN: both are written as
  /// the maximum range.
  double error_share = 0.5;
  /// Keep every k-th scan (1: all, 2: every other one dropped), from first_scan.
  int keep_every = 1;
  /// Drop every scan's odometry (identity, OdometryOrigin::kNone) and the odometry messages.
  bool drop_odometry = false;
  /// Odometry drift, as a poorer robot's wheels would give it: each kept scan's odometry step
  /// from the kept scan before is perturbed by Gaussian noise and the steps are chained again,
  /// so the errors accumulate. Standard deviations: translation (each axis of the step)
  /// odometry_translation_noise x the step's length; rotation odometry_rotation_noise x the
  /// step's turn + odometry_rotation_per_metre x its length (radians per metre). The scans keep
  /// their odometry origin; the odometry messages are dropped where any of the three is set
  /// (each scan carries its own, and `interpolated` odometry would not be the drifted one).
  /// Made for logs whose poses are a reference (e.g. the corrected logs): the reference stays
  /// as the truth, the drifted odometry is what the front-end sees.
  double odometry_translation_noise = 0;
  double odometry_rotation_noise = 0;
  double odometry_rotation_per_metre = 0;
  /// A kidnap (the thesis's section 5.2): the scans stamped within [kidnap_at, kidnap_at +
  /// kidnap_seconds) seconds after the first kept scan are cut out, with the odometry messages.
  /// kidnap_seconds 0: no cut. What the scans after the cut keep:
  /// - kidnap_close_gap: their stamps (and logger stamps) moved back by kidnap_seconds, so that
  ///   the stamps run on uniformly across the cut (a detector cannot see the time gap);
  /// - kidnap_keep_odometry false (the robot was carried): their odometry continues from the
  ///   last scan before the cut, moved by kidnap_offset (the odometry saw nothing of the move, or
  ///   a jump that has nothing to do with it), and the odometry messages are dropped (each scan
  ///   carries its own); true: the odometry as logged (it saw the move: a gap in the scans only).
  /// DegradeLog gives the scan where the kidnap happened.
  double kidnap_at = 0;
  double kidnap_seconds = 0;
  bool kidnap_close_gap = false;
  bool kidnap_keep_odometry = false;
  SE2<double> kidnap_offset;
  /// The first scan kept (an index into the log's scans, in their order).
  std::size_t first_scan = 0;
  /// At most this many scans kept (0: all).
  std::size_t max_scans = 0;
  /// The seed of the noise and of the drops. Each scan draws from streams of its own (by its
  /// index in the log), so cropping or thinning the log leaves the other scans' draws as they were.
  std::uint64_t seed = 1;

  /// True where any odometry noise is set.
  bool DriftsOdometry() const;
  /// True where a kidnap is cut (kidnap_seconds above 0).
  bool Kidnaps() const { return kidnap_seconds > 0; }
  /// False (and why) for beams 1 or negative, a negative or non-finite range, sigma or odometry
  /// noise, a fraction or share outside [0, 1], keep_every below 1, a kidnap time or length that
  /// is negative or not finite, a kidnap offset that is not finite.
  bool IsValid(std::string* why) const;
};

/// Sets *options to a named preset (all other fields to their defaults, the seed kept); false
/// for an unknown name. "lds": a low-cost 360-degree scanner, 360 beams, 6 m, 0.02 m noise, 5%
/// of the beams dropped, every other scan kept (a 5 Hz scanner on a 10 Hz log).
bool DegradePreset(const std::string& name, DegradeOptions* options);
/// "lds" (the presets' names, for messages).
std::string DegradePresetNames();

/// The degraded log (see DegradeOptions). The odometry messages kept are those within the kept
/// scans' time span and the nearest one on either side (so interpolation gives the same
/// odometry); scans keep their source_index. `kidnap_scan`, where given, gets the index (from 0)
/// in the degraded log of the first scan after the kidnap's cut (the scan a detector should
/// stop at), or the number of scans where there is no kidnap or no scan after it. Throws
/// InvalidArgument where the options are not
/// valid or first_scan is beyond the log's scans.
LidarLog DegradeLog(const LidarLog& log, const DegradeOptions& options, std::size_t* kidnap_scan = nullptr);

/// Writes `log` as a CARMEN log that ReadCarmenLog reads back as the same scans:
/// - with_odometry: the odometry messages as ODOM lines (in time order, each before the first
///   scan not older than it), and each scan with odometry (odometry_origin not kNone) as a
///   ROBOTLASER1 line, which carries the robot's odometry pose and the laser's, so that both
///   the odometry and laser_in_robot read back the same (as `scan-line` odometry);
/// - otherwise, and for scans without odometry: RAWLASER1 lines, which carry no pose, so the
///   laser's pose on the robot is not kept (it reads back as the identity).
/// Angles, the maximum range, the stamps and poses are written with 17 significant digits,
/// ranges with 9 (a float reads back exactly); an invalid beam (not finite, below the minimum,
/// at or beyond the maximum) is written as the maximum range (rounded up to a float: ranges are
/// read as floats), so it reads back invalid. The
/// scan's minimum range is not written (CARMEN lines have none; it reads back as 0). `comment`
/// (may be empty) is written first as `#` lines. Throws InvalidArgument where a number to write
/// is not finite (the laser's pose composed out of range), IoError where the stream fails.
void WriteCarmenLog(std::ostream& out, const LidarLog& log, bool with_odometry, const std::string& comment = "");

}  // namespace lidar
}  // namespace tether
