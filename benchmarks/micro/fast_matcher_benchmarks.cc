// Branch and bound against the exhaustive search of the same candidates, for loop closure on
// the corrected Intel log: a map of its first 200 scans (endpoints as hits), 16 of those scans
// searched from guesses up to 1 m and 5 degrees off, in a 7 m x 7 m x 30 degree window.
// Counters: nodes scored and the share of searches that found the scan within 0.1 m.
#include <benchmark/benchmark.h>

#include <fstream>
#include <random>

#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"

namespace tether {
namespace lidar {
namespace {

struct Scene {
  ProbabilityGrid grid{0.05};
  std::vector<std::vector<Eigen::Vector2d>> points;
  std::vector<SE2d> truth, guesses;
  bool ok = false;
};

const Scene& IntelScene() {
  static Scene s;
  static bool made = false;
  if (made) return s;
  made = true;
  const std::string path = std::string(TETHER_DATASETS_LIDAR) + "/corrected/intel-corrected.log.gz";
  if (!std::ifstream(path).good()) return s;
  LidarReadOptions ro;
  ro.limits.max_range = 15;
  const LidarLog log = ReadLidarLog(path, ro);
  for (std::size_t i = 0; i < 200 && i < log.scans.size(); ++i) {
    const SE2d laser = log.scans[i].odometry * log.scans[i].laser_in_robot;
    for (const Eigen::Vector2d& p : ScanToPoints(log.scans[i], ro.limits))
      s.grid.SetProbability(s.grid.CellOf(laser * p), 0.9);
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (std::size_t i = 5; i < 200; i += 12) {
    s.points.push_back(ScanToPoints(log.scans[i], ro.limits));
    const SE2d t = log.scans[i].odometry * log.scans[i].laser_in_robot;
    s.truth.push_back(t);
    s.guesses.push_back(SE2d(t.x() + u(rng), t.y() + u(rng), t.theta() + 0.087 * u(rng)));
  }
  s.ok = true;
  return s;
}

void Search(benchmark::State& state, bool exhaustive) {
  const Scene& s = IntelScene();
  if (!s.ok) {
    state.SkipWithError("lidar/corrected/intel-corrected.log.gz absent (../shared/datasets not beside the repository)");
    return;
  }
  const FastCorrelativeScanMatcher2D matcher(s.grid);  // 7 m x 7 m x 30 degrees, depth 7
  std::size_t q = 0;
  long nodes = 0, searches = 0, right = 0;
  for (auto _ : state) {
    const FastMatch m = exhaustive ? matcher.MatchExhaustive(s.guesses[q], s.points[q], 0.5)
                                   : matcher.Match(s.guesses[q], s.points[q], 0.5);
    nodes += m.nodes;
    ++searches;
    if (m.found && (m.pose.translation() - s.truth[q].translation()).norm() < 0.1) ++right;
    q = (q + 1) % s.points.size();
  }
  state.counters["nodes_per_search"] = static_cast<double>(nodes) / static_cast<double>(searches);
  state.counters["found_right"] = static_cast<double>(right) / static_cast<double>(searches);
}

void BM_BranchAndBound(benchmark::State& state) { Search(state, false); }
void BM_ExhaustiveSearch(benchmark::State& state) { Search(state, true); }
BENCHMARK(BM_BranchAndBound)->Unit(benchmark::kMillisecond)->Iterations(48);
BENCHMARK(BM_ExhaustiveSearch)->Unit(benchmark::kMillisecond)->Iterations(16);

}  // namespace
}  // namespace lidar
}  // namespace tether
