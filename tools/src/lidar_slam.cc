#include "tether/tools/lidar_slam.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/core/trajectory_error.h"
#include "tether/frontends/lidar/io/laser_offset.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/sensor/body_mask.h"
#include "tether/frontends/lidar/sensor/sensor_preset.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"
#include "tether/tools/folder_outputs.h"

namespace tether {

namespace {

std::string Fixed(double v, int digits) { return FormatFixed(v, digits); }

// What the log holds, said before the run: scans, beams, rate, range, odometry.
std::string Describe(const lidar::LidarLog& log, const lidar::ScanStatistics& st) {
  const long n = st.scans;
  const lidar::LaserScan& first = log.scans[0];
  std::ostringstream s;
  s << log.path << ": " << n << " scans of " << st.beams_min;
  if (st.beams_max != st.beams_min) s << "-" << st.beams_max;
  s << " beams over " << Fixed(st.field_of_view * 180 / M_PI, 0) << " degrees, maximum range " << Fixed(st.max_range, 1)
    << " m, "
    << (st.span > 0 ? Fixed(st.rate, 1) + " scans/s over " + Fixed(st.span, 1) + " s" : std::string("no time span"))
    << "; odometry: ";
  const long with_odometry = st.with_odometry;
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
  if (!log.imu.empty()) {
    s << "IMU: " << log.imu.samples.size() << " messages, a heading for " << log.imu.scans_with_yaw << " of "
      << log.scans.size() << " scans; " << log.imu.bias_why
      << (with_odometry == n ? "; unused: every scan has odometry" : "; it turns the scans without odometry") << "\n";
  }
  return s.str();
}

}  // namespace

namespace {

// The flags of the option fields the options' IsValid names in its messages.
constexpr std::pair<const char*, const char*> kFieldFlags[] = {
    {"consecutive_translation_sigma", "--consecutive-sigma-t"},
    {"consecutive_rotation_sigma", "--consecutive-sigma-r"},
    {"local_translation_sigma", "--local-sigma-t"},
    {"local_rotation_sigma", "--local-sigma-r"},
    {"loop_translation_sigma", "--loop-sigma-t"},
    {"loop_rotation_sigma", "--loop-sigma-r"},
    {"local_huber_delta", "--local-huber"},
    {"huber_delta", "--huber"},
    {"min_score", "--min-score"},
    {"max_search_distance", "--max-search-distance"},
    {"search_voxel_size", "--search-voxel"},
    {"search_window_growth", "--search-window-growth"},
    {"max_search_window", "--max-search-window"},
    {"search_angle_growth", "--search-angle-growth"},
    {"max_search_angle", "--max-search-angle"},
    {"rival_ratio", "--rival-ratio"},
    {"confirm_translation", "--confirm-t"},
    {"confirm_rotation", "--confirm-r"},
    {"min_match_probability", "--min-match-probability"},
    {"still_distance", "--still-distance"},
    {"still_angle", "--still-angle"},
    {"scans_per_submap", "--scans-per-submap"},
    {"max_submap_travel", "--max-submap-travel"},
    {"search_every_metres", "--search-every-metres"},
    {"min_range", "--min-range"},
    {"imu_bias_seconds", "--imu-bias-seconds"},
    {"imu_rotation_weight", "--imu-rotation-weight"},
    {"kidnap filter_size", "--kidnap-filter"},
    {"kidnap threshold", "--kidnap-threshold"},
    {"kidnap max_overlap", "--kidnap-max-overlap"},
    {"kidnap relocate_window", "--kidnap-relocate-window"},
};

// The options a sensor preset sets, each with the flag that sets it too: where that flag was
// given, its value stays. Every field lidar::ForSensor changes from the defaults is here.
struct PresetField {
  const char* flag;
  void (*take)(const lidar::LidarSlamOptions& preset, LidarCommand* cmd);
};
constexpr PresetField kPresetFields[] = {
    {"--min-range",
     [](const lidar::LidarSlamOptions& p, LidarCommand* c) { c->options.mask.min_range = p.mask.min_range; }},
    {"--mask-angles",
     [](const lidar::LidarSlamOptions& p, LidarCommand* c) { c->options.mask.sectors = p.mask.sectors; }},
};

bool Given(const LidarCommand& cmd, const char* flag) {
  return std::find(cmd.given.begin(), cmd.given.end(), flag) != cmd.given.end();
}

// The command's own rules (the options' rules are checked once, by their IsValid); false after
// saying why.
bool ResolveLidarOptions(LidarCommand* cmd, std::ostream& err) {
  cmd->options.pose_graph.search.angular_search_window = cmd->search_angle_deg * M_PI / 180;
  cmd->options.local.correlative.angular_search_window = cmd->correlative_angle_deg * M_PI / 180;
  cmd->options.local.limits = cmd->read.limits;
  lidar::SensorClass sensor;
  if (!FromString(cmd->sensor, &sensor)) {
    err << "tether lidar: --sensor " << cmd->sensor << " is not one of " << EnumNameList<lidar::SensorClass>() << "\n";
    return false;
  }
  if (!cmd->mask_angles.empty()) {
    std::string why;
    if (!lidar::ParseAngleSectors(cmd->mask_angles, &cmd->options.mask.sectors, &why)) {
      err << "tether lidar: --mask-angles " << cmd->mask_angles << ": " << why << "\n";
      return false;
    }
  }
  if (!FromString(cmd->odometry, &cmd->read.odometry)) {
    err << "tether lidar: --odometry " << cmd->odometry << " is not one of " << EnumNameList<lidar::OdometrySource>()
        << "\n";
    return false;
  }
  const std::vector<double>& o = cmd->laser_offset;
  if (!o.empty() && (o.size() != 3 || !std::isfinite(o[0]) || !std::isfinite(o[1]) || !std::isfinite(o[2]))) {
    err << "tether lidar: --laser-offset takes three finite numbers x,y,theta (m, m, rad)\n";
    return false;
  }
  std::string why;
  if (!cmd->options.IsValid(&why) || !cmd->read.IsValid(&why)) {
    err << "tether lidar: " << WithFlags(why, kFieldFlags) << "\n";
    return false;
  }
  return true;
}

// The log (with --laser-offset applied) and the truth; kExitOk, or the exit code after saying
// why.
int ReadLidarInputs(const LidarCommand& cmd, lidar::LidarLog* log, std::vector<lidar::StampedPose2>* truth,
                    std::ostream& err) {
  try {
    *log = lidar::ReadLidarLog(cmd.log, cmd.read);
    if (!cmd.ground_truth.empty()) *truth = lidar::ReadTumFile(cmd.ground_truth);
  } catch (const Error& e) {  // IoError, ParseError; InvalidArgument where bags are not supported
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  if (log->format == lidar::LogFormat::kRosBag && log->odometry.empty() &&
      cmd.read.odometry != lidar::OdometrySource::kNone) {
    err << "warning: " << cmd.log << " has no message on the odometry topic " << cmd.read.odom_topic
        << ": mapping scan-only (check --odom-topic; --odometry none asks for scan-only and silences this)\n";
  }
  if (log->scans.empty()) {
    err << "error: " << cmd.log << " has no scans\n";
    return kExitBadInput;
  }
  if (cmd.laser_offset.size() == 3) {
    const SE2d offset(cmd.laser_offset[0], cmd.laser_offset[1], cmd.laser_offset[2]);
    for (lidar::LaserScan& s : log->scans) s.laser_in_robot = offset;
  }
  return kExitOk;
}

// Maps the first n scans, with progress lines; kExitOk or kExitBadInput after saying why.
int Map(const LidarCommand& cmd, const lidar::LidarLog& log, long n, lidar::LidarSlam2D* slam, std::ostream& out,
        std::ostream& err) {
  const auto t0 = std::chrono::steady_clock::now();
  try {
    slam->Run(log, n, cmd.quiet ? 0 : cmd.progress_every, [&](long done) {
      const double logged = log.scans[static_cast<std::size_t>(done - 1)].stamp - log.scans[0].stamp;
      const double seconds = SecondsSince(t0);
      out << "scans " << done << " of " << n << ", submaps " << slam->pose_graph().submap_count() << ", loop closures "
          << slam->pose_graph().loop_closures().size() << " (searches " << slam->pose_graph().stats().searches
          << "), real-time factor " << Fixed(logged / std::max(seconds, 1e-9), 1) << "\n"
          << std::flush;
    });
  } catch (const Error& e) {  // a scan the mapping cannot take (a reader lets none through)
    err << "error: " << e.what() << "; nothing was written\n";  // names the log and line
    return kExitBadInput;
  }
  return kExitOk;
}

}  // namespace

int RunLidar(LidarCommand cmd, std::ostream& out, std::ostream& err) {
  if (!ResolveLidarOptions(&cmd, err)) return kExitUsage;
  FolderOutputs outputs(cmd.output_dir);
  std::vector<std::pair<std::string, std::string>> inputs = {{cmd.log, ""}};
  if (!cmd.ground_truth.empty()) inputs.emplace_back(cmd.ground_truth, "ground truth");
  if (!cmd.continue_state.empty()) inputs.emplace_back(cmd.continue_state, "state");
  std::vector<lidar::LidarOutput> names = lidar::LidarSlam2D::OutputNames();
  if (cmd.save_state) names.push_back(lidar::LidarSlam2D::StateOutputName());
  if (const int rc = outputs.Prepare("lidar", inputs, names, err); rc != kExitOk) return rc;
  lidar::LidarLog log;
  std::vector<lidar::StampedPose2> truth;
  if (const int rc = ReadLidarInputs(cmd, &log, &truth, err); rc != kExitOk) return outputs.Fail(rc);
  const long n = cmd.max_scans > 0 ? std::min(static_cast<long>(log.scans.size()), cmd.max_scans)
                                   : static_cast<long>(log.scans.size());
  const lidar::ScanStatistics statistics = lidar::ComputeScanStatistics(log.scans, n);
  // The scanner's settings where the command line gave none.
  lidar::SensorChoice choice;
  FromString(cmd.sensor, &choice.sensor);  // checked by ResolveLidarOptions
  if (choice.sensor == lidar::SensorClass::kAuto) {
    choice = lidar::ChooseSensor(statistics);
  } else {
    choice.why = "given by --sensor";
  }
  const lidar::LidarSlamOptions preset = lidar::ForSensor(choice.sensor);
  for (const PresetField& f : kPresetFields) {
    if (!Given(cmd, f.flag)) f.take(preset, &cmd);
  }
  if (!ResolveLidarOptions(&cmd, err)) return outputs.Fail(kExitUsage);
  if (!cmd.quiet) {
    out << Describe(log, statistics) << "scanner: " << ToString(choice.sensor) << " (" << choice.why << "; "
        << lidar::SensorDescription(choice.sensor) << ")";
    const lidar::BodyMask& mask = cmd.options.mask;
    if (mask.empty()) {
      out << "; no body mask";
    } else {
      out << "; body mask: returns nearer than " << FormatDouble(mask.min_range) << " m";
      if (!mask.sectors.empty()) out << " and at " << lidar::FormatAngleSectors(mask.sectors) << " degrees";
    }
    out << "\n" << std::flush;
  }

  lidar::LidarSlam2D slam(cmd.options);
  if (!cmd.continue_state.empty()) {
    try {
      const lidar::LidarState state = lidar::ReadLidarState(cmd.continue_state);
      slam.Continue(state);
      if (!cmd.quiet) {
        out << "going on from " << cmd.continue_state << ": " << state.scans.size() << " scans, "
            << state.submaps.size() << " submaps, " << state.closures.size() << " loop closures\n";
      }
    } catch (const Error& e) {
      err << "error: " << e.what() << "; nothing was written\n";
      return outputs.Fail(kExitBadInput);
    }
  }
  if (const int rc = Map(cmd, log, n, &slam, out, err); rc != kExitOk) return outputs.Fail(rc);
  std::vector<lidar::LidarOutput> files = slam.Outputs();
  if (cmd.save_state) files.push_back(slam.StateOutput());
  if (const int rc = outputs.Write(files, err); rc != kExitOk) return outputs.Fail(rc);
  out << slam.report().Summary(cmd.options.pose_graph.threads);
  if (!cmd.ground_truth.empty()) {
    const TrajectoryError ate = lidar::StampedTrajectoryError(slam.Trajectory(), truth);
    out << "against " << cmd.ground_truth << ": absolute trajectory error (rigid alignment) " << FormatMetres(ate.rmse)
        << " RMSE, max " << FormatMetres(ate.max) << " over " << ate.poses << " poses\n";
  }
  out << "wrote " << FolderOutputs::List(cmd.output_dir, names) << "\n";
  return kExitOk;
}

namespace {

class LidarCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override {
    for (const CLI::Option* o : app_->get_options()) {
      if (o->count() > 0) cmd_.given.push_back(o->get_name());
    }
    return RunLidar(cmd_, out, err);
  }

 private:
  // An option with its default shown in --help.
  template <class T>
  void Option(const char* name, T& value, const char* help) {
    app_->add_option(name, value, help)->capture_default_str();
  }
  void AddMatchingOptions(CLI::App* sub);
  void AddKidnapOptions(CLI::App* sub);
  void AddSensorOptions(CLI::App* sub);
  LidarCommand cmd_;
};

void LidarCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "lidar", "2D LiDAR SLAM over a laser log (CARMEN or ROS 1 bag): trajectory, pose graph and occupancy map");
  sub->add_option("log", cmd_.log, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  AddPath(sub, "-o,--output", &cmd_.output_dir, "Output folder (made if missing)")->required();
  lidar::LocalSlamOptions& lo = cmd_.options.local;
  lidar::PoseGraphOptions& po = cmd_.options.pose_graph;
  sub->add_flag_function(
      "--no-loop-closure", [&po](std::int64_t) { po.loop_closure = false; },
      "Local SLAM and the pose graph without loop closures");
  Option("--threads", po.threads,
         "Background loop-closure search threads (default: the machine's cores; 0: "
         "inline; the result does not depend on it)");
  Option("--max-scans", cmd_.max_scans, "Only the first N scans (0: all)");
  Option("--scans-per-submap", lo.submaps.scans_per_submap, "Scans in a finished submap");
  Option("--max-submap-travel", lo.submaps.max_submap_travel,
         "A submap is also finished once the robot travelled this far over its scans [m] (0: by scans only)");
  Option("--resolution", lo.submaps.resolution, "Grid resolution [m]");
  Option("--search-every", po.search_every_n_scans, "Loop-closure search for every N-th scan");
  Option("--search-every-metres", po.search_every_metres,
         "Loop-closure search for a scan sooner where the robot travelled this far since the last searched [m] (0: "
         "by count only)");
  Option("--update-every", po.update_every_n_scans,
         "Scans per smoother update (in between, new scans follow local SLAM from the last estimate)");
  Option("--min-score", po.min_score, "Branch and bound's score threshold");
  Option("--local-sigma-t", po.local_translation_sigma, "Local constraints' translation sigma [m]");
  Option("--local-sigma-r", po.local_rotation_sigma, "Local constraints' rotation sigma [rad]");
  Option("--consecutive-sigma-t", po.consecutive_translation_sigma,
         "Consecutive scans' constraints (local SLAM's relative pose): translation sigma [m] (0: none)");
  Option("--consecutive-sigma-r", po.consecutive_rotation_sigma,
         "Consecutive scans' constraints: rotation sigma [rad] (0: none)");
  Option("--local-huber", po.local_huber_delta,
         "Huber loss on the local and consecutive constraints: delta on the whitened error (0: none)");
  Option("--loop-sigma-t", po.loop_translation_sigma, "Loop closures' translation sigma [m]");
  Option("--loop-sigma-r", po.loop_rotation_sigma, "Loop closures' rotation sigma [rad]");
  Option("--rival-ratio", po.rival_ratio,
         "Drop a loop closure where a candidate 0.3 m or 2 degrees away scores above this share of its "
         "score (0: keep them)");
  Option("--confirm-t", po.confirm_translation,
         "A match becomes a loop closure once a match of another scan to the same submap agrees with it "
         "through local SLAM's relative pose within this [m] and --confirm-r (0: every match is added)");
  Option("--confirm-r", po.confirm_rotation, "See --confirm-t [rad]");
  Option("--max-search-distance", po.max_search_distance,
         "Search a scan against the finished submaps whose origin lies this near it [m]");
  AddMatchingOptions(sub);
}

// Loop-closure search and local matching.
void LidarCli::AddMatchingOptions(CLI::App* sub) {
  lidar::LocalSlamOptions& lo = cmd_.options.local;
  lidar::PoseGraphOptions& po = cmd_.options.pose_graph;
  Option("--search-voxel", po.search_voxel_size,
         "Loop closures: branch and bound scores the scan's points thinned by a voxel filter of this edge "
         "[m] (0: the matching points)");
  Option("--search-window", po.search.linear_search_window,
         "Loop closures: branch and bound searches +- this far in x and y around the estimate [m]");
  Option("--search-window-growth", po.search_window_growth,
         "Loop closures: the window's half side grows by this many metres per metre between the scan and "
         "the submap in the graph (0: fixed)");
  Option("--max-search-window", po.max_search_window, "Loop closures: the window's half side grows up to this [m]");
  Option("--search-angle-growth", po.search_angle_growth,
         "Loop closures: the window's rotations grow by this many radians per metre between the scan and "
         "the submap in the graph (0: fixed)");
  Option("--max-search-angle", po.max_search_angle, "Loop closures: the window's rotations grow up to this [rad]");
  Option("--search-angle", cmd_.search_angle_deg,
         "Loop closures: branch and bound searches +- this many degrees around the estimate");
  Option("--huber", po.huber_delta, "Loop closures' Huber delta (on the whitened error)");
  Option("--match-translation-weight", lo.refiner.weights.translation,
         "Local matching: the scan-match factor's weight on the distance to the odometry's prediction "
         "[1/m]");
  Option("--match-rotation-weight", lo.refiner.weights.rotation,
         "Local matching: the scan-match factor's weight on the turn from the odometry's prediction [1/rad]");
  Option("--correlative-translation-weight", lo.correlative.translation_delta_cost_weight,
         "Local matching: the correlative search's preference for the prediction's translation [1/m]");
  Option("--correlative-rotation-weight", lo.correlative.rotation_delta_cost_weight,
         "Local matching: the correlative search's preference for the prediction's heading [1/rad]");
  Option("--correlative-angle", cmd_.correlative_angle_deg,
         "Local matching: the correlative search's rotations, +- this many degrees around the prediction");
  Option("--min-match-probability", lo.min_match_probability,
         "Local matching: a scan whose matched points read a lower mean probability in the submap takes "
         "the prediction (0: always trust the match)");
  Option("--still-distance", lo.still_distance,
         "Local matching: where the odometry moved less than this [m] and turned less than --still-angle "
         "since the scan before, the scan keeps the pose before, unmatched (0: always match)");
  Option("--still-angle", lo.still_angle, "Local matching: see --still-distance [rad]");
  Option("--weak-window", lo.weak_prediction_linear_window,
         "Scan-only scans (no odometry): a weak first match is searched again +- this far [m]");
  Option("--line-radius", lo.scan_to_scan_options.normal_radius,
         "Scan-only scans: scan-to-scan matching fits each point's line to its neighbours within this [m] "
         "(0: the line through the next point each way)");
  Option("--degenerate-information", lo.scan_to_scan_options.degenerate_information,
         "Scan-only scans: a direction of translation the scan-to-scan match sees less than this many "
         "pairs' worth of keeps the predicted motion, there and in the submap match (0: off; needs "
         "--line-radius)");
  AddKidnapOptions(sub);
  AddSensorOptions(sub);
}

// Kidnap detection (lidar::KidnapOptions).
void LidarCli::AddKidnapOptions(CLI::App* sub) {
  lidar::KidnapOptions& k = cmd_.options.local.kidnap;
  sub->add_flag_function(
      "--no-kidnap", [&k](std::int64_t) { k.detect = false; },
      "Do not act on a kidnap: the detector's signals are still written (kidnap.csv, kidnap.svg)");
  Option("--kidnap-filter", k.filter_size, "Kidnap detection: the match costs averaged (f_size)");
  Option("--kidnap-threshold", k.threshold,
         "Kidnap detection: the filtered match cost's rise over the last filtered value before it");
  Option("--kidnap-max-overlap", k.max_overlap,
         "Kidnap detection's independent signal: a scan breaks with the scan before where fewer of its points "
         "than this share lie near that scan's");
  Option("--kidnap-relocate-window", k.relocate_window,
         "Before acting on a kidnap, search the scan in the current submap within this distance [m] of the last "
         "pose before the break; where it fits as well as the scans before, go on from there (0: never)");
}

// The scanner, its mounting and body, the IMU, reading the log and the checks.
void LidarCli::AddSensorOptions(CLI::App* sub) {
  lidar::LocalSlamOptions& lo = cmd_.options.local;
  Option("--max-range", cmd_.read.limits.max_range, "Drop ranges beyond this [m] (0: the log's)");
  sub->add_option("--min-range", cmd_.options.mask.min_range,
                  "The robot's body: returns nearer than this are dropped before matching and mapping [m] (0: none; "
                  "default: the scanner's, lds 0.15, hokuyo 0.1, sick 0)");
  sub->add_option("--mask-angles", cmd_.mask_angles,
                  "The robot's body: returns at these angles of the laser are dropped, from:to counter-clockwise in "
                  "degrees, several separated by commas (e.g. 160:200 for the back)");
  Option("--sensor", cmd_.sensor,
         "The scanner's settings for every option not given: auto (by the log's maximum range: up to 16 m lds, "
         "up to 40 m hokuyo, beyond sick), lds (low-cost 360-degree), sick (SICK LMS-class: the benchmark logs') "
         "or hokuyo (UTM-30LX-class)");
  Option("--imu-topic", cmd_.read.imu_topic,
         "Bags: a sensor_msgs/Imu topic whose yaw rate turns the prediction of scans without odometry (empty: none)");
  Option("--imu-bias-seconds", cmd_.read.imu_bias_seconds,
         "The gyro's bias: the mean rate over the IMU's first this many seconds, where the robot stood still (0: "
         "none taken off)");
  Option("--imu-rotation-weight", lo.imu_rotation_weight,
         "Scan-to-scan matching's pull towards the IMU's turn [1/rad]");
  Option("--odometry", cmd_.odometry,
         "Where the odometry comes from: auto, scan-line, interpolated, or none (scan-only: every scan "
         "predicted from the scans before)");
  Option("--scan-topic", cmd_.read.scan_topic, "Bags: the sensor_msgs/LaserScan topic");
  Option("--odom-topic", cmd_.read.odom_topic, "Bags: the nav_msgs/Odometry topic");
  sub->add_option("--laser-offset", cmd_.laser_offset,
                  "The laser's pose on the robot, x,y,theta [m, m, rad], for every scan instead of the log's")
      ->delimiter(',')
      ->expected(3);
  sub->add_option("--ground-truth", cmd_.ground_truth,
                  "A true trajectory (TUM text, e.g. from tether simulate lidar --truth): print the absolute "
                  "trajectory error against it");
  Option("--self-check-every", cmd_.options.self_check.sample_every,
         "Self-check every N-th scan against the map made at other times (0: no check)");
  Option("--progress-every", cmd_.progress_every, "Scans between progress lines (0: none)");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No progress lines");
  sub->add_option("--continue", cmd_.continue_state,
                  "Go on from a saved state (DIR/state.tether of an earlier --save-state run): the log is a second "
                  "session of that map, joined to it where it recognises a place");
  sub->add_flag("--save-state", cmd_.save_state,
                "Also write state.tether: the scans, submaps, loop closures and map, for tether localize");
}

}  // namespace

std::unique_ptr<Command> MakeLidarCommand() { return std::make_unique<LidarCli>(); }

}  // namespace tether
