#include "tether/frontends/localization/mcl_experiment.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <thread>

#include "tether/core/error.h"
#include "tether/core/parallel_for.h"
#include "tether/frontends/simulation/random_stream.h"
#include "tether/frontends/simulation/walls.h"

namespace tether {
namespace localization {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool Fail(std::string* why, const std::string& what) {
  if (why) *why = what;
  return false;
}

bool PositiveFinite(double v) { return v > 0 && std::isfinite(v); }

template <class T>
bool Repeats(const std::vector<T>& v) {
  return std::set<T>(v.begin(), v.end()).size() != v.size();
}

double HeadingError(double a, double b) { return std::abs(std::remainder(a - b, 2 * kPi)); }

// The route's step (in (kidnap, kidnap + window]) the robot is carried to: one drawn uniformly
// among those at least min_jump from the pose before the kidnap.
int PickKidnapTarget(const lidar::SimulatedLidar& sim, std::uint64_t seed, const MclExperimentOptions& o) {
  const int k = o.kidnap_step;
  const Eigen::Vector2d from = sim.truth[static_cast<std::size_t>(k - 1)].pose.translation();
  std::vector<int> candidates;
  for (int j = k + 1; j <= k + o.kidnap_window; ++j) {
    if ((sim.truth[static_cast<std::size_t>(j)].pose.translation() - from).norm() >= o.min_jump)
      candidates.push_back(j);
  }
  if (candidates.empty()) {
    throw InvalidArgument("MakeKidnapScenario: no step of the route within the kidnap window lies " +
                          std::to_string(o.min_jump) + " m from the pose before the kidnap");
  }
  RandomStream random(seed, 0x6b69646e6170);
  const std::size_t pick = std::min(
      candidates.size() - 1, static_cast<std::size_t>(random.Uniform() * static_cast<double>(candidates.size())));
  return candidates[pick];
}

}  // namespace

bool MclExperimentOptions::IsValid(std::string* why) const {
  if (worlds.empty() || methods.empty() || particles.empty()) {
    return Fail(why, "the lists of worlds, methods and particle counts must not be empty");
  }
  if (Repeats(worlds) || Repeats(methods) || Repeats(particles)) return Fail(why, "a world, method or count repeats");
  for (const int p : particles) {
    if (p < 1) return Fail(why, "particle counts must be at least 1");
  }
  if (seeds < 1) return Fail(why, "seeds must be at least 1");
  if (kidnap_step < 2) return Fail(why, "kidnap_step must be at least 2");
  if (converge_hold < 1 || max_steps < converge_hold) {
    return Fail(why, "converge_hold must be at least 1 and max_steps at least converge_hold");
  }
  if (kidnap_window < 1) return Fail(why, "kidnap_window must be at least 1");
  for (const double v :
       {min_jump, sim_step, sim_max_turn, map_resolution, converge_distance, converge_angle, near_radius, near_angle}) {
    if (!PositiveFinite(v)) {
      return Fail(why,
                  "min_jump, sim_step, sim_max_turn, map_resolution and the convergence and near bounds must "
                  "be positive and finite");
    }
  }
  if (sim_beams < 2) return Fail(why, "sim_beams must be at least 2");
  std::string w;
  if (!maze.IsValid(&w)) return Fail(why, "maze: " + w);
  if (threads < 0) return Fail(why, "threads must be 0 (every core) or more");
  if (!filter.IsValid(&w)) return Fail(why, "filter: " + w);
  return true;
}

KidnapScenario MakeKidnapScenario(lidar::LidarWorld world, std::uint64_t seed, const MclExperimentOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("MakeKidnapScenario: " + why);
  lidar::LidarSimOptions sim_options;
  sim_options.world = world;
  sim_options.maze = o.maze;
  sim_options.seed = seed;
  sim_options.step = o.sim_step;
  sim_options.max_turn = o.sim_max_turn;
  sim_options.beams = o.sim_beams;
  sim_options.scans = o.kidnap_step + o.kidnap_window + o.max_steps + 1;
  const lidar::SimulatedLidar sim = lidar::SimulateLidar(sim_options);
  const int k = o.kidnap_step;
  const int target = PickKidnapTarget(sim, seed, o);
  KidnapScenario s;
  s.world = world;
  s.seed = seed;
  s.map = std::make_shared<const OccupancyMap2D>(lidar::RasterizeWalls(sim.walls, o.map_resolution));
  s.kidnap_step = k;
  s.route_step = target;
  const std::size_t steps = static_cast<std::size_t>(k + o.max_steps);
  // Before the kidnap the route as simulated; from it the route from `target` on, its odometry
  // continued from the last pose before the jump by the route's own increments.
  const SE2d odometry_before = sim.log.scans[static_cast<std::size_t>(k - 1)].odometry;
  const SE2d odometry_target_from = sim.log.scans[static_cast<std::size_t>(target - 1)].odometry;
  for (std::size_t i = 0; i < steps; ++i) {
    const bool after = i >= static_cast<std::size_t>(k);
    const std::size_t route = after ? i - static_cast<std::size_t>(k) + static_cast<std::size_t>(target) : i;
    lidar::LaserScan scan = sim.log.scans[route];
    scan.stamp = sim.log.scans[i].stamp;
    scan.logger_stamp = sim.log.scans[i].logger_stamp;
    if (after) scan.odometry = odometry_before * (odometry_target_from.Inverse() * scan.odometry);
    s.scans.push_back(std::move(scan));
    s.truth.push_back(sim.truth[route].pose);
  }
  s.jump = (s.truth[static_cast<std::size_t>(k)].translation() - s.truth[static_cast<std::size_t>(k - 1)].translation())
               .norm();
  return s;
}

KidnapRun RunKidnap(const KidnapScenario& s, const MclOptions& filter, const MclExperimentOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  MclOptions f = filter;
  f.update_min_translation = 0;
  f.update_min_rotation = 0;
  MonteCarloLocalizer2D mcl(s.map, f);
  mcl.InitializeGaussian(s.truth.front(), Eigen::Vector3d(0.01, 0.01, 0.003).asDiagonal());
  KidnapRun run;
  // Per update after the kidnap: re-drawn or injected particles, and those near the truth.
  std::vector<std::int64_t> redrawn, near, near_pose;
  const auto count = [&](const std::vector<bool>& flags, const SE2d& truth) {
    for (std::size_t i = 0; i < flags.size(); ++i) {
      if (!flags[i]) continue;
      const Particle& p = mcl.particles()[i];
      ++redrawn.back();
      if ((Eigen::Vector2d(p.x, p.y) - truth.translation()).norm() > o.near_radius) continue;
      ++near.back();
      if (HeadingError(p.theta, truth.theta()) <= o.near_angle) ++near_pose.back();
    }
  };
  int within_since = -1;  // the first update of the current run of updates within the bounds
  for (std::size_t k = 0; k < s.scans.size(); ++k) {
    const bool after = k >= static_cast<std::size_t>(s.kidnap_step);
    const int t = static_cast<int>(k) - s.kidnap_step + 1;  // updates since the kidnap
    if (after) {
      redrawn.push_back(0);
      near.push_back(0);
      near_pose.push_back(0);
    }
    if (k > 0) mcl.Predict(s.scans[k - 1].odometry, s.scans[k].odometry);
    mcl.Update(s.scans[k]);
    if (k == 0 && !o.settled_filters && std::isfinite(mcl.log_w_fast())) {
      // The filter starts both at the first update's w_avg; from 0, as in the textbook, one
      // update leaves alpha times it.
      const double log_w_avg = mcl.log_w_fast();
      mcl.SetRecoveryFilters(std::log(f.alpha_slow) + log_w_avg, std::log(f.alpha_fast) + log_w_avg);
    }
    if (after) count(mcl.redrawn(), s.truth[k]);
    const PoseEstimate e = mcl.Estimate();
    mcl.Resample();
    if (after) count(mcl.injected(), s.truth[k]);
    const bool within = (e.pose.translation() - s.truth[k].translation()).norm() <= o.converge_distance &&
                        HeadingError(e.pose.theta(), s.truth[k].theta()) <= o.converge_angle;
    if (!after) {
      run.tracked_before = within;
      continue;
    }
    run.steps_run = t;
    within_since = within ? (within_since < 0 ? t : within_since) : -1;
    if (within_since > 0 && t - within_since + 1 >= o.converge_hold) {
      run.steps_to_converge = within_since;
      break;
    }
  }
  const std::size_t counted =
      run.steps_to_converge > 0 ? static_cast<std::size_t>(run.steps_to_converge) : redrawn.size();
  for (std::size_t i = 0; i < counted; ++i) {
    run.redrawn += redrawn[i];
    run.near += near[i];
    run.near_pose += near_pose[i];
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return run;
}

int MclExperimentRow::Converged() const {
  return static_cast<int>(
      std::count_if(runs.begin(), runs.end(), [](const KidnapRun& r) { return r.steps_to_converge > 0; }));
}

double MclExperimentRow::StepsMean() const {
  const int n = Converged();
  if (n == 0) return kNaN;
  double sum = 0;
  for (const KidnapRun& r : runs) sum += r.steps_to_converge > 0 ? r.steps_to_converge : 0;
  return sum / n;
}

double MclExperimentRow::StepsStd() const {
  const int n = Converged();
  if (n < 2) return n == 1 ? 0 : kNaN;
  const double mean = StepsMean();
  double sum = 0;
  for (const KidnapRun& r : runs) {
    if (r.steps_to_converge > 0) sum += (r.steps_to_converge - mean) * (r.steps_to_converge - mean);
  }
  return std::sqrt(sum / (n - 1));
}

std::int64_t MclExperimentRow::Redrawn() const {
  std::int64_t n = 0;
  for (const KidnapRun& r : runs) n += r.redrawn;
  return n;
}

double MclExperimentRow::RecoveryRatio() const {
  std::int64_t near = 0;
  for (const KidnapRun& r : runs) near += r.near;
  const std::int64_t n = Redrawn();
  return n > 0 ? static_cast<double>(near) / static_cast<double>(n) : kNaN;
}

double MclExperimentRow::RecoveryRatioPose() const {
  std::int64_t near = 0;
  for (const KidnapRun& r : runs) near += r.near_pose;
  const std::int64_t n = Redrawn();
  return n > 0 ? static_cast<double>(near) / static_cast<double>(n) : kNaN;
}

double MclExperimentRow::SecondsMean() const {
  double sum = 0;
  for (const KidnapRun& r : runs) sum += r.seconds;
  return runs.empty() ? kNaN : sum / static_cast<double>(runs.size());
}

double UniformDrawRatio(double area, double radius) { return area > 0 ? kPi * radius * radius / area : kNaN; }

MclExperimentResult RunMclExperiment(const MclExperimentOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("RunMclExperiment: " + why);
  const auto start = std::chrono::steady_clock::now();
  MclExperimentResult result;
  result.options = o;
  const std::size_t seeds = static_cast<std::size_t>(o.seeds);
  const std::size_t per_seed = o.methods.size() * o.particles.size();
  for (const lidar::LidarWorld world : o.worlds) {
    std::vector<KidnapScenario> scenarios(seeds);
    ParallelFor(seeds, o.threads,
                [&](std::size_t i) { scenarios[i] = MakeKidnapScenario(world, o.first_seed + i, o); });
    MclWorldFigures figures;
    figures.world = world;
    const double cell = o.map_resolution * o.map_resolution;
    for (const KidnapScenario& s : scenarios) {
      figures.jump += s.jump / static_cast<double>(seeds);
      figures.free_area += cell * static_cast<double>(s.map->free_cells().size()) / static_cast<double>(seeds);
      const Costmap2D costmap(*s.map, o.filter.robot_radius);
      figures.valid_area += cell * static_cast<double>(costmap.valid_cells().size()) / static_cast<double>(seeds);
    }
    result.worlds.push_back(figures);
    const std::size_t first_row = result.rows.size();
    for (const MclMethod method : o.methods) {
      for (const int particles : o.particles) {
        MclExperimentRow row;
        row.world = world;
        row.method = method;
        row.particles = particles;
        row.runs.resize(seeds);
        result.rows.push_back(row);
      }
    }
    // Job j: seed j / per_seed, row j % per_seed of this world's.
    ParallelFor(seeds * per_seed, o.threads, [&](std::size_t j) {
      MclExperimentRow& row = result.rows[first_row + j % per_seed];
      MclOptions f = o.filter;
      f.method = row.method;
      f.particles = row.particles;
      f.seed = o.first_seed + j / per_seed;
      f.threads = 1;
      row.runs[j / per_seed] = RunKidnap(scenarios[j / per_seed], f, o);
    });
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

namespace {

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

std::string Percent(double ratio, int digits) { return std::isfinite(ratio) ? Fixed(100 * ratio, digits) + "%" : "-"; }

const char* MethodLabel(MclMethod m) {
  switch (m) {
    case MclMethod::kMcl:
      return "MCL";
    case MclMethod::kAugmented:
      return "Augmented MCL";
    case MclMethod::kCostmap:
      return "Costmap MCL";
    case MclMethod::kAcmcl:
      return "ACMCL";
    case MclMethod::kAuto:
      return "auto (ACMCL until localised)";
  }
  return "";
}

// The thesis's Table 5.1 (maze, steps to converge) for a method and particle count; NaN where
// it has none.
double ThesisSteps(MclMethod m, int particles) {
  static const int counts[] = {500, 1000, 1500, 2000, 2500};
  static const double amcl[] = {379, 108, 104, 72, 67};
  static const double acmcl[] = {50, 50, 24, 28, 18};
  for (int i = 0; i < 5; ++i) {
    if (counts[i] != particles) continue;
    if (m == MclMethod::kAugmented) return amcl[i];
    if (m == MclMethod::kAcmcl) return acmcl[i];
  }
  return kNaN;
}

// The thesis's Table 5.2 (recovery ratio) for a method on the maze or the larger map.
double ThesisRatio(MclMethod m, lidar::LidarWorld w) {
  const bool maze = w == lidar::LidarWorld::kMaze;
  if (m == MclMethod::kAugmented) return maze ? 0.008 : 0.0081;
  if (m == MclMethod::kAcmcl) return maze ? 0.047 : 0.085;
  return kNaN;
}

const char* WorldLabel(lidar::LidarWorld w) { return w == lidar::LidarWorld::kMaze ? "maze" : "office"; }

std::string StepsCell(const MclExperimentRow& r) {
  const int failed = static_cast<int>(r.runs.size()) - r.Converged();
  std::string cell = r.Converged() > 0 ? Fixed(r.StepsMean(), 1) + " ± " + Fixed(r.StepsStd(), 1) : "-";
  if (failed > 0) cell += " (" + std::to_string(failed) + "/" + std::to_string(r.runs.size()) + " not converged)";
  return cell;
}

// Rows of a world and method, in particle order.
std::vector<const MclExperimentRow*> RowsOf(const MclExperimentResult& r, lidar::LidarWorld w, MclMethod m) {
  std::vector<const MclExperimentRow*> out;
  for (const MclExperimentRow& row : r.rows) {
    if (row.world == w && row.method == m) out.push_back(&row);
  }
  return out;
}

std::string ParticleHeader(const std::vector<int>& particles, const std::string& first) {
  std::string head = "| " + first, rule = "|" + std::string(first.size() + 2, '-');
  for (const int p : particles) {
    head += " | " + std::to_string(p);
    rule += "|---:";
  }
  return head + " |\n" + rule + "|\n";
}

std::string StepsTable(const MclExperimentResult& r) {
  const MclExperimentOptions& o = r.options;
  std::string t =
      "Steps to converge after the kidnap (mean ± std over the converged seeds; updates until the "
      "estimate is within " +
      Fixed(o.converge_distance, 2) + " m and " + Fixed(o.converge_angle * 180 / kPi, 0) + "° of the truth for " +
      std::to_string(o.converge_hold) + " updates in a row; cap " + std::to_string(o.max_steps) +
      "), by particle count:\n\n" + ParticleHeader(o.particles, "world, method");
  for (const lidar::LidarWorld w : o.worlds) {
    for (const MclMethod m : o.methods) {
      t += std::string("| ") + WorldLabel(w) + ", " + MethodLabel(m);
      for (const MclExperimentRow* row : RowsOf(r, w, m)) t += " | " + StepsCell(*row);
      t += " |\n";
      if (w != lidar::LidarWorld::kMaze || !std::isfinite(ThesisSteps(m, o.particles.front()))) continue;
      t += std::string("| thesis (Table 5.1), maze, ") + MethodLabel(m);
      for (const int p : o.particles) t += " | " + Fixed(ThesisSteps(m, p), 0);
      t += " |\n";
    }
  }
  return t;
}

std::string RatioTable(const MclExperimentResult& r) {
  const MclExperimentOptions& o = r.options;
  std::string t =
      "Recovery ratio (particles re-drawn or injected after the kidnap, up to convergence, that land "
      "within " +
      Fixed(o.near_radius, 2) + " m of the true position; pose: also within " + Fixed(o.near_angle * 180 / kPi, 0) +
      "° of its heading), all particle counts together; the thesis's Table 5.2 beside:\n\n"
      "| method";
  std::string rule = "|---";
  for (const lidar::LidarWorld w : o.worlds) {
    t += std::string(" | ") + WorldLabel(w) + ": position | " + WorldLabel(w) + ": pose | " + WorldLabel(w) +
         ": re-drawn";
    rule += "|---:|---:|---:";
  }
  t += " | thesis: maze | thesis: larger map |\n" + rule + "|---:|---:|\n";
  for (const MclMethod m : o.methods) {
    t += std::string("| ") + MethodLabel(m);
    for (const lidar::LidarWorld w : o.worlds) {
      std::int64_t redrawn = 0, near = 0, near_pose = 0;
      for (const MclExperimentRow* row : RowsOf(r, w, m)) {
        for (const KidnapRun& run : row->runs) {
          redrawn += run.redrawn;
          near += run.near;
          near_pose += run.near_pose;
        }
      }
      const double n = static_cast<double>(redrawn);
      t += " | " + (redrawn > 0 ? Percent(static_cast<double>(near) / n, 2) : "-") + " | " +
           (redrawn > 0 ? Percent(static_cast<double>(near_pose) / n, 3) : "-") + " | " + std::to_string(redrawn);
    }
    t += " | " + Percent(ThesisRatio(m, lidar::LidarWorld::kMaze), 2) + " | " +
         Percent(ThesisRatio(m, lidar::LidarWorld::kOffice), 2) + " |\n";
  }
  t += "\nA uniform draw's expectation (pi r^2 / area, r = " + Fixed(o.near_radius, 2) + " m):";
  for (const MclWorldFigures& f : r.worlds) {
    t += std::string(" ") + WorldLabel(f.world) + ": free space " + Fixed(f.free_area, 0) + " m² (amcl's draws) " +
         Percent(UniformDrawRatio(f.free_area, o.near_radius), 2) + ", costmap's valid cells " +
         Fixed(f.valid_area, 0) + " m² (cmcl's, acmcl's) " + Percent(UniformDrawRatio(f.valid_area, o.near_radius), 2) +
         "; mean jump " + Fixed(f.jump, 1) + " m.";
  }
  return t + "\n";
}

std::string PerCountTable(const MclExperimentResult& r, bool seconds) {
  const MclExperimentOptions& o = r.options;
  std::string t = seconds
                      ? "Seconds per run (mean over the seeds; the whole experiment " + Fixed(r.seconds, 0) + " s):\n\n"
                      : "Recovery ratio (position) by particle count:\n\n";
  t += ParticleHeader(o.particles, "world, method");
  for (const lidar::LidarWorld w : o.worlds) {
    for (const MclMethod m : o.methods) {
      t += std::string("| ") + WorldLabel(w) + ", " + MethodLabel(m);
      for (const MclExperimentRow* row : RowsOf(r, w, m))
        t += " | " + (seconds ? Fixed(row->SecondsMean(), 2) : Percent(row->RecoveryRatio(), 2));
      t += " |\n";
    }
  }
  return t;
}

}  // namespace

std::string MclExperimentTables(const MclExperimentResult& r) {
  return StepsTable(r) + "\n" + RatioTable(r) + "\n" + PerCountTable(r, false) + "\n" + PerCountTable(r, true);
}

}  // namespace localization
}  // namespace tether
