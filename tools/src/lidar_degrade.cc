#include "tether/tools/lidar_degrade.h"

#include <cmath>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/degrade_log.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

// The kidnap's options (--kidnap, --kidnap-offset, --kidnap-close-gap, --kidnap-keep-odometry).
bool KidnapOptions(const LidarDegradeCommand& cmd, lidar::DegradeOptions* o, std::ostream& err) {
  const char* usage = "tether lidar-degrade: ";
  if (cmd.kidnap.empty()) {
    if (!cmd.kidnap_offset.empty() || cmd.kidnap_close_gap || cmd.kidnap_keep_odometry) {
      err << usage << "--kidnap-offset, --kidnap-close-gap and --kidnap-keep-odometry need --kidnap AT,SECONDS\n";
      return false;
    }
    return true;
  }
  if (cmd.kidnap.size() != 2 || !(cmd.kidnap[1] > 0)) {
    err << usage << "--kidnap takes two numbers AT,SECONDS, the cut's length above 0\n";
    return false;
  }
  o->kidnap_at = cmd.kidnap[0];
  o->kidnap_seconds = cmd.kidnap[1];
  o->kidnap_close_gap = cmd.kidnap_close_gap;
  o->kidnap_keep_odometry = cmd.kidnap_keep_odometry;
  if (!cmd.kidnap_offset.empty()) {
    if (cmd.kidnap_offset.size() != 3 || cmd.kidnap_keep_odometry) {
      err << usage << "--kidnap-offset takes three numbers X,Y,THETA, and not with --kidnap-keep-odometry\n";
      return false;
    }
    o->kidnap_offset = SE2<double>(cmd.kidnap_offset[0], cmd.kidnap_offset[1], cmd.kidnap_offset[2]);
  }
  return true;
}

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
  if (!cmd.odometry_drift.empty()) {
    if (cmd.odometry_drift.size() != 3) {
      err << usage << "--odometry-drift takes three numbers T,R,RPM (got " << cmd.odometry_drift.size() << ")\n";
      return false;
    }
    o->odometry_translation_noise = cmd.odometry_drift[0];
    o->odometry_rotation_noise = cmd.odometry_drift[1];
    o->odometry_rotation_per_metre = cmd.odometry_drift[2];
    if (o->drop_odometry) {
      err << usage << "--odometry-drift and --no-odometry exclude each other (no odometry left to drift)\n";
      return false;
    }
  }
  if (!KidnapOptions(cmd, o, err)) return false;
  std::string why;
  if (!o->IsValid(&why)) {
    err << usage << why
        << " (--beams, --max-range, --noise, --drop, --error-share, --keep-every, --odometry-drift, --kidnap)\n";
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
    << ", odometry " << (o.drop_odometry ? "dropped" : "kept");
  if (o.DriftsOdometry()) {
    s << " with drift " << o.odometry_translation_noise << ", " << o.odometry_rotation_noise << ", "
      << o.odometry_rotation_per_metre << " rad/m";
  }
  if (o.Kidnaps()) {
    s << ", kidnap: " << o.kidnap_seconds << " s cut from " << o.kidnap_at << " s, "
      << (o.kidnap_close_gap ? "stamps closed over the gap" : "a gap in the stamps") << ", odometry "
      << (o.kidnap_keep_odometry
              ? "as logged"
              : "carried (offset " + FormatDouble(o.kidnap_offset.x()) + ", " + FormatDouble(o.kidnap_offset.y()) +
                    ", " + FormatDouble(o.kidnap_offset.theta()) + ")");
  }
  s << ", seed " << o.seed;
  return s.str();
}

}  // namespace

int RunLidarDegrade(const LidarDegradeCommand& cmd, std::ostream& out, std::ostream& err) {
  const char* usage = "tether lidar-degrade: ";
  lidar::DegradeOptions options;
  if (!Options(cmd, &options, err)) return kExitUsage;
  lidar::LidarReadOptions read;
  if (!lidar::FromString(cmd.odometry, &read.odometry)) {
    err << usage << "--odometry takes " << EnumNameList<lidar::OdometrySource>() << " (got '" << cmd.odometry << "')\n";
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
    std::size_t kidnap_scan = 0;
    const lidar::LidarLog degraded = lidar::DegradeLog(log, options, &kidnap_scan);
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
    if (options.Kidnaps()) {
      if (kidnap_scan < degraded.scans.size()) {
        out << "kidnap at scan " << kidnap_scan + 1 << " (t = " << FormatFixed(degraded.scans[kidnap_scan].stamp, 3)
            << " s): the first scan after the cut\n";
      } else {
        out << "kidnap: no scan comes after the cut\n";
      }
    }
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

namespace {

class LidarDegradeCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override {
    std::ostream none(nullptr);  // -q: the report goes nowhere
    return RunLidarDegrade(cmd_, quiet_ ? none : out, err);
  }

 private:
  LidarDegradeCommand cmd_;
  bool quiet_ = false;
};

void LidarDegradeCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "lidar-degrade", "Write a laser log degraded as a cheaper scanner would record it (CARMEN; docs/lidar.md)");
  sub->add_option("log", cmd_.input, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  sub->add_flag("-q,--quiet", quiet_, "Print nothing but errors");
  AddPath(sub, "-o,--output", &cmd_.output, "The degraded log (CARMEN text)")->required();
  sub->add_option("--preset", cmd_.preset, "lds: 360 beams, 6 m, 0.02 m noise, 5% drops, every other scan");
  sub->add_option("--beams", cmd_.beams, "Resample each scan to N beams over its field of view");
  sub->add_option("--max-range", cmd_.max_range, "Maximum range [m]: beams beyond become no return");
  sub->add_option("--noise", cmd_.noise, "Gaussian range noise sigma [m]");
  sub->add_option("--drop", cmd_.drop, "Share of valid beams dropped, in [0, 1]");
  sub->add_option("--error-share", cmd_.error_share, "Share of the dropped beams made errors (NaN in memory)");
  sub->add_option("--keep-every", cmd_.keep_every, "Keep every K-th scan (2: every other one)");
  sub->add_option("--first-scan", cmd_.first_scan, "The first scan kept (index, from 0)");
  sub->add_option("--max-scans", cmd_.max_scans, "At most N scans (0: all)");
  sub->add_option("--seed", cmd_.seed, "Random seed of the noise and the drops (default 1)");
  sub->add_flag("--no-odometry", cmd_.no_odometry, "Drop the odometry (RAWLASER1 lines, no ODOM lines)");
  sub->add_option("--odometry-drift", cmd_.odometry_drift,
                  "T,R,RPM: each odometry step perturbed (sigma T x length per axis, R x turn + RPM x length "
                  "[rad]) and chained again; for logs whose poses are a reference (docs/lidar.md)")
      ->delimiter(',');
  sub->add_option("--kidnap", cmd_.kidnap,
                  "AT,SECONDS: cut out the scans and odometry of SECONDS from AT seconds after the first scan, the "
                  "robot carried (its odometry after the cut continues from before it)")
      ->delimiter(',');
  sub->add_option("--kidnap-offset", cmd_.kidnap_offset,
                  "X,Y,THETA: the carried odometry jumps by this pose at the cut [m, m, rad]")
      ->delimiter(',');
  sub->add_flag("--kidnap-close-gap", cmd_.kidnap_close_gap,
                "Move the stamps after the cut back by its length: no gap in time");
  sub->add_flag("--kidnap-keep-odometry", cmd_.kidnap_keep_odometry,
                "Keep the logged odometry across the cut (it saw the move: a gap in the scans only)");
  sub->add_option("--odometry", cmd_.odometry, "Reading: auto, scan-line, interpolated or none")->capture_default_str();
  sub->add_option("--scan-topic", cmd_.scan_topic, "Bags: the sensor_msgs/LaserScan topic")->capture_default_str();
  sub->add_option("--odom-topic", cmd_.odom_topic, "Bags: the nav_msgs/Odometry topic")->capture_default_str();
}

}  // namespace

std::unique_ptr<Command> MakeLidarDegradeCommand() { return std::make_unique<LidarDegradeCli>(); }

}  // namespace tether
