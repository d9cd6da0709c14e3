// `tether pf-slam`: grid-based Rao-Blackwellised particle filter SLAM of a laser log
// (frontends/lidar/rbpf_slam_2d.h); this file only binds the flags and prints.
#include <memory>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/rbpf_slam_2d.h"
#include "tether/tools/command.h"
#include "tether/tools/folder_outputs.h"

namespace tether {

namespace {

struct PfSlamCommand {
  std::string log, output_dir;
  lidar::RbpfSlamOptions options;
  lidar::LidarReadOptions read;
  long max_scans = 0;
  bool quiet = false;
};

int RunPfSlam(const PfSlamCommand& cmd, std::ostream& out, std::ostream& err) {
  std::string why;
  if (!cmd.options.IsValid(&why) || !cmd.read.IsValid(&why)) {
    err << "tether pf-slam: " << why << "\n";
    return kExitUsage;
  }
  FolderOutputs outputs(cmd.output_dir);
  const auto names = lidar::RbpfSlam2D::OutputNames();
  if (const int rc = outputs.Prepare("pf-slam", {{cmd.log, ""}}, names, err); rc != kExitOk) return rc;
  lidar::LidarLog log;
  try {
    log = lidar::ReadLidarLog(cmd.log, cmd.read);
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return outputs.Fail(kExitBadInput);
  }
  if (log.scans.empty()) {
    err << "error: " << cmd.log << " has no scans\n";
    return outputs.Fail(kExitBadInput);
  }
  if (!cmd.quiet) {
    out << cmd.log << ": " << log.scans.size() << " scans; " << cmd.options.particles << " particles\n" << std::flush;
  }
  try {
    lidar::RbpfSlam2D slam(cmd.options);
    slam.Run(log, cmd.max_scans);
    if (const int rc = outputs.Write(slam.Outputs(), err); rc != kExitOk) return outputs.Fail(rc);
    out << slam.report().Summary();
  } catch (const Error& e) {  // a scan without odometry, a scan the filter refuses
    err << "error: " << e.what() << "; nothing was written\n";
    return outputs.Fail(kExitBadInput);
  }
  out << "wrote " << FolderOutputs::List(cmd.output_dir, names) << "\n";
  return kExitOk;
}

class PfSlamCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunPfSlam(cmd_, out, err); }

 private:
  template <class T>
  void Option(const char* name, T& value, const char* help) {
    app_->add_option(name, value, help)->capture_default_str();
  }
  PfSlamCommand cmd_;
};

void PfSlamCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "pf-slam",
      "Grid-based Rao-Blackwellised particle filter SLAM of a laser log (CARMEN or ROS 1 bag; with odometry or "
      "scan-only)");
  sub->add_option("log", cmd_.log, "The log: CARMEN (.clf, .log, plain or gzip) or a ROS 1 bag")->required();
  AddPath(sub, "-o,--output", &cmd_.output_dir, "Output folder (made if missing)")->required();
  lidar::RbpfSlamOptions& o = cmd_.options;
  Option("--particles", o.particles, "Particles, each with its own trajectory and map");
  Option("--max-scans", cmd_.max_scans, "Only this many scans from the start (0: all)");
  Option("--resolution", o.resolution, "The maps' cell size [m]");
  Option("--max-range", o.max_range, "Returns beyond this are left out of matching and the maps [m]");
  Option("--linear-update", o.linear_update, "Process a scan once the odometry moved this far [m]");
  Option("--angular-update", o.angular_update, "... or turned this much [rad]");
  Option("--likelihood-points", o.likelihood_points, "A scan's points count as this many independent beams");
  Option("--resample-fraction", o.resample_fraction,
         "Resample where the effective sample size falls below this share of the particles");
  Option("--threads", o.threads, "Threads (0: every core; the result does not depend on it)");
  Option("--seed", o.seed, "The random streams' seed");
  AddEnumOption(app_, "--odometry", &cmd_.read.odometry,
                "Where each scan's odometry comes from (none: scan-only, the scans moved by scan-to-scan matching)");
  Option("--scan-topic", cmd_.read.scan_topic, "Bags: the scan topic");
  Option("--odom-topic", cmd_.read.odom_topic, "Bags: the odometry topic");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No line before the run");
}

}  // namespace

std::unique_ptr<Command> MakePfSlamCommand() { return std::make_unique<PfSlamCli>(); }

}  // namespace tether
