#include "tether/tools/lidar_slam.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/laser_offset.h"
#include "tether/frontends/lidar/tum_trajectory.h"
#include "tether/tools/commands.h"
#include "tether/tools/trajectory_error.h"

namespace tether {

namespace {

std::string Fixed(double v, int digits) { return FormatFixed(v, digits); }

// What the log holds, said before the run: scans, beams, rate, range, odometry.
std::string Describe(const lidar::LidarLog& log, long n) {
  std::size_t beams_min = SIZE_MAX, beams_max = 0;
  double range_max = 0;
  long with_odometry = 0;
  for (long i = 0; i < n; ++i) {
    const lidar::LaserScan& s = log.scans[static_cast<std::size_t>(i)];
    beams_min = std::min(beams_min, s.ranges.size());
    beams_max = std::max(beams_max, s.ranges.size());
    range_max = std::max(range_max, s.range_max);
    with_odometry += s.odometry_origin != lidar::OdometryOrigin::kNone;
  }
  const double span = log.scans[static_cast<std::size_t>(n - 1)].stamp - log.scans[0].stamp;
  const lidar::LaserScan& first = log.scans[0];
  std::ostringstream s;
  s << log.path << ": " << n << " scans of " << beams_min;
  if (beams_max != beams_min) s << "-" << beams_max;
  s << " beams over "
    << Fixed(std::abs(first.angle_increment) * static_cast<double>(first.ranges.size() - 1) * 180 / M_PI, 0)
    << " degrees, maximum range " << Fixed(range_max, 1) << " m, "
    << (span > 0 ? Fixed(static_cast<double>(n - 1) / span, 1) + " scans/s over " + Fixed(span, 1) + " s"
                 : std::string("no time span"))
    << "; odometry: ";
  if (with_odometry == 0) {
    s << "none (scan-only: each scan predicted from the scans before it)";
  } else if (with_odometry < n) {
    s << "on " << with_odometry << " of " << n << " scans (the others scan-only)";
  } else {
    s << "yes";
  }
  const SE2d& laser = first.laser_in_robot;
  s << "; laser on the robot at (" << Fixed(laser.x(), 3) << " m, " << Fixed(laser.y(), 3) << " m, "
    << Fixed(laser.theta() * 180 / M_PI, 1) << " deg)";
  // The mounting the log's own turns in place say, where there are enough of them.
  if (with_odometry > 0) {
    const lidar::LaserOffsetEstimate e = lidar::EstimateLaserOffset(log);
    if (e.turns >= 10) {
      s << "; its turns in place put the laser at (" << Fixed(e.x, 3) << " m, " << Fixed(e.y, 3) << " m) (" << e.turns
        << " turns, residual " << Fixed(100 * e.rms, 1) << " cm against " << Fixed(100 * e.rms_at_log, 1)
        << " cm at the log's; --laser-offset to change it)";
    }
  }
  s << "\n";
  return s.str();
}

}  // namespace

int RunLidar(LidarCommand cmd, std::ostream& out, std::ostream& err) {
  cmd.options.pose_graph.search.angular_search_window = cmd.search_angle_deg * M_PI / 180;
  cmd.options.local.correlative.angular_search_window = cmd.correlative_angle_deg * M_PI / 180;
  cmd.options.local.limits = cmd.read.limits;
  if (!lidar::FromString(cmd.odometry, &cmd.read.odometry)) {
    err << "tether lidar: --odometry " << cmd.odometry << " is not one of " << lidar::OdometrySourceNames() << "\n";
    return kExitUsage;
  }
  if (cmd.max_scans < 0) {
    err << "tether lidar: --max-scans must not be negative\n";
    return kExitUsage;
  }
  if (!cmd.laser_offset.empty() && (cmd.laser_offset.size() != 3 || !std::isfinite(cmd.laser_offset[0]) ||
                                    !std::isfinite(cmd.laser_offset[1]) || !std::isfinite(cmd.laser_offset[2]))) {
    err << "tether lidar: --laser-offset takes three finite numbers x,y,theta (m, m, rad)\n";
    return kExitUsage;
  }
  std::string why;
  const lidar::PoseGraphOptions& pg = cmd.options.pose_graph;
  if ((pg.consecutive_translation_sigma > 0) != (pg.consecutive_rotation_sigma > 0)) {
    err << "tether lidar: --consecutive-sigma-t and --consecutive-sigma-r must both be positive, or both 0 (no "
           "consecutive constraints)\n";
    return kExitUsage;
  }
  if (!cmd.options.IsValid(&why) || !cmd.read.IsValid(&why)) {
    err << "tether lidar: " << why << "\n";
    return kExitUsage;
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool folder_existed = fs::exists(cmd.output_dir, ec);
  fs::create_directories(cmd.output_dir, ec);
  if (ec || !fs::is_directory(cmd.output_dir)) {
    err << "tether lidar: cannot make the output folder '" << cmd.output_dir << "' (" << ec.message()
        << "); give a folder that can be written\n";
    return kExitWriteFailed;
  }
  // A failed run leaves no folder it made behind (it is still empty then: outputs are
  // written only at the end, all or nothing).
  const auto fail = [&](int code) {
    std::error_code ignored;
    if (!folder_existed && fs::is_empty(cmd.output_dir, ignored)) fs::remove(cmd.output_dir, ignored);
    return code;
  };
  OutputSet outputs;
  std::vector<OutputFile*> files;
  const int rc = CheckOutputs(
      "lidar", outputs,
      [&] {
        outputs.AddInput(cmd.log);
        if (!cmd.ground_truth.empty()) outputs.AddInput(cmd.ground_truth, "ground truth");
        for (const lidar::LidarOutput& o : lidar::LidarSlam2D::OutputNames()) {
          files.push_back(&outputs.Add((fs::path(cmd.output_dir) / o.name).string(), o.what));
        }
      },
      err);
  if (rc != 0) return fail(rc);

  lidar::LidarLog log;
  try {
    log = lidar::ReadLidarLog(cmd.log, cmd.read);
  } catch (const Error& e) {  // IoError, ParseError; InvalidArgument where bags are not supported
    err << "error: " << e.what() << "\n";
    return fail(kExitBadInput);
  }
  if (log.format == lidar::LogFormat::kRosBag && log.odometry.empty() &&
      cmd.read.odometry != lidar::OdometrySource::kNone) {
    err << "warning: " << cmd.log << " has no message on the odometry topic " << cmd.read.odom_topic
        << ": mapping scan-only (check --odom-topic; --odometry none asks for scan-only and silences this)\n";
  }
  if (log.scans.empty()) {
    err << "error: " << cmd.log << " has no scans\n";
    return fail(kExitBadInput);
  }
  std::vector<lidar::StampedPose2> truth;
  if (!cmd.ground_truth.empty()) {
    try {
      truth = lidar::ReadTumFile(cmd.ground_truth);
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return fail(kExitBadInput);
    }
  }
  if (cmd.laser_offset.size() == 3) {
    const SE2d offset(cmd.laser_offset[0], cmd.laser_offset[1], cmd.laser_offset[2]);
    for (lidar::LaserScan& s : log.scans) s.laser_in_robot = offset;
  }
  const long n = cmd.max_scans > 0 ? std::min(static_cast<long>(log.scans.size()), cmd.max_scans)
                                   : static_cast<long>(log.scans.size());
  if (!cmd.quiet) out << Describe(log, n) << std::flush;

  lidar::LidarSlam2D slam(cmd.options);
  const auto t0 = std::chrono::steady_clock::now();
  try {
    slam.Run(log, n, cmd.quiet ? 0 : cmd.progress_every, [&](long done) {
      const double logged = log.scans[static_cast<std::size_t>(done - 1)].stamp - log.scans[0].stamp;
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      out << "scans " << done << " of " << n << ", submaps " << slam.pose_graph().submap_count() << ", loop closures "
          << slam.pose_graph().loop_closures().size() << " (searches " << slam.pose_graph().stats().searches
          << "), real-time factor " << Fixed(logged / std::max(seconds, 1e-9), 1) << "\n"
          << std::flush;
    });
  } catch (const Error& e) {  // a scan the mapping cannot take (a reader lets none through)
    err << "error: " << e.what() << "; nothing was written\n";  // names the log and line
    return fail(kExitBadInput);
  }
  try {
    const std::vector<lidar::LidarOutput> written = slam.Outputs();
    for (std::size_t i = 0; i < written.size(); ++i) files[i]->Stage(written[i].bytes);
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return fail(kExitWriteFailed);
  }
  try {
    outputs.CommitAll();  // all or nothing; its message says what became of the files
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return fail(kExitWriteFailed);
  }
  out << slam.report().Summary(cmd.options.pose_graph.threads);
  if (!cmd.ground_truth.empty()) {
    // The poses whose stamps the truth has (within 1 microsecond), by index as Values keys.
    Values estimate, reference;
    const std::vector<lidar::StampedPose2> t = slam.Trajectory();
    std::size_t k = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      while (k < truth.size() && truth[k].stamp < t[i].stamp - 1e-6) ++k;
      if (k < truth.size() && std::abs(truth[k].stamp - t[i].stamp) <= 1e-6) {
        estimate.Insert(static_cast<Key>(i), t[i].pose);
        reference.Insert(static_cast<Key>(i), truth[k].pose);
      }
    }
    const TrajectoryError ate = AbsoluteTrajectoryError(estimate, reference);
    out << "against " << cmd.ground_truth << ": absolute trajectory error (rigid alignment) " << FormatMetres(ate.rmse)
        << " RMSE, max " << FormatMetres(ate.max) << " over " << ate.poses << " poses\n";
  }
  out << "wrote " << cmd.output_dir << "/{";
  const std::vector<lidar::LidarOutput> names = lidar::LidarSlam2D::OutputNames();
  for (std::size_t i = 0; i < names.size(); ++i) out << (i > 0 ? ", " : "") << names[i].name;
  out << "}\n";
  return 0;
}

}  // namespace tether
