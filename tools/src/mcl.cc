// `tether mcl`: Monte Carlo localisation of a laser log in a saved map
// (frontends/localization/mcl_localization_2d.h); this file only binds the flags and prints.
#include <algorithm>
#include <cmath>
#include <memory>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/localization/mcl_localization_2d.h"
#include "tether/tools/command.h"
#include "tether/tools/folder_outputs.h"

namespace tether {

namespace {

using localization::MclRunOptions;

struct MclCommand {
  std::string log, map, output_dir, reference;
  MclRunOptions options;
  lidar::LidarReadOptions read;
  std::vector<double> initial_pose, motion_alphas;
  long max_scans = 0;
  bool quiet = false;
};

// The options the flags could not check alone; false after saying why.
bool ResolveMclOptions(MclCommand* cmd, std::ostream& err) {
  if (cmd->initial_pose.size() == 3) {
    cmd->options.has_initial_pose = true;
    cmd->options.initial_pose = SE2d(cmd->initial_pose[0], cmd->initial_pose[1], cmd->initial_pose[2]);
  }
  if (cmd->motion_alphas.size() == 4) {
    localization::OdometryMotionModel& m = cmd->options.filter.motion;
    m = {cmd->motion_alphas[0], cmd->motion_alphas[1], cmd->motion_alphas[2], cmd->motion_alphas[3]};
  }
  std::string why;
  if (!cmd->options.IsValid(&why) || !cmd->read.IsValid(&why)) {
    err << "tether mcl: " << why << "\n";
    return false;
  }
  return true;
}

// The map and the log (and the reference); kExitOk, or kExitBadInput after saying why.
int ReadMclInputs(const MclCommand& cmd, std::shared_ptr<const localization::OccupancyMap2D>* map, lidar::LidarLog* log,
                  std::vector<lidar::StampedPose2>* reference, std::ostream& err) {
  try {
    *map = std::make_shared<const localization::OccupancyMap2D>(localization::OccupancyMap2D::Read(cmd.map));
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

void PrintReference(const MclCommand& cmd, const localization::MclLocalization2D& run,
                    const std::vector<lidar::StampedPose2>& reference, std::ostream& out) {
  const localization::LocalizationError e = localization::CompareWithReference(run.Trajectory(), reference);
  out << "against " << cmd.reference << ": " << e.matched << " poses matched by stamp; position error mean "
      << FormatFixed(e.mean_error, 4) << " m, max " << FormatFixed(e.max_error, 3) << " m; heading error mean "
      << FormatFixed(e.mean_heading_error * 180 / M_PI, 2) << " deg\n";
  if (e.converged_index < 0) {
    out << "not converged: the last estimate is more than 0.5 m or 10 degrees from the reference\n";
  } else {
    out << "converged (within 0.5 m and 10 degrees from then on) at pose " << e.converged_index + 1 << ", "
        << FormatFixed(std::max(0.0, e.converged_stamp - run.Trajectory().front().stamp), 1)
        << " s into the run; from there: position error mean " << FormatFixed(e.mean_error_converged, 4)
        << " m, heading error mean " << FormatFixed(e.mean_heading_error_converged * 180 / M_PI, 2) << " deg\n";
  }
}

int RunMcl(MclCommand cmd, std::ostream& out, std::ostream& err) {
  if (!ResolveMclOptions(&cmd, err)) return kExitUsage;
  FolderOutputs outputs(cmd.output_dir);
  std::vector<std::pair<std::string, std::string>> inputs = {{cmd.log, ""}, {cmd.map, "map"}};
  if (!cmd.reference.empty()) inputs.emplace_back(cmd.reference, "reference");
  const auto names = localization::MclLocalization2D::OutputNames();
  if (const int rc = outputs.Prepare("mcl", inputs, names, err); rc != kExitOk) return rc;
  std::shared_ptr<const localization::OccupancyMap2D> map;
  lidar::LidarLog log;
  std::vector<lidar::StampedPose2> reference;
  if (const int rc = ReadMclInputs(cmd, &map, &log, &reference, err); rc != kExitOk) return outputs.Fail(rc);
  if (!cmd.quiet) {
    out << cmd.map << ": " << map->width() << " x " << map->height() << " cells of " << FormatDouble(map->resolution())
        << " m, " << map->free_cells().size() << " free; " << log.scans.size() << " scans; method "
        << ToString(cmd.options.filter.method) << ", " << cmd.options.filter.particles << " particles, "
        << (cmd.options.has_initial_pose ? "from the initial pose" : "global start") << "\n"
        << std::flush;
  }
  try {
    localization::MclLocalization2D run(map, cmd.options);
    run.Run(log, cmd.max_scans);
    if (const int rc = outputs.Write(run.Outputs(), err); rc != kExitOk) return outputs.Fail(rc);
    out << run.report().Summary();
    if (!cmd.reference.empty()) PrintReference(cmd, run, reference, out);
  } catch (const Error& e) {  // a scan without odometry, a map the filter refuses
    err << "error: " << e.what() << "; nothing was written\n";
    return outputs.Fail(kExitBadInput);
  }
  out << "wrote " << FolderOutputs::List(cmd.output_dir, names) << "\n";
  return kExitOk;
}

class MclCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunMcl(cmd_, out, err); }

 private:
  template <class T>
  void Option(const char* name, T& value, const char* help) {
    app_->add_option(name, value, help)->capture_default_str();
  }
  void AddFilterOptions();
  MclCommand cmd_;
};

void MclCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "mcl", "Monte Carlo localisation of a laser log (CARMEN or ROS 1 bag) in a saved map (map_server YAML + PGM)");
  sub->add_option("log", cmd_.log, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  sub->add_option("--map", cmd_.map, "The map's YAML (as tether lidar writes it: DIR/map.yaml)")->required();
  AddPath(sub, "-o,--output", &cmd_.output_dir, "Output folder (made if missing)")->required();
  sub->add_option("--initial-pose", cmd_.initial_pose,
                  "Where the robot starts in the map, x,y,theta [m, m, rad] (default: a global start, particles "
                  "over the whole free space)")
      ->delimiter(',')
      ->expected(3);
  Option("--start-time", cmd_.options.start_time, "Start this many seconds into the log [s]");
  Option("--max-scans", cmd_.max_scans, "Only this many scans from the start (0: all)");
  sub->add_option("--reference", cmd_.reference,
                  "A TUM trajectory in the map's frame (the mapping run's trajectory.tum, or the truth): errors "
                  "and the time to converge printed");
  Option("--scan-topic", cmd_.read.scan_topic, "Bags: the scan topic");
  Option("--odom-topic", cmd_.read.odom_topic, "Bags: the odometry topic");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No line before the run");
  AddFilterOptions();
}

void MclCli::AddFilterOptions() {
  localization::MclOptions& f = cmd_.options.filter;
  AddEnumOption(app_, "--method", &f.method,
                "mcl (plain), amcl (Augmented MCL: random particles), cmcl (costmap), acmcl (both), auto (acmcl until "
                "localised, then amcl)");
  AddEnumOption(app_, "--model", &f.model, "The measurement model");
  Option("--particles", f.particles, "Particles (the first count with --kld)");
  Option("--max-beams", f.max_beams, "Beams scored per scan (0: all)");
  Option("--sigma-hit", f.likelihood_field.sigma_hit, "The likelihood field's sigma [m]");
  AddEnumOption(app_, "--combination", &f.likelihood_field.combination, "How the beams' scores combine");
  app_->add_option("--motion-alphas", cmd_.motion_alphas, "The odometry motion model's alpha1..alpha4")
      ->delimiter(',')
      ->expected(4);
  Option("--alpha-slow", f.alpha_slow, "Augmented MCL's slow filter");
  Option("--alpha-fast", f.alpha_fast, "Augmented MCL's fast filter");
  Option("--robot-radius", f.robot_radius, "The costmap's inflation (cmcl, acmcl) [m]");
  app_->add_flag("--kld", f.kld.enabled, "KLD sampling: the particle count follows the spread");
  Option("--min-particles", f.kld.min_particles, "KLD sampling's least count");
  Option("--max-particles", f.kld.max_particles, "KLD sampling's largest count");
  Option("--update-min-d", f.update_min_translation, "Update once the robot moved this far [m]");
  Option("--update-min-a", f.update_min_rotation, "... or turned this much [rad]");
  Option("--min-effective", f.min_effective_fraction,
         "Temper a scan's likelihoods so that at least this share of the particles stays effective (0: never)");
  Option("--threads", f.threads, "Threads weighting the particles (0: every core; the result does not depend on it)");
  Option("--seed", f.seed, "The random stream's seed");
}

}  // namespace

std::unique_ptr<Command> MakeMclCommand() { return std::make_unique<MclCli>(); }

}  // namespace tether
