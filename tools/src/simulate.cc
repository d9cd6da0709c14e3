// `tether simulate WORLD -o FILE`: a synthetic graph with known ground truth
// (tether/frontends/simulation/simulate.h); the lidar world writes a laser log instead
// (lidar_simulate.cc).
#include "tether/frontends/simulation/simulate.h"

#include <ostream>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/output_file.h"
#include "tether/factors/builtin.h"
#include "tether/tools/commands.h"
#include "tether/tools/lidar_simulate.h"

namespace tether {

int RunSimulate(const SimulateCommand& cmd, std::ostream& out, std::ostream& err) {
  SimulateOptions so;
  if (!FromString(cmd.world, &so.world)) {
    err << "tether simulate: unknown world '" << cmd.world << "'; use " << EnumNameList<SimWorld>() << " (or lidar)\n";
    return 2;
  }
  so.poses = cmd.poses;
  so.seed = cmd.seed;
  std::string why;
  if (!so.IsValid(&why)) {
    err << "tether simulate: " << why << "\n";
    return 2;
  }
  if (cmd.output.empty()) {
    err << "tether simulate: -o FILE is required\n";
    return 2;
  }
  OutputSet outputs;
  OutputFile* graph_file = nullptr;
  OutputFile* truth_file = nullptr;
  const int rc = CheckOutputs(
      "simulate", outputs,
      [&] {
        graph_file = &outputs.Add(cmd.output, "simulated graph");
        if (!cmd.ground_truth.empty()) truth_file = &outputs.Add(cmd.ground_truth, "ground truth");
      },
      err);
  if (rc != 0) return rc;
  const SimulatedGraph sim = Simulate(so);
  try {
    graph_file->Stage([&](std::ostream& s) { WriteG2o(s, sim.initial, sim.graph, DefaultRegistry()); });
    if (truth_file != nullptr) {
      truth_file->Stage([&](std::ostream& s) { WriteG2o(s, sim.ground_truth, sim.graph, DefaultRegistry()); });
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  try {
    outputs.CommitAll();  // its message says what became of the files
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  const Values& v = sim.ground_truth;
  const std::size_t poses = v.Count(VarType::kSE2) + v.Count(VarType::kSE3);
  const std::size_t landmarks = v.Count(VarType::kPoint2) + v.Count(VarType::kPoint3);
  out << "wrote " << cmd.output << ": " << cmd.world << ", " << poses << " poses, " << landmarks << " landmarks, "
      << sim.graph.size() << " factors (" << sim.odometry_factors << " odometry, " << sim.loop_closures
      << " loop closures, " << sim.observations << " observations), seed " << cmd.seed << "\n";
  if (!cmd.ground_truth.empty()) out << "wrote ground truth " << cmd.ground_truth << "\n";
  return 0;
}

namespace {

class SimulateCli : public Command {
 public:
  void Add(CLI::App& app) override {
    CLI::App* sub = app_ = app.add_subcommand("simulate", "Write a synthetic graph with known ground truth");
    sub->add_option("world", sim_.world, "manhattan | sphere | landmarks | lidar")->required();
    sub->add_option("--poses", sim_.poses, "Number of poses")->capture_default_str();
    sub->add_option("--seed", sim_.seed, "Random seed")->capture_default_str();
    AddPath(sub, "-o,--output", &sim_.output, "Output g2o file (initial values: composed odometry)")->required();
    AddPath(sub, "--ground-truth", &sim_.ground_truth, "Also write the true values to this g2o file");
    AddPath(sub, "--truth", &lidar_.truth, "lidar: write the true trajectory here (TUM text)");
    sub->add_option("--scans", lidar_.scans, "lidar: scans at 10 Hz (default 3000)");
    sub->add_option("--beams", lidar_.beams, "lidar: beams over 360 degrees (default 360)");
    sub->add_flag("--no-odometry", lidar_.no_odometry, "lidar: scans without odometry");
    sub->add_option("--preset", lidar_.preset, "lidar: lds (6 m, 0.02 m noise, 5% of the beams dropped, 5 Hz)");
    world_ =
        AddEnumOption(sub, "--world", &lidar_.world, "lidar: the office (40 m x 30 m) or a maze (8 x 8 cells of 2 m)");
    AddPath(sub, "--map-out", &lidar_.map_out, "lidar: write the world's map to this .yaml and the .pgm beside it");
    map_resolution_ = sub->add_option("--map-resolution", lidar_.map_resolution, "lidar: the map's metres a pixel")
                          ->capture_default_str();
    sub->add_flag("-q,--quiet", quiet_, "Print nothing but errors");
  }
  int Run(std::ostream& out, std::ostream& err) override {
    std::ostream none(nullptr);  // -q: the report goes nowhere
    std::ostream& report = quiet_ ? none : out;
    lidar_.world_given = world_->count() > 0;
    lidar_.map_resolution_given = map_resolution_->count() > 0;
    if (sim_.world == "lidar" || lidar_.Given()) return RunSimulateLidar(sim_, lidar_, report, err);
    return RunSimulate(sim_, report, err);
  }

 private:
  SimulateCommand sim_;
  SimulateLidarCommand lidar_;
  CLI::Option* world_ = nullptr;
  CLI::Option* map_resolution_ = nullptr;
  bool quiet_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeSimulateCommand() { return std::make_unique<SimulateCli>(); }

}  // namespace tether
