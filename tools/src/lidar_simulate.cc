#include "tether/tools/lidar_simulate.h"

#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/io/degrade_log.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {

int RunSimulateLidar(const SimulateCommand& sim, const SimulateLidarCommand& cmd, std::ostream& out,
                     std::ostream& err) {
  const char* usage = "tether simulate: ";
  if (sim.world != "lidar") {
    err << usage << "--truth, --scans, --beams, --no-odometry and --preset are for the lidar world (got '" << sim.world
        << "')\n";
    return kExitUsage;
  }
  if (!sim.ground_truth.empty()) {
    err << usage << "the lidar world writes its true trajectory as TUM text: use --truth, not --ground-truth\n";
    return kExitUsage;
  }
  lidar::LidarSimOptions o;
  o.seed = sim.seed;
  if (cmd.scans) o.scans = *cmd.scans;
  if (cmd.beams) o.beams = *cmd.beams;
  o.odometry = !cmd.no_odometry;
  lidar::DegradeOptions degrade;
  degrade.seed = sim.seed;
  if (!cmd.preset.empty()) {
    if (!lidar::DegradePreset(cmd.preset, &degrade)) {
      err << usage << "--preset takes " << lidar::DegradePresetNames() << " (got '" << cmd.preset << "')\n";
      return kExitUsage;
    }
    // The scanner's beams are simulated (--beams or the preset's), its noise added once.
    if (cmd.beams) degrade.beams = *cmd.beams;
    o.beams = degrade.beams > 0 ? degrade.beams : o.beams;
    o.range_noise = 0;
  }
  std::string why;
  if (!o.IsValid(&why)) {
    err << usage << "lidar: " << why << " (--scans, --beams)\n";
    return kExitUsage;
  }
  if (sim.output.empty()) {
    err << usage << "-o FILE is required\n";
    return kExitUsage;
  }
  OutputSet outputs;
  OutputFile* log_file = nullptr;
  OutputFile* truth_file = nullptr;
  const int rc = CheckOutputs(
      "simulate", outputs,
      [&] {
        log_file = &outputs.Add(sim.output, "simulated log");
        if (!cmd.truth.empty()) truth_file = &outputs.Add(cmd.truth, "true trajectory");
      },
      err);
  if (rc != 0) return rc;
  const lidar::SimulatedLidar run = lidar::SimulateLidar(o);
  lidar::LidarLog log = run.log;
  std::vector<lidar::StampedPose2> truth = run.truth;
  if (!cmd.preset.empty()) {
    log = lidar::DegradeLog(run.log, degrade);
    // The truth of the scans kept.
    truth.clear();
    for (std::size_t k = 0; k < run.truth.size(); k += static_cast<std::size_t>(degrade.keep_every)) {
      truth.push_back(run.truth[k]);
    }
  }
  std::ostringstream what;
  what << "tether simulate lidar: the office world, seed " << sim.seed << ", " << log.scans.size() << " scans of "
       << log.scans.front().ranges.size() << " beams, max range " << log.scans.front().range_max << " m";
  if (!cmd.preset.empty()) what << ", preset " << cmd.preset;
  what << ", " << (o.odometry ? "odometry" : "no odometry");
  try {
    log_file->Stage([&](std::ostream& s) { lidar::WriteCarmenLog(s, log, o.odometry, what.str()); });
    if (truth_file != nullptr) truth_file->Stage([&](std::ostream& s) { lidar::WriteTum(s, truth); });
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  const double drift = (run.log.scans.back().odometry.translation() - run.truth.back().pose.translation()).norm();
  out << "wrote " << sim.output << ": " << what.str() << "\n"
      << "the run: " << run.distance << " m, " << run.laps << " corridor laps begun, " << run.rooms_visited
      << " rooms entered";
  if (o.odometry) out << ", odometry " << drift << " m off the truth at the end";
  out << "\n";
  if (truth_file != nullptr) out << "wrote the true trajectory " << cmd.truth << " (" << truth.size() << " poses)\n";
  return 0;
}

}  // namespace tether
