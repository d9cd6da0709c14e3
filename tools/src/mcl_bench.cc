// `tether mcl-bench`: how fast Monte Carlo localisation is — the map's loading (PGM, distance
// transform, likelihood field), particle-beams scored per second on one thread and on every
// core, a full update (predict, weight, resample, estimate) — beside the machine's own rate of
// random reads from a table the size of the likelihood field. Measured on a generated map
// (rooms off corridors, `--cells` a side) or on a given one (`--map`).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <ostream>
#include <thread>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/localization/monte_carlo_localizer_2d.h"
#include "tether/tools/command.h"

namespace tether {

namespace {

using localization::MclOptions;
using localization::MonteCarloLocalizer2D;
using localization::OccupancyMap2D;

struct MclBenchCommand {
  std::string map;   // a map_server YAML; empty: generated
  int cells = 4000;  // the generated map's side
  int particles = 5000;
  int beams = 60;
  int repeats = 20;
  std::uint64_t seed = 1;
};

// Rooms of 5 m (100 cells at 0.05 m) with doors, walls 2 cells thick, a box in every other room.
lidar::OccupancyImage GeneratedMap(int cells, std::uint64_t seed) {
  lidar::OccupancyImage image;
  image.width = image.height = cells;
  image.resolution = 0.05;
  image.pixels.assign(static_cast<std::size_t>(cells) * static_cast<std::size_t>(cells), 254);
  RandomStream random(seed, 11);
  const auto set = [&](int i, int j) {
    if (i >= 0 && j >= 0 && i < cells && j < cells) image.pixels[static_cast<std::size_t>(j) * cells + i] = 0;
  };
  for (int a = 0; a < cells; a += 100) {
    for (int b = 0; b < cells; ++b) {
      const bool door = b % 100 > 40 && b % 100 < 60;  // a 1 m door in every wall
      for (int t = 0; t < 2 && !door; ++t) {
        set(a + t, b);
        set(b, a + t);
      }
    }
  }
  for (int r = 0; r < (cells / 100) * (cells / 100); r += 2) {
    const int i0 = (r % (cells / 100)) * 100 + 10 + static_cast<int>(random.Uniform() * 60);
    const int j0 = (r / (cells / 100)) * 100 + 10 + static_cast<int>(random.Uniform() * 60);
    for (int j = j0; j < j0 + 12; ++j)
      for (int i = i0; i < i0 + 12; ++i) set(i, j);
  }
  return image;
}

// A scan of `beams` returns cast in the map from `pose` (the filter's SelectBeams takes all).
lidar::LaserScan CastScan(const OccupancyMap2D& map, const SE2d& pose, int beams) {
  const localization::BeamModel caster(map, {});
  lidar::LaserScan s;
  s.angle_min = -3.14159265358979323846;
  s.angle_increment = 2 * 3.14159265358979323846 / beams;
  s.range_max = 30;
  for (int b = 0; b < beams; ++b) {
    const double r = caster.CastRay(pose.translation(), pose.theta() + s.Angle(static_cast<std::size_t>(b)), 29);
    s.ranges.push_back(static_cast<float>(r));
  }
  s.odometry_origin = lidar::OdometryOrigin::kScanLine;
  return s;
}

// The machine's rate of dependent-free random 8-byte reads from a table of `bytes`.
double RandomReadsPerSecond(std::size_t bytes, std::uint64_t seed) {
  std::vector<std::uint64_t> table(bytes / 8, 1);
  std::vector<std::uint32_t> index(1 << 22);
  RandomStream random(seed, 12);
  for (std::uint32_t& i : index) i = static_cast<std::uint32_t>(random.Uniform() * static_cast<double>(table.size()));
  const auto t0 = std::chrono::steady_clock::now();
  std::uint64_t sum = 0;
  for (int r = 0; r < 4; ++r)
    for (const std::uint32_t i : index) sum += table[i];
  const double seconds = SecondsSince(t0);
  if (sum == 42) std::puts("");  // keeps the reads
  return 4.0 * static_cast<double>(index.size()) / seconds;
}

// Seconds per Update (Augmented MCL's: the weighting and the recovery filters) and per full
// step (predict, update, estimate, resample), with `threads`.
std::pair<double, double> TimeUpdates(const std::shared_ptr<const OccupancyMap2D>& map, const MclBenchCommand& cmd,
                                      const lidar::LaserScan& scan, const SE2d& pose, bool global, int threads) {
  MclOptions o;
  o.method = localization::MclMethod::kAugmented;  // the weighting alone: no costmap, no clustering in Update
  o.particles = cmd.particles;
  o.max_beams = cmd.beams;
  o.threads = threads;
  o.update_min_translation = o.update_min_rotation = 0;
  MonteCarloLocalizer2D mcl(map, o);
  const auto init = [&] {
    if (global) {
      mcl.InitializeGlobal();
    } else {
      mcl.InitializeGaussian(pose, Eigen::Vector3d(0.04, 0.04, 0.01).asDiagonal());
    }
  };
  init();
  mcl.Update(scan);  // builds the likelihood field
  double update = 0, step = 0;
  for (int r = 0; r < cmd.repeats; ++r) {
    init();
    auto t0 = std::chrono::steady_clock::now();
    mcl.Update(scan);
    update += SecondsSince(t0);
    t0 = std::chrono::steady_clock::now();
    mcl.Predict(SE2d(), SE2d(0.05, 0, 0.01));
    mcl.Update(scan);
    mcl.Estimate();
    mcl.Resample();
    step += SecondsSince(t0);
  }
  return {update / cmd.repeats, step / cmd.repeats};
}

int RunMclBench(const MclBenchCommand& cmd, std::ostream& out, std::ostream& err) {
  std::string yaml = cmd.map;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("tether-mcl-bench-" + std::to_string(cmd.seed));
  if (yaml.empty()) {
    std::filesystem::create_directories(dir);
    const lidar::OccupancyImage image = GeneratedMap(cmd.cells, cmd.seed);
    std::ofstream((dir / "map.pgm").string(), std::ios::binary) << lidar::PgmBytes(image);
    std::ofstream((dir / "map.yaml").string()) << lidar::MapYaml(image, "map.pgm");
    yaml = (dir / "map.yaml").string();
  }
  std::shared_ptr<const OccupancyMap2D> map;
  auto t0 = std::chrono::steady_clock::now();
  try {
    map = std::make_shared<const OccupancyMap2D>(OccupancyMap2D::Read(yaml));
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  const double load = SecondsSince(t0);
  t0 = std::chrono::steady_clock::now();
  const localization::LikelihoodField field(*map, {}, 30);
  const double field_seconds = SecondsSince(t0);
  if (cmd.map.empty()) std::filesystem::remove_all(dir);
  const std::uint32_t k = map->free_cells()[map->free_cells().size() / 2];
  const SE2d pose(map->CellCentre(static_cast<int>(k % map->width()), static_cast<int>(k / map->width())).x(),
                  map->CellCentre(static_cast<int>(k % map->width()), static_cast<int>(k / map->width())).y(), 0.3);
  const lidar::LaserScan scan = CastScan(*map, pose, cmd.beams);
  out << "map: " << map->width() << " x " << map->height() << " cells; read with its distance transform in "
      << FormatFixed(load, 3) << " s, likelihood field " << FormatFixed(field_seconds, 3) << " s (together "
      << FormatFixed(load + field_seconds, 3) << " s)\n";
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  out << "| particles (" << cmd.particles << ") | threads | weighting [ms] | particle-beams / s | full update [ms] |\n"
      << "|---|---|---|---|---|\n";
  for (const bool global : {false, true}) {
    for (const int threads : {1, static_cast<int>(cores)}) {
      const auto t = TimeUpdates(map, cmd, scan, pose, global, threads);
      const double rate = static_cast<double>(cmd.particles) * cmd.beams / t.first;
      out << "| " << (global ? "spread over the map" : "around the pose (tracking)") << " | " << threads << " | "
          << FormatFixed(1e3 * t.first, 2) << " | " << FormatFixed(rate / 1e6, 1) << " million | "
          << FormatFixed(1e3 * t.second, 2) << " |\n";
    }
  }
  const double reads = RandomReadsPerSecond(8 * static_cast<std::size_t>(map->width()) * map->height(), cmd.seed);
  out << "random 8-byte reads from a table of the field's size, one thread: " << FormatFixed(reads / 1e6, 1)
      << " million / s\n";
  return kExitOk;
}

class MclBenchCli : public Command {
 public:
  void Add(CLI::App& app) override {
    CLI::App* sub = app_ = app.add_subcommand(
        "mcl-bench", "Monte Carlo localisation's speed: map loading, particle-beams per second, a full update");
    sub->add_option("--map", cmd_.map, "A map_server YAML (default: a generated map of rooms)");
    sub->add_option("--cells", cmd_.cells, "The generated map's side in cells (0.05 m)")->capture_default_str();
    sub->add_option("--particles", cmd_.particles, "Particles")->capture_default_str();
    sub->add_option("--beams", cmd_.beams, "Beams per scan")->capture_default_str();
    sub->add_option("--repeats", cmd_.repeats, "Updates timed per case")->capture_default_str();
    sub->add_option("--seed", cmd_.seed, "The generated map's and the particles' seed")->capture_default_str();
  }
  int Run(std::ostream& out, std::ostream& err) override {
    if (cmd_.cells < 200 || cmd_.cells > 20000 || cmd_.particles < 1 || cmd_.beams < 1 || cmd_.repeats < 1) {
      err << "tether mcl-bench: --cells takes 200..20000, --particles, --beams and --repeats at least 1\n";
      return kExitUsage;
    }
    return RunMclBench(cmd_, out, err);
  }

 private:
  MclBenchCommand cmd_;
};

}  // namespace

std::unique_ptr<Command> MakeMclBenchCommand() { return std::make_unique<MclBenchCli>(); }

}  // namespace tether
