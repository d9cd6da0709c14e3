#pragma once
// The kidnapped-robot experiment of the thesis's section 5.2 in simulation, the loop behind
// `tether mcl-demo`. For each world (the maze and the office of lidar_world.h) and seed, a
// simulated robot with a simulated 2D scanner drives the simulator's route; the map it
// localises in is the world's walls rasterised (RasterizeWalls, 0.05 m). The filter starts at
// the truth; at step `kidnap_step` the robot is carried off: its true pose jumps to the pose of
// a later step of the same route, at least `min_jump` metres away, while the odometry goes on
// as if nothing happened (its increment across the jump is the route's ordinary increment into
// that later step). For each method and particle count it reports, over the seeds:
//
// - steps to converge: the updates after the kidnap until the estimate is within
//   `converge_distance` and `converge_angle` of the truth and stays so for `converge_hold`
//   updates in a row — the number of the first of those updates (1: the first update after the
//   jump). A run that has not converged after `max_steps` updates is counted as not converged
//   and left out of the mean;
// - the recovery ratio: over the updates after the kidnap up to convergence (or the cap), the
//   particles the costmap re-drew in the update (cmcl, acmcl) and those the resampling injected
//   (amcl, acmcl), and how many of them landed near the truth: within `near_radius` of its
//   position (and, for the pose variant, also within `near_angle` of its heading);
//   ratio = landed near / re-drawn, summed over the steps and the seeds.
//
//   MclExperimentOptions o;  // maze and office, amcl and acmcl, 500..2500 particles, 20 seeds
//   const MclExperimentResult r = RunMclExperiment(o);
//   std::cout << MclExperimentTables(r);
//
// One update per scan (the filter's update thresholds are set to 0), so a step is one scan,
// one filter update and `sim_step` metres of the route at most. Deterministic for the options:
// the runs are independent (each filter on one thread), only the times vary.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/localization/monte_carlo_localizer_2d.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace localization {

struct MclExperimentOptions {
  std::vector<lidar::LidarWorld> worlds = {lidar::LidarWorld::kMaze, lidar::LidarWorld::kOffice};
  std::vector<MclMethod> methods = {MclMethod::kAugmented, MclMethod::kAcmcl};
  std::vector<int> particles = {500, 1000, 1500, 2000, 2500};
  int seeds = 20;
  std::uint64_t first_seed = 1;
  int kidnap_step = 100;                        ///< the robot is carried off before this step's scan
  int max_steps = 1000;                         ///< updates after the kidnap at most
  int kidnap_window = 600;                      ///< the new pose is that of a route step in (kidnap_step, + window]
  double min_jump = 5;                          ///< metres the truth jumps at least
  double sim_step = 0.2;                        ///< metres the robot moves between scans (at full speed)
  double sim_max_turn = 0.2;                    ///< radians it turns between scans at most
  lidar::MazeOptions maze;                      ///< the maze's size (the default: 8 x 8 cells of 2 m)
  int sim_beams = 360;                          ///< the scanner's beams (over a full turn)
  double map_resolution = 0.05;                 ///< metres: the localisation map's cells
  double converge_distance = 0.5;               ///< metres
  double converge_angle = 0.17453292519943295;  ///< radians (10 degrees)
  int converge_hold = 10;                       ///< updates in a row within both
  double near_radius = 0.5;                     ///< metres: a re-drawn particle "near" the truth
  double near_angle = 0.17453292519943295;      ///< radians: ... and its heading (pose variant)
  /// The recovery filters (amcl, acmcl) start settled: w_slow and w_fast both at the first
  /// update's average, as the filter starts them. False: from 0, as in the textbook, and by the
  /// kidnap w_slow has reached only
  /// 1 - (1 - alpha_slow)^kidnap_step of the average (10% at step 100), so a kidnap must cut
  /// the average likelihood tenfold before a random particle is injected.
  bool settled_filters = true;
  int threads = 0;  ///< runs in parallel (0: every core); each filter weighs on one thread
  /// The filter's options; method, particles, seed, threads and the update thresholds are set per
  /// run (the thresholds to 0: every scan an update).
  MclOptions filter;

  /// False (and why) for an empty list, an unknown or repeated entry, fewer than 1 particle or
  /// seed, kidnap_step < 2, max_steps < converge_hold, converge_hold < 1, kidnap_window < 1,
  /// a non-positive or non-finite distance, angle, step or resolution, sim_beams < 2,
  /// an invalid maze, threads < 0, or invalid filter options.
  bool IsValid(std::string* why) const;
};

/// One world and seed, kidnap included: what the filter is fed.
struct KidnapScenario {
  lidar::LidarWorld world = lidar::LidarWorld::kMaze;
  std::uint64_t seed = 1;
  std::shared_ptr<const OccupancyMap2D> map;  ///< the walls rasterised at map_resolution
  std::vector<lidar::LaserScan> scans;        ///< one per step; odometry continuous across the jump
  std::vector<SE2d> truth;                    ///< the true pose at each step
  int kidnap_step = 0;                        ///< truth[kidnap_step] is the first pose after the jump
  int route_step = 0;                         ///< the route's step the robot was carried to
  double jump = 0;                            ///< metres between truth[kidnap_step - 1] and truth[kidnap_step]
};

/// The scenario of a world and seed (the simulation, the map, the jump). Throws
/// InvalidArgument for invalid options or where no step of the window lies min_jump away.
KidnapScenario MakeKidnapScenario(lidar::LidarWorld world, std::uint64_t seed, const MclExperimentOptions& options);

/// One filter run over a scenario.
struct KidnapRun {
  int steps_to_converge = -1;   ///< -1: not converged within max_steps
  int steps_run = 0;            ///< updates after the kidnap that were run
  bool tracked_before = false;  ///< the estimate was within the bounds at the step before the kidnap
  std::int64_t redrawn = 0;     ///< particles re-drawn or injected after the kidnap, up to convergence
  std::int64_t near = 0;        ///< ... of them within near_radius of the truth
  std::int64_t near_pose = 0;   ///< ... and within near_angle of its heading
  double seconds = 0;
};

/// Runs one filter over the scenario: the particles drawn around the first true pose, one
/// update per step, until converge_hold updates after convergence or max_steps after the
/// kidnap. `filter` is used as given except the update thresholds (set to 0).
KidnapRun RunKidnap(const KidnapScenario& scenario, const MclOptions& filter, const MclExperimentOptions& options);

/// One world, method and particle count over the seeds.
struct MclExperimentRow {
  lidar::LidarWorld world = lidar::LidarWorld::kMaze;
  MclMethod method = MclMethod::kAugmented;
  int particles = 0;
  std::vector<KidnapRun> runs;  ///< per seed, first_seed first

  int Converged() const;             ///< runs that converged
  double StepsMean() const;          ///< over the converged runs (NaN: none)
  double StepsStd() const;           ///< sample standard deviation over them (0 for one)
  std::int64_t Redrawn() const;      ///< summed over the runs
  double RecoveryRatio() const;      ///< near / re-drawn over the runs (NaN: none re-drawn)
  double RecoveryRatioPose() const;  ///< near_pose / re-drawn
  double SecondsMean() const;
};

/// A world's figures, means over the seeds.
struct MclWorldFigures {
  lidar::LidarWorld world = lidar::LidarWorld::kMaze;
  double jump = 0;        ///< metres the truth jumped
  double free_area = 0;   ///< square metres of free cells (where amcl draws)
  double valid_area = 0;  ///< ... of the costmap's valid cells (where cmcl and acmcl draw)
};

/// The share of draws uniform over `area` square metres that land within `radius` of a point
/// whose disc lies inside the area: pi r^2 / area, the recovery ratio a uniform draw gives.
double UniformDrawRatio(double area, double radius);

struct MclExperimentResult {
  MclExperimentOptions options;
  std::vector<MclExperimentRow> rows;   ///< by world, then method, then particle count
  std::vector<MclWorldFigures> worlds;  ///< in the options' order
  double seconds = 0;                   ///< wall-clock time of the whole experiment
};

/// Runs every world, seed, method and particle count. Throws InvalidArgument for invalid options.
MclExperimentResult RunMclExperiment(const MclExperimentOptions& options);

/// The tables in markdown: steps to converge (mean +- std over the converged seeds, and how
/// many did not converge), the recovery ratio per world (position and pose), the recovery ratio
/// per particle count, the time per run; the thesis's figures beside them where it has them.
std::string MclExperimentTables(const MclExperimentResult& result);

}  // namespace localization
}  // namespace tether
