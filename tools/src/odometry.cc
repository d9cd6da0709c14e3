// `tether odometry LOG -o GRAPH.g2o`: a log's wheel odometry through the odometry front-end
// (tether/frontends/odometry/odometry_run.h) into a pose graph; this file binds the flags to
// its options, reads the log and writes what it returns.
#include <Eigen/Core>
#include <cmath>
#include <ostream>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/output_file.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/odometry/odometry_run.h"
#include "tether/tools/commands.h"

namespace tether {
namespace {

struct OdometryCommand {
  std::string log, output, trajectory;
  lidar::LidarReadOptions read;
  odometry::OdometryFrontEndOptions options;
  double v_sigma = 0.1;        // m/s
  double w_sigma = M_PI / 18;  // rad/s
  bool quiet = false;
};

// The log's odometry as stamps and poses: its odometry messages (ODOM lines, the bag's topic),
// else the poses on its laser lines; false after saying why.
bool ReadTrack(const OdometryCommand& cmd, std::vector<double>* stamps, std::vector<SE2d>* poses, std::ostream& err) {
  lidar::LidarLog log;
  try {
    log = lidar::ReadLidarLog(cmd.log, cmd.read);
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return false;
  }
  for (const lidar::StampedPose2& p : log.odometry.Sorted()) {
    stamps->push_back(p.stamp);
    poses->push_back(p.pose);
  }
  if (poses->empty()) {
    for (const lidar::LaserScan& scan : log.scans) {
      if (scan.odometry_origin != lidar::OdometryOrigin::kScanLine) continue;  // no pose on its line
      stamps->push_back(scan.stamp);
      poses->push_back(scan.odometry);
    }
  }
  if (poses->size() < 2) {
    err << "error: " << cmd.log << " has " << poses->size()
        << " odometry poses (no ODOM lines and no poses on its laser lines, or no messages on --odom-topic "
        << cmd.read.odom_topic << "); the odometry front-end needs at least two\n";
    return false;
  }
  return true;
}

int RunOdometryCommand(OdometryCommand cmd, std::ostream& out, std::ostream& err) {
  cmd.options.noise.control = Eigen::Vector2d(cmd.v_sigma * cmd.v_sigma, cmd.w_sigma * cmd.w_sigma).asDiagonal();
  cmd.options.letter = '\0';  // pose i is key i in the file
  OutputSet set;
  OutputFile* graph = nullptr;
  OutputFile* trajectory = nullptr;
  const int rc = CheckOutputs(
      "odometry", set,
      [&] {
        set.AddInput(cmd.log, "log");
        graph = &set.Add(cmd.output, "pose graph");
        if (!cmd.trajectory.empty()) trajectory = &set.Add(cmd.trajectory, "trajectory");
      },
      err);
  if (rc != 0) return rc;
  std::vector<double> stamps;
  std::vector<SE2d> poses;
  if (!ReadTrack(cmd, &stamps, &poses, err)) return kExitBadInput;
  odometry::OdometryRunResult r;
  try {
    r = odometry::RunOdometry(stamps, poses, cmd.options);
  } catch (const InvalidArgument& e) {
    err << "error: " << cmd.log << ": " << e.what() << "\n";
    return kExitBadInput;
  }
  if (!cmd.quiet) out << r.report.Summary();
  try {
    graph->Stage([&](std::ostream& s) { WriteG2o(s, r.values, r.graph, DefaultRegistry()); });
    if (trajectory != nullptr) {
      std::vector<lidar::StampedPose2> tum;
      for (std::size_t i = 0; i < r.trajectory.size(); ++i) tum.push_back({r.stamps[i], r.trajectory[i]});
      trajectory->Stage([&](std::ostream& s) { lidar::WriteTum(s, tum); });
    }
    set.CommitAll();  // all or nothing; its message says what became of the files
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  if (!cmd.quiet) out << "wrote " << cmd.output << (cmd.trajectory.empty() ? "" : " and " + cmd.trajectory) << "\n";
  return kExitOk;
}

class OdometryCli : public Command {
 public:
  void Add(CLI::App& app) override {
    CLI::App* sub = app_ = app.add_subcommand(
        "odometry", "A log's wheel odometry through the odometry front-end: a pose graph to add closures to");
    sub->add_option("log", cmd_.log, "CARMEN log (ODOM lines, or poses on the laser lines) or ROS 1 bag")->required();
    AddPath(sub, "-o,--output", &cmd_.output, "The pose graph (g2o): a prior on the start, a BetweenSE2 per pose")
        ->required();
    AddPath(sub, "--trajectory", &cmd_.trajectory, "The dead-reckoned poses with their stamps (TUM text)");
    sub->add_option("--controls-per-pose", cmd_.options.controls_per_pose,
                    "Odometry steps composed into one pose-pose factor")
        ->capture_default_str();
    sub->add_option("--v-sigma", cmd_.v_sigma, "Standard deviation of the forward speed [m/s]")->capture_default_str();
    sub->add_option("--w-sigma", cmd_.w_sigma, "Standard deviation of the turn rate [rad/s]")->capture_default_str();
    sub->add_option("--floor-sigma", cmd_.options.noise.floor_sigma,
                    "Added to each relative pose's standard deviations [m, m, rad]")
        ->capture_default_str();
    sub->add_option("--prior-sigma", cmd_.options.prior_sigma, "The start's prior [m, m, rad] (0: none)")
        ->capture_default_str();
    AddEnumOption(sub, "--format", &cmd_.read.format, "The log's format (auto: by its first bytes)");
    sub->add_option("--odom-topic", cmd_.read.odom_topic, "Bags: the nav_msgs/Odometry topic")->capture_default_str();
    sub->add_flag("-q,--quiet", cmd_.quiet, "Print nothing but errors");
  }
  int Run(std::ostream& out, std::ostream& err) override { return RunOdometryCommand(cmd_, out, err); }

 private:
  OdometryCommand cmd_;
};

}  // namespace

std::unique_ptr<Command> MakeOdometryCommand() { return std::make_unique<OdometryCli>(); }

}  // namespace tether
