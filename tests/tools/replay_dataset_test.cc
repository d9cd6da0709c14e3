// tether replay on every public 2D and 3D pose graph (../shared/datasets/g2o): each file fed
// to the incremental smoother pose by pose, with --check batch solves on the way: after every
// update on the files where that is cheap (a few seconds), else at about 20 to 100 points.
//
// The same in the smoother's local mode on six of the files.
//
// Asserted per file: one update per pose; every check's online chi2 (computed from the
// smoother's graph and estimate) within 1e-3 relative of the batch optimum of the graph so
// far; and the chi2 after Finish within 1e-6 relative of the batch optimum of the whole file
// (Optimize from the chordal start).
//
// sphere2500 takes a minute or two, so they are a program of their own with the ctest label
// `replay_datasets`: `ctest -L replay_datasets` runs them, `ctest -LE replay_datasets` leaves
// them out (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <iostream>
#include <ostream>
#include <string>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/tools/replay.h"

namespace tether {
namespace {

struct Dataset {
  const char* file;
  int checks;  // about this many --check batch solves; 0: after every update
};

void PrintTo(const Dataset& d, std::ostream* os) { *os << d.file; }

const Dataset kDatasets[] = {
    {"CSAIL.g2o", 0},       {"MIT.g2o", 0},         {"ais2klinik.g2o", 20}, {"input_M3500_g2o.g2o", 100},
    {"intel.g2o", 0},       {"kitti_00.g2o", 20},   {"manhattan.g2o", 100}, {"parking-garage.g2o", 100},
    {"smallGrid3D.g2o", 0}, {"sphere2500.g2o", 20}, {"tinyGrid3D.g2o", 0},
};

constexpr double kFinalTolerance = 1e-6;  // final chi2 against the batch optimum, relative
constexpr double kCheckTolerance = 1e-3;  // online chi2 against the optimum so far, relative

std::string DatasetPath(const std::string& name) { return std::string(TETHER_DATASETS_DIR) + "/g2o/" + name; }

// The number of poses (SE2 and SE3 variables) of a graph file, as read (files of edges alone
// get their variables from the edges).
std::size_t CountPoses(const std::string& path) {
  const GraphFile f = ReadGraphFile(path, DefaultRegistry());
  return f.values.Count(VarType::kSE2) + f.values.Count(VarType::kSE3);
}

// Replays `d` in `mode` and asserts the above.
void ReplayAndCheck(const Dataset& d, SmootherMode mode) {
  const std::string path = DatasetPath(d.file);
  if (!std::ifstream(path).good()) {
    GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  }
  const std::size_t poses = CountPoses(path);
  ASSERT_GT(poses, 0u);
  ReplayOptions options;
  options.smoother.mode = mode;
  const int checks = d.checks;
  options.check = checks == 0 ? 1 : static_cast<int>(std::max<std::size_t>(1, poses / checks));

  const auto t0 = std::chrono::steady_clock::now();
  const ReplayResult r = ReplayFile(path, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(r.status, ReplayStatus::kDone) << r.message;
  ::testing::Test::RecordProperty("replay_seconds", std::to_string(r.total_seconds()));
  std::cout << d.file << (mode == SmootherMode::kLocal ? " (local mode)" : "") << ": " << r.poses << " poses, replay "
            << r.total_seconds() << " s (p99 " << 1e3 * r.p99_seconds << " ms), whole test " << seconds << " s with "
            << r.checks.size() << " checks (largest gap " << r.max_check_gap << "), final gap " << r.relative_gap
            << ", peak " << r.peak_rss_mib << " MiB\n";

  EXPECT_EQ(r.poses, poses);
  EXPECT_EQ(r.latencies.size(), r.poses) << "one update per pose";
  // Every update is checked but the first where checks is 0 or more than the poses.
  const std::size_t expected = checks == 0 ? poses - 1 : std::min<std::size_t>(checks, poses - 1);
  EXPECT_GE(r.checks.size(), expected);
  for (const ReplayCheck& c : r.checks) {
    EXPECT_LE(c.gap, kCheckTolerance) << "check at step " << c.step << ": online chi2 " << c.online_chi2 << ", batch "
                                      << c.batch_chi2;
  }
  EXPECT_NEAR(r.final_chi2, r.batch_chi2, kFinalTolerance * r.batch_chi2)
      << "final chi2 " << r.final_chi2 << ", batch optimum " << r.batch_chi2;
}

std::string TestName(const ::testing::TestParamInfo<Dataset>& i) {
  std::string n = i.param.file;
  n = n.substr(0, n.rfind('.'));
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

class ReplayDatasetTest : public ::testing::TestWithParam<Dataset> {};

TEST_P(ReplayDatasetTest, ReachesTheBatchOptimum) { ReplayAndCheck(GetParam(), SmootherMode::kFactor); }

INSTANTIATE_TEST_SUITE_P(G2o, ReplayDatasetTest, ::testing::ValuesIn(kDatasets), TestName);

// The local mode (SmootherMode::kLocal) on files of every kind: 2D and 3D, a small chi2
// (parking-garage: 1.2 over 1661 poses, where an absolute edge tolerance failed), and
// ais2klinik (where Levenberg-Marquardt alone stopped 1.3e-5 short after the replay).
const Dataset kLocalDatasets[] = {
    {"intel.g2o", 50},      {"input_M3500_g2o.g2o", 50}, {"parking-garage.g2o", 50},
    {"ais2klinik.g2o", 20}, {"sphere2500.g2o", 20},      {"smallGrid3D.g2o", 0},
};

class LocalReplayDatasetTest : public ::testing::TestWithParam<Dataset> {};

TEST_P(LocalReplayDatasetTest, ReachesTheBatchOptimum) { ReplayAndCheck(GetParam(), SmootherMode::kLocal); }

INSTANTIATE_TEST_SUITE_P(G2o, LocalReplayDatasetTest, ::testing::ValuesIn(kLocalDatasets), TestName);

}  // namespace
}  // namespace tether
