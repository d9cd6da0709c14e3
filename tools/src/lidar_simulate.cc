#include "tether/tools/lidar_simulate.h"

#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/frontends/lidar/io/degrade_log.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {

namespace {

constexpr const char* kUsage = "tether simulate: ";

// The simulation's and the preset's options from the flags; kExitUsage (said on err) where they
// do not make a run.
int MakeOptions(const SimulateCommand& sim, const SimulateLidarCommand& cmd, lidar::LidarSimOptions* o,
                lidar::DegradeOptions* degrade, std::ostream& err) {
  o->seed = sim.seed;
  o->world = cmd.world;
  if (cmd.scans) o->scans = *cmd.scans;
  if (cmd.beams) o->beams = *cmd.beams;
  o->odometry = !cmd.no_odometry;
  degrade->seed = sim.seed;
  if (!cmd.preset.empty()) {
    if (!lidar::DegradePreset(cmd.preset, degrade)) {
      err << kUsage << "--preset takes " << lidar::DegradePresetNames() << " (got '" << cmd.preset << "')\n";
      return kExitUsage;
    }
    // The scanner's beams are simulated (--beams or the preset's), its noise added once.
    if (cmd.beams) degrade->beams = *cmd.beams;
    o->beams = degrade->beams > 0 ? degrade->beams : o->beams;
    o->range_noise = 0;
  }
  std::string why;
  if (!o->IsValid(&why)) {
    err << kUsage << "lidar: " << why << " (--scans, --beams)\n";
    return kExitUsage;
  }
  return 0;
}

// MAP.yaml -> MAP.pgm; "" where the path does not end in .yaml or .yml.
std::string MapImagePath(const std::string& yaml) {
  for (const std::string ext : {".yaml", ".yml"}) {
    if (yaml.size() > ext.size() && yaml.compare(yaml.size() - ext.size(), ext.size(), ext) == 0) {
      return yaml.substr(0, yaml.size() - ext.size()) + ".pgm";
    }
  }
  return "";
}

// The line the log begins with and the report repeats.
std::string Describe(const SimulateCommand& sim, const SimulateLidarCommand& cmd, const lidar::LidarSimOptions& o,
                     const lidar::LidarLog& log) {
  std::ostringstream what;
  what << "tether simulate lidar: the " << ToString(o.world) << " world";
  if (o.world == lidar::LidarWorld::kMaze) {
    what << " (" << o.maze.cells_x << " x " << o.maze.cells_y << " cells of " << o.maze.cell_size << " m)";
  }
  what << ", seed " << sim.seed << ", " << log.scans.size() << " scans of " << log.scans.front().ranges.size()
       << " beams, max range " << log.scans.front().range_max << " m";
  if (!cmd.preset.empty()) what << ", preset " << cmd.preset;
  what << ", " << (o.odometry ? "odometry" : "no odometry");
  return what.str();
}

void ReportRun(const lidar::LidarSimOptions& o, const lidar::SimulatedLidar& run, std::ostream& out) {
  out << "the run: " << run.distance << " m, ";
  if (o.world == lidar::LidarWorld::kMaze) {
    out << run.tours << " maze tours begun, " << run.cells_visited << " of " << o.maze.cells_x * o.maze.cells_y
        << " cells visited";
  } else {
    out << run.laps << " corridor laps begun, " << run.rooms_visited << " rooms entered";
  }
  if (o.odometry) {
    const double drift = (run.log.scans.back().odometry.translation() - run.truth.back().pose.translation()).norm();
    out << ", odometry " << drift << " m off the truth at the end";
  }
  out << "\n";
}

}  // namespace

int RunSimulateLidar(const SimulateCommand& sim, const SimulateLidarCommand& cmd, std::ostream& out,
                     std::ostream& err) {
  if (sim.world != "lidar") {
    err << kUsage
        << "--truth, --scans, --beams, --no-odometry, --preset, --world and --map-out are for the lidar world "
        << "(got '" << sim.world << "')\n";
    return kExitUsage;
  }
  if (!sim.ground_truth.empty()) {
    err << kUsage << "the lidar world writes its true trajectory as TUM text: use --truth, not --ground-truth\n";
    return kExitUsage;
  }
  lidar::LidarSimOptions o;
  lidar::DegradeOptions degrade;
  if (const int rc = MakeOptions(sim, cmd, &o, &degrade, err); rc != 0) return rc;
  if (sim.output.empty()) {
    err << kUsage << "-o FILE is required\n";
    return kExitUsage;
  }
  const std::string map_image = MapImagePath(cmd.map_out);
  if (!cmd.map_out.empty() && map_image.empty()) {
    err << kUsage << "--map-out takes the map's .yaml (its image is written beside it as .pgm)\n";
    return kExitUsage;
  }
  OutputSet outputs;
  OutputFile *log_file = nullptr, *truth_file = nullptr, *yaml_file = nullptr, *pgm_file = nullptr;
  const int rc = CheckOutputs(
      "simulate", outputs,
      [&] {
        log_file = &outputs.Add(sim.output, "simulated log");
        if (!cmd.truth.empty()) truth_file = &outputs.Add(cmd.truth, "true trajectory");
        if (!cmd.map_out.empty()) yaml_file = &outputs.Add(cmd.map_out, "map (YAML)");
        if (!cmd.map_out.empty()) pgm_file = &outputs.Add(map_image, "map image (PGM)");
      },
      err);
  if (rc != 0) return rc;
  const lidar::SimulatedLidar run = lidar::SimulateLidar(o);
  lidar::LidarLog log = run.log;
  std::vector<lidar::StampedPose2> truth = run.truth;
  if (!cmd.preset.empty()) {
    log = lidar::DegradeLog(run.log, degrade);
    truth.clear();  // the truth of the scans kept
    for (std::size_t k = 0; k < run.truth.size(); k += static_cast<std::size_t>(degrade.keep_every)) {
      truth.push_back(run.truth[k]);
    }
  }
  lidar::OccupancyImage map;
  try {
    if (yaml_file != nullptr) map = lidar::RasterizeWalls(run.walls, cmd.map_resolution);
  } catch (const InvalidArgument& e) {
    err << kUsage << e.what() << " (--map-resolution); nothing was written\n";
    return kExitUsage;
  }
  const std::string what = Describe(sim, cmd, o, log);
  try {
    log_file->Stage([&](std::ostream& s) { lidar::WriteCarmenLog(s, log, o.odometry, what); });
    if (truth_file != nullptr) truth_file->Stage([&](std::ostream& s) { lidar::WriteTum(s, truth); });
    if (yaml_file != nullptr) {
      pgm_file->Stage(lidar::PgmBytes(map));
      yaml_file->Stage(lidar::MapYaml(map, map_image.substr(map_image.find_last_of('/') + 1)));
    }
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  out << "wrote " << sim.output << ": " << what << "\n";
  ReportRun(o, run, out);
  if (truth_file != nullptr) out << "wrote the true trajectory " << cmd.truth << " (" << truth.size() << " poses)\n";
  if (yaml_file != nullptr) out << "wrote the world's map " << cmd.map_out << " and " << map_image << "\n";
  return 0;
}

}  // namespace tether
