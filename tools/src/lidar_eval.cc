#include "tether/tools/lidar_eval.h"

#include <cmath>
#include <cstdlib>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/restamp.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/lidar/sensor/laser_scan.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// "tum" or "log" for the trajectory file; throws IoError where it cannot be opened.
std::string TrajectoryKind(const LidarEvalCommand& cmd) {
  if (cmd.format != "auto") return cmd.format;
  if (lidar::DetectLogFormat(cmd.trajectory) == lidar::LogFormat::kRosBag) return "log";
  for (const char* ext : {".clf", ".log", ".gz"}) {
    if (EndsWith(cmd.trajectory, ext)) return "log";
  }
  return "tum";
}

// "x,y,theta" into *offset; false where it is not three finite numbers, or (`why` set) where
// PoseProblem refuses them as a pose.
bool ParseOffset(const std::string& text, SE2<double>* offset, std::string* why) {
  double v[3];
  std::size_t at = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t comma = text.find(',', at);
    if ((k < 2) != (comma != std::string::npos)) return false;
    const std::string field = text.substr(at, k < 2 ? comma - at : std::string::npos);
    char* end = nullptr;
    v[k] = std::strtod(field.c_str(), &end);
    if (field.empty() || *end != '\0' || !std::isfinite(v[k])) return false;
    at = comma + 1;
  }
  *why = lidar::PoseProblem(v[0], v[1], v[2]);
  if (!why->empty()) return false;
  *offset = SE2<double>(v[0], v[1], v[2]);
  return true;
}

}  // namespace

namespace {

constexpr const char* kUsage = "tether lidar-eval: ";

// The reading options and the pose offset from the command; false after saying why.
bool ResolveEvalOptions(const LidarEvalCommand& cmd, lidar::LidarReadOptions* read, SE2<double>* offset,
                        std::ostream& err) {
  if (cmd.format != "auto" && cmd.format != "tum" && cmd.format != "log") {
    err << kUsage << "--format takes auto, tum or log (got '" << cmd.format << "')\n";
    return false;
  }
  if (!FromString(cmd.odometry, &read->odometry)) {
    err << kUsage << "--odometry takes " << EnumNameList<lidar::OdometrySource>() << " (got '" << cmd.odometry
        << "')\n";
    return false;
  }
  if (!(cmd.tolerance >= 0) || !std::isfinite(cmd.tolerance) || !(cmd.time_reference_tolerance >= 0) ||
      !std::isfinite(cmd.time_reference_tolerance)) {
    err << kUsage << "--tolerance and --time-reference-tolerance must be finite and not negative\n";
    return false;
  }
  std::string offset_problem;
  if (!cmd.pose_offset.empty() && !ParseOffset(cmd.pose_offset, offset, &offset_problem)) {
    if (!offset_problem.empty()) {
      err << kUsage << "--pose-offset '" << cmd.pose_offset << "': " << offset_problem << "\n";
    } else {
      err << kUsage << "--pose-offset takes x,y,theta (metres, radians), got '" << cmd.pose_offset << "'\n";
    }
    return false;
  }
  read->scan_topic = cmd.scan_topic;
  read->odom_topic = cmd.odom_topic;
  return true;
}

// The poses to score: a TUM file's, or a log's odometry (restamped by the raw log of
// --time-reference where given). Throws what the readers throw.
std::vector<lidar::StampedPose2> ReadScoredPoses(const LidarEvalCommand& cmd, const std::string& kind,
                                                 const lidar::LidarReadOptions& read, std::ostream& out) {
  if (kind == "tum") {
    std::vector<lidar::StampedPose2> poses = lidar::ReadTumFile(cmd.trajectory);
    out << "trajectory: " << poses.size() << " poses (TUM text)\n";
    return poses;
  }
  const lidar::LidarLog log = lidar::ReadLidarLog(cmd.trajectory, read);
  out << "trajectory: " << log.scans.size() << " scans (" << ToString(log.format)
      << "), odometry: " << ToString(read.odometry);
  if (log.clamped_odometry > 0) out << ", " << log.clamped_odometry << " scans outside the odometry (clamped)";
  out << "\n";
  if (cmd.time_reference.empty()) return lidar::OdometryTrajectory(log);
  lidar::LidarReadOptions ref_options = read;
  ref_options.odometry = lidar::OdometrySource::kAuto;
  const lidar::LidarLog reference = lidar::ReadLidarLog(cmd.time_reference, ref_options);
  const lidar::RestampResult r = lidar::RestampByReference(log, reference, cmd.time_reference_tolerance);
  out << "restamped from " << cmd.time_reference << ": " << r.by_ranges << " scans by their ranges, " << r.by_time
      << " by time only, " << r.dropped << " without a raw scan within " << cmd.time_reference_tolerance
      << " s (dropped); largest logger-time difference " << r.max_time_difference << " s\n";
  return r.poses;
}

// Scores the poses on the relations and writes --trajectory-out; the exit code. Throws what
// the readers throw.
int Score(const LidarEvalCommand& cmd, const std::vector<lidar::StampedPose2>& poses, OutputSet* outputs,
          OutputFile* tum_file, std::ostream& out, std::ostream& info, std::ostream& err) {
  if (poses.empty()) {
    err << "error: " << cmd.trajectory << ": the trajectory has no pose; nothing to score\n";
    return kExitBadInput;
  }
  const std::vector<lidar::Relation> relations = lidar::ReadRelationsFile(cmd.relations);
  if (relations.empty()) {
    err << "error: " << cmd.relations << ": the relations file has no relation; nothing to score\n";
    return kExitBadInput;
  }
  lidar::RelationsOptions ro;
  ro.tolerance = cmd.tolerance;
  const lidar::RelationsResult result = lidar::EvaluateRelations(poses, relations, ro);
  out << result.Report();
  info << "stamps matched within " << cmd.tolerance << " s (largest difference " << result.max_stamp_difference
       << " s)\n";
  if (result.matched == 0) {
    err << kUsage << "no relation matched the trajectory's stamps within " << cmd.tolerance
        << " s; are they the same clock (the relations use CARMEN's ipc_timestamp; see --time-reference)?\n";
  }
  if (tum_file == nullptr) return kExitOk;
  try {
    tum_file->Stage([&](std::ostream& s) { lidar::WriteTum(s, poses); });
    outputs->CommitAll();
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  info << "trajectory written to " << cmd.trajectory_output << "\n";
  return kExitOk;
}

}  // namespace

int RunLidarEval(const LidarEvalCommand& cmd, std::ostream& out, std::ostream& err) {
  lidar::LidarReadOptions read;
  SE2<double> offset;
  if (!ResolveEvalOptions(cmd, &read, &offset, err)) return kExitUsage;
  OutputSet outputs;
  OutputFile* tum_file = nullptr;
  const int rc = CheckOutputs(
      "lidar-eval", outputs,
      [&] {
        outputs.AddInput(cmd.trajectory, "trajectory");
        outputs.AddInput(cmd.relations, "relations");
        if (!cmd.time_reference.empty()) outputs.AddInput(cmd.time_reference, "time reference");
        if (!cmd.trajectory_output.empty()) tum_file = &outputs.Add(cmd.trajectory_output, "trajectory");
      },
      err);
  if (rc != 0) return rc;
  try {
    const std::string kind = TrajectoryKind(cmd);
    if (kind == "tum" && !cmd.time_reference.empty()) {
      err << kUsage << "--time-reference needs a log as the trajectory (its scans are matched by their ranges)\n";
      return kExitUsage;
    }
    std::ostream none(nullptr);  // -q: only the scores
    std::ostream& info = cmd.quiet ? none : out;
    std::vector<lidar::StampedPose2> poses = ReadScoredPoses(cmd, kind, read, info);
    if (!cmd.pose_offset.empty()) {
      for (lidar::StampedPose2& p : poses) p.pose = p.pose * offset;
      info << "every pose composed with the offset (" << offset.x() << ", " << offset.y() << ", " << offset.theta()
           << ")\n";
    }
    return Score(cmd, poses, &outputs, tum_file, out, info, err);
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const ParseError& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const InvalidArgument& e) {
    err << kUsage << e.what() << "\n";
    return kExitUsage;
  }
}

namespace {

class LidarEvalCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunLidarEval(cmd_, out, err); }

 private:
  LidarEvalCommand cmd_;
};

void LidarEvalCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "lidar-eval",
      "Score a trajectory on the relations of Kuemmerle et al. (mean +- std of the relative-pose errors)");
  sub->add_option("trajectory", cmd_.trajectory,
                  "TUM text (timestamp x y z qx qy qz qw), or a laser log (CARMEN .clf/.log, plain or .gz, or a ROS 1 "
                  "bag) whose scans' odometry poses are scored")
      ->required();
  sub->add_option("relations", cmd_.relations, "Relations file: t1 t2 x y z roll pitch yaw per line")->required();
  sub->add_option("--format", cmd_.format, "auto, tum or log")->capture_default_str();
  sub->add_option("--odometry", cmd_.odometry, "Logs: auto, scan-line, interpolated or none")->capture_default_str();
  sub->add_option("--scan-topic", cmd_.scan_topic, "Bags: the sensor_msgs/LaserScan topic")->capture_default_str();
  sub->add_option("--odom-topic", cmd_.odom_topic, "Bags: the nav_msgs/Odometry topic")->capture_default_str();
  sub->add_option("--tolerance", cmd_.tolerance, "Seconds between a relation's stamp and the nearest pose")
      ->capture_default_str();
  sub->add_option("--time-reference", cmd_.time_reference,
                  "The raw log a corrected log was made from: its scans' stamps (found by ranges near the "
                  "logger time) replace the trajectory's");
  sub->add_option("--time-reference-tolerance", cmd_.time_reference_tolerance,
                  "Seconds of logger time searched for the raw scan")
      ->capture_default_str();
  sub->add_option("--pose-offset", cmd_.pose_offset,
                  "x,y,theta: score every pose T as T * offset (e.g. laser poses on relations of the robot's)");
  sub->add_flag("-q,--quiet", cmd_.quiet, "Only the scores");
  AddPath(sub, "--trajectory-out", &cmd_.trajectory_output, "Also write the scored trajectory (TUM text)");
}

}  // namespace

std::unique_ptr<Command> MakeLidarEvalCommand() { return std::make_unique<LidarEvalCli>(); }

}  // namespace tether
