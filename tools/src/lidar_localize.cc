// `tether localize LOG --state STATE -o DIR`: a laser log localised in the saved map of an
// earlier `tether lidar --save-state` run (frontends/lidar/localizer_2d.h); this file only binds
// the flags, runs and prints.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/localizer_2d.h"
#include "tether/frontends/localization/mcl_localization_2d.h"
#include "tether/tools/command.h"
#include "tether/tools/folder_outputs.h"

namespace tether {

namespace {

struct LocalizeCommand {
  std::string log, state, output_dir, reference;
  lidar::LocalizationOptions options;
  lidar::LidarReadOptions read;
  std::string odometry = "auto";
  std::vector<double> initial_pose;
  long start_scan = 0, max_scans = 0, progress_every = 0;
  int repeat = 1;
  bool quiet = false;
};

bool ResolveLocalizeOptions(LocalizeCommand* cmd, std::ostream& err) {
  if (cmd->initial_pose.size() == 3) {
    cmd->options.has_initial_pose = true;
    cmd->options.initial_pose = SE2d(cmd->initial_pose[0], cmd->initial_pose[1], cmd->initial_pose[2]);
  }
  if (!FromString(cmd->odometry, &cmd->read.odometry)) {
    err << "tether localize: --odometry " << cmd->odometry << " is not one of " << EnumNameList<lidar::OdometrySource>()
        << "\n";
    return false;
  }
  cmd->options.local.limits = cmd->read.limits;
  std::string why;
  if (!cmd->options.IsValid(&why) || !cmd->read.IsValid(&why)) {
    err << "tether localize: " << why << "\n";
    return false;
  }
  return true;
}

// The state, the log and the reference; kExitOk, or kExitBadInput after saying why.
int ReadLocalizeInputs(const LocalizeCommand& cmd, lidar::LidarState* state, lidar::LidarLog* log,
                       std::vector<lidar::StampedPose2>* reference, std::ostream& err) {
  try {
    *state = lidar::ReadLidarState(cmd.state);
    *log = lidar::ReadLidarLog(cmd.log, cmd.read);
    if (!cmd.reference.empty()) *reference = lidar::ReadTumFile(cmd.reference);
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  if (log->scans.empty()) {
    err << "error: " << cmd.log << " has no scans\n";
    return kExitBadInput;
  }
  return kExitOk;
}

void PrintReference(const LocalizeCommand& cmd, const lidar::Localizer2D& run,
                    const std::vector<lidar::StampedPose2>& reference, std::ostream& out) {
  const localization::LocalizationError e = localization::CompareWithReference(run.Trajectory(), reference);
  out << "against " << cmd.reference << ": " << e.matched << " localised poses matched by stamp; position error mean "
      << FormatFixed(e.mean_error, 4) << " m, max " << FormatFixed(e.max_error, 3) << " m; heading error mean "
      << FormatFixed(e.mean_heading_error * 180 / M_PI, 3) << " deg\n";
}

int RunLocalize(LocalizeCommand cmd, std::ostream& out, std::ostream& err) {
  if (!ResolveLocalizeOptions(&cmd, err)) return kExitUsage;
  FolderOutputs outputs(cmd.output_dir);
  std::vector<std::pair<std::string, std::string>> inputs = {{cmd.log, ""}, {cmd.state, "state"}};
  if (!cmd.reference.empty()) inputs.emplace_back(cmd.reference, "reference");
  const auto names = lidar::Localizer2D::OutputNames();
  if (const int rc = outputs.Prepare("localize", inputs, names, err); rc != kExitOk) return rc;
  lidar::LidarState state;
  lidar::LidarLog log;
  std::vector<lidar::StampedPose2> reference;
  if (const int rc = ReadLocalizeInputs(cmd, &state, &log, &reference, err); rc != kExitOk) return outputs.Fail(rc);
  if (!cmd.quiet) {
    const ProbabilityGrid& m = *state.map;
    ProbabilityGrid::Cell lo, hi;
    m.KnownBounds(&lo, &hi);
    const long total = static_cast<long>(log.scans.size());
    const long from = std::min(cmd.start_scan, total);
    const long n = cmd.max_scans > 0 ? std::min(cmd.max_scans, total - from) : total - from;
    out << cmd.state << ": a map of " << FormatFixed((hi.x() - lo.x() + 1) * m.resolution(), 1) << " m x "
        << FormatFixed((hi.y() - lo.y() + 1) * m.resolution(), 1) << " m in cells of " << FormatDouble(m.resolution())
        << " m from " << state.scans.size() << " scans; " << n << " scans to localise from scan " << from + 1 << ", "
        << (cmd.options.has_initial_pose ? "from the initial pose" : "global start") << "\n"
        << std::flush;
  }
  const auto t0 = std::chrono::steady_clock::now();
  try {
    lidar::Localizer2D run(state, cmd.options);
    state = lidar::LidarState{};  // the localiser holds the map; the rest is not needed
    run.Run(log, cmd.start_scan, cmd.max_scans, cmd.repeat, cmd.quiet ? 0 : cmd.progress_every, [&](long done) {
      out << "scans " << done << ", localised " << run.report().localized << ", " << FormatFixed(SecondsSince(t0), 1)
          << " s\n"
          << std::flush;
    });
    if (const int rc = outputs.Write(run.Outputs(), err); rc != kExitOk) return outputs.Fail(rc);
    out << run.report().Summary();
    if (!cmd.reference.empty()) PrintReference(cmd, run, reference, out);
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return outputs.Fail(kExitBadInput);
  }
  out << "wrote " << FolderOutputs::List(cmd.output_dir, names) << "\n";
  return kExitOk;
}

class LocalizeCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunLocalize(cmd_, out, err); }

 private:
  template <class T>
  void Option(const char* name, T& value, const char* help) {
    app_->add_option(name, value, help)->capture_default_str();
  }
  LocalizeCommand cmd_;
};

void LocalizeCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "localize", "Localise a laser log (CARMEN or ROS 1 bag) in the saved map of tether lidar --save-state");
  sub->add_option("log", cmd_.log, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  sub->add_option("--state", cmd_.state, "The saved state (DIR/state.tether of tether lidar --save-state)")->required();
  AddPath(sub, "-o,--output", &cmd_.output_dir, "Output folder (made if missing)")->required();
  lidar::LocalizationOptions& o = cmd_.options;
  sub->add_option("--initial-pose", cmd_.initial_pose,
                  "Where the first scan is in the map, x,y,theta [m, m, rad] (default: global localisation)")
      ->delimiter(',')
      ->expected(3);
  Option("--start-scan", cmd_.start_scan, "Start at this scan of the log (from 0)");
  Option("--max-scans", cmd_.max_scans, "Only this many scans from the start (0: to the end)");
  Option("--repeat", cmd_.repeat, "Replay the scans this many times in a row (an endless log)");
  sub->add_option("--reference", cmd_.reference,
                  "A TUM trajectory in the map's frame (the mapping run's trajectory.tum): the error printed");
  Option("--global-every", o.global_every_n_scans, "Global localisation: search every N-th scan until the fix");
  Option("--global-min-score", o.global_min_score, "Global localisation: a match must score above this");
  Option("--global-max-range", o.global_max_range,
         "Global localisation: score only the points at most this far from the robot [m] (0: all)");
  Option("--global-depth", o.search.branch_and_bound_depth, "Global localisation: branch and bound's depth");
  Option("--track-min-score", o.track_min_score,
         "Tracking: a scan fits the map where its points read this mean probability");
  Option("--lost-after", o.lost_after_scans, "Scans in a row that do not fit before the fix is given up");
  Option("--keep-submaps", o.keep_submaps, "Local SLAM's newest submaps kept");
  sub->add_flag_function(
      "--no-correlative", [&o](std::int64_t) { o.local.use_correlative_matcher = false; },
      "Local SLAM refines from the prediction without the correlative search first");
  sub->add_flag_function(
      "--correlative", [&o](std::int64_t) { o.local.use_correlative_matcher = true; },
      "Local SLAM searches correlatively before refining");
  Option("--odometry", cmd_.odometry, "Where the odometry comes from: auto, scan-line, interpolated, or none");
  Option("--max-range", cmd_.read.limits.max_range, "Drop ranges beyond this [m] (0: the log's)");
  Option("--scan-topic", cmd_.read.scan_topic, "Bags: the sensor_msgs/LaserScan topic");
  Option("--odom-topic", cmd_.read.odom_topic, "Bags: the nav_msgs/Odometry topic");
  Option("--progress-every", cmd_.progress_every, "Scans between progress lines (0: none)");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No line before the run");
}

}  // namespace

std::unique_ptr<Command> MakeLocalizeCommand() { return std::make_unique<LocalizeCli>(); }

}  // namespace tether
