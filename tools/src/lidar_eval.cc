#include "tether/tools/lidar_eval.h"

#include <cmath>
#include <cstdlib>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/laser_scan.h"
#include "tether/frontends/lidar/lidar_log.h"
#include "tether/frontends/lidar/relations_metric.h"
#include "tether/frontends/lidar/restamp.h"
#include "tether/frontends/lidar/tum_trajectory.h"
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

int RunLidarEval(const LidarEvalCommand& cmd, std::ostream& out, std::ostream& err) {
  const char* usage = "tether lidar-eval: ";
  lidar::LidarReadOptions read;
  if (cmd.format != "auto" && cmd.format != "tum" && cmd.format != "log") {
    err << usage << "--format takes auto, tum or log (got '" << cmd.format << "')\n";
    return kExitUsage;
  }
  if (!lidar::FromString(cmd.odometry, &read.odometry)) {
    err << usage << "--odometry takes " << lidar::OdometrySourceNames() << " (got '" << cmd.odometry << "')\n";
    return kExitUsage;
  }
  if (!(cmd.tolerance >= 0) || !std::isfinite(cmd.tolerance) || !(cmd.time_reference_tolerance >= 0) ||
      !std::isfinite(cmd.time_reference_tolerance)) {
    err << usage << "--tolerance and --time-reference-tolerance must be finite and not negative\n";
    return kExitUsage;
  }
  SE2<double> offset;
  std::string offset_problem;
  if (!cmd.pose_offset.empty() && !ParseOffset(cmd.pose_offset, &offset, &offset_problem)) {
    if (!offset_problem.empty()) {
      err << usage << "--pose-offset '" << cmd.pose_offset << "': " << offset_problem << "\n";
    } else {
      err << usage << "--pose-offset takes x,y,theta (metres, radians), got '" << cmd.pose_offset << "'\n";
    }
    return kExitUsage;
  }
  read.scan_topic = cmd.scan_topic;
  read.odom_topic = cmd.odom_topic;
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
      err << usage << "--time-reference needs a log as the trajectory (its scans are matched by their ranges)\n";
      return kExitUsage;
    }
    std::vector<lidar::StampedPose2> poses;
    if (kind == "tum") {
      poses = lidar::ReadTumFile(cmd.trajectory);
      out << "trajectory: " << poses.size() << " poses (TUM text)\n";
    } else {
      const lidar::LidarLog log = lidar::ReadLidarLog(cmd.trajectory, read);
      out << "trajectory: " << log.scans.size() << " scans (" << lidar::ToString(log.format)
          << "), odometry: " << lidar::ToString(read.odometry);
      if (log.clamped_odometry > 0) out << ", " << log.clamped_odometry << " scans outside the odometry (clamped)";
      out << "\n";
      if (cmd.time_reference.empty()) {
        poses = lidar::OdometryTrajectory(log);
      } else {
        lidar::LidarReadOptions ref_options = read;
        ref_options.odometry = lidar::OdometrySource::kAuto;
        const lidar::LidarLog reference = lidar::ReadLidarLog(cmd.time_reference, ref_options);
        const lidar::RestampResult r = lidar::RestampByReference(log, reference, cmd.time_reference_tolerance);
        out << "restamped from " << cmd.time_reference << ": " << r.by_ranges << " scans by their ranges, " << r.by_time
            << " by time only, " << r.dropped << " without a raw scan within " << cmd.time_reference_tolerance
            << " s (dropped); largest logger-time difference " << r.max_time_difference << " s\n";
        poses = r.poses;
      }
    }
    if (!cmd.pose_offset.empty()) {
      for (lidar::StampedPose2& p : poses) p.pose = p.pose * offset;
      out << "every pose composed with the offset (" << offset.x() << ", " << offset.y() << ", " << offset.theta()
          << ")\n";
    }
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
    out << "stamps matched within " << cmd.tolerance << " s (largest difference " << result.max_stamp_difference
        << " s)\n";
    if (result.matched == 0) {
      err << usage << "no relation matched the trajectory's stamps within " << cmd.tolerance
          << " s; are they the same clock (the relations use CARMEN's ipc_timestamp; see --time-reference)?\n";
    }
    if (tum_file != nullptr) {
      try {
        tum_file->Stage([&](std::ostream& s) { lidar::WriteTum(s, poses); });
        outputs.CommitAll();
      } catch (const IoError& e) {
        err << "error: " << e.what() << "\n";
        return kExitWriteFailed;
      }
      out << "trajectory written to " << cmd.trajectory_output << "\n";
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
