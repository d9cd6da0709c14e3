#include "tether/tools/lidar_degrade.h"

#include <cmath>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/degrade_log.h"
#include "tether/frontends/lidar/lidar_log.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

// The options the command asks for: the preset's, then each option given.
bool Options(const LidarDegradeCommand& cmd, lidar::DegradeOptions* o, std::ostream& err) {
  const char* usage = "tether lidar-degrade: ";
  if (!cmd.preset.empty() && !lidar::DegradePreset(cmd.preset, o)) {
    err << usage << "--preset takes " << lidar::DegradePresetNames() << " (got '" << cmd.preset << "')\n";
    return false;
  }
  if (cmd.beams) o->beams = *cmd.beams;
  if (cmd.max_range) o->max_range = *cmd.max_range;
  if (cmd.noise) o->noise_sigma = *cmd.noise;
  if (cmd.drop) o->drop_fraction = *cmd.drop;
  if (cmd.error_share) o->error_share = *cmd.error_share;
  if (cmd.keep_every) o->keep_every = *cmd.keep_every;
  if (cmd.first_scan) o->first_scan = *cmd.first_scan;
  if (cmd.max_scans) o->max_scans = *cmd.max_scans;
  if (cmd.seed) o->seed = *cmd.seed;
  if (cmd.no_odometry) o->drop_odometry = true;
  std::string why;
  if (!o->IsValid(&why)) {
    err << usage << why << " (--beams, --max-range, --noise, --drop, --error-share, --keep-every)\n";
    return false;
  }
  return true;
}

// What was done, for the log's header and the report.
std::string Describe(const LidarDegradeCommand& cmd, const lidar::DegradeOptions& o) {
  std::ostringstream s;
  s << "degraded from " << cmd.input << " by tether lidar-degrade";
  if (!cmd.preset.empty()) s << " --preset " << cmd.preset;
  s << ": beams " << (o.beams > 0 ? std::to_string(o.beams) : std::string("kept")) << ", max range ";
  if (o.max_range > 0) {
    s << o.max_range << " m";
  } else {
    s << "kept";
  }
  s << ", noise " << o.noise_sigma << " m, drop " << o.drop_fraction << " (error share " << o.error_share
    << "), keep every " << o.keep_every << ", first scan " << o.first_scan << ", max scans " << o.max_scans
    << ", odometry " << (o.drop_odometry ? "dropped" : "kept") << ", seed " << o.seed;
  return s.str();
}

}  // namespace

int RunLidarDegrade(const LidarDegradeCommand& cmd, std::ostream& out, std::ostream& err) {
  const char* usage = "tether lidar-degrade: ";
  lidar::DegradeOptions options;
  if (!Options(cmd, &options, err)) return kExitUsage;
  lidar::LidarReadOptions read;
  if (!lidar::FromString(cmd.odometry, &read.odometry)) {
    err << usage << "--odometry takes " << lidar::OdometrySourceNames() << " (got '" << cmd.odometry << "')\n";
    return kExitUsage;
  }
  read.scan_topic = cmd.scan_topic;
  read.odom_topic = cmd.odom_topic;
  OutputSet outputs;
  OutputFile* log_file = nullptr;
  const int rc = CheckOutputs(
      "lidar-degrade", outputs,
      [&] {
        outputs.AddInput(cmd.input, "log");
        log_file = &outputs.Add(cmd.output, "degraded log");
      },
      err);
  if (rc != 0) return rc;
  try {
    const lidar::LidarLog log = lidar::ReadLidarLog(cmd.input, read);
    std::size_t beams = 0;
    for (const lidar::LaserScan& s : log.scans) beams += s.ranges.size();
    out << "read " << cmd.input << ": " << log.scans.size() << " scans (" << lidar::ToString(log.format) << ", "
        << beams / log.scans.size() << " beams on average), " << log.odometry.size() << " odometry messages\n";
    const lidar::LidarLog degraded = lidar::DegradeLog(log, options);
    const std::string what = Describe(cmd, options);
    const bool with_odometry = !options.drop_odometry;
    bool offset_lost = false;
    std::size_t valid = 0, total = 0;
    for (const lidar::LaserScan& s : degraded.scans) {
      const bool raw = !with_odometry || s.odometry_origin == lidar::OdometryOrigin::kNone;
      offset_lost =
          offset_lost || (raw && (s.laser_in_robot.translation().norm() > 0 || s.laser_in_robot.theta() != 0));
      valid += s.ValidCount();
      total += s.ranges.size();
    }
    try {
      log_file->Stage([&](std::ostream& s) { lidar::WriteCarmenLog(s, degraded, with_odometry, what); });
      outputs.CommitAll();
    } catch (const IoError& e) {
      err << "error: " << e.what() << "; nothing was written\n";
      return kExitWriteFailed;
    }
    out << "wrote " << cmd.output << ": " << degraded.scans.size() << " scans, "
        << (with_odometry ? std::to_string(degraded.odometry.size()) + " odometry messages" : "no odometry") << ", "
        << (total > 0 ? 100.0 * static_cast<double>(valid) / static_cast<double>(total) : 0.0) << "% valid beams\n"
        << what << "\n";
    if (offset_lost) {
      err << "note: RAWLASER1 lines carry no laser pose: the laser's pose on the robot of the scans without odometry "
             "is not kept (the written scans are the laser's; lidar-eval's --pose-offset scores them as the robot's)\n";
    }
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const ParseError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const InvalidArgument& e) {
    err << usage << e.what() << "\n";
    return kExitUsage;
  }
  return 0;
}

}  // namespace tether
