// The LiDAR pose graph: local SLAM's scans and submaps in, loop closures by branch and bound,
// the incremental smoother; on a simulated room driven twice around with drifting odometry.
#include "tether/frontends/lidar/pose_graph_2d.h"

#include <gtest/gtest.h>

#include <cmath>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/frontends/lidar/submap_2d.h"

namespace tether {
namespace lidar {
namespace {

using testing::Segment;

std::vector<Segment> World() {
  std::vector<Segment> s;
  testing::AddRectangle(0, 0, 24, 18, &s);
  testing::AddRectangle(3, 3, 4, 5, &s);
  testing::AddRectangle(19, 2, 21, 3, &s);
  testing::AddRectangle(11, 8, 13, 10.5, &s);
  testing::AddRectangle(5, 13, 8, 14, &s);
  testing::AddRectangle(18, 14, 19, 16, &s);
  return s;
}

// Two laps of a circle of radius 5 m around the room's centre in 0.25 m steps, and scans
// from the true poses. What local SLAM would give drifts: each step's relative motion turned by
// 0.0006 rad more than the truth's (4.3 degrees a lap).
struct Trip {
  std::vector<SE2d> truth, local;
  std::vector<std::vector<Eigen::Vector2d>> points;  // the robot's frame
};

Trip Drive() {
  Trip trip;
  const std::vector<Segment> world = World();
  for (int k = 0; k < 2 * 126; ++k) {
    const double a = 2 * M_PI * k / 126.0;
    const SE2d truth(12 + 5 * std::sin(a), 9 - 5 * std::cos(a), a);
    trip.truth.push_back(truth);
    trip.local.push_back(k == 0 ? truth
                                : trip.local.back() * (trip.truth[trip.truth.size() - 2].Inverse() * truth) *
                                      SE2d(0, 0, 0.0006));
    trip.points.push_back(testing::ScanPoints(world, truth, 360, 15));
  }
  return trip;
}

struct Result {
  std::vector<SE2d> poses, submap_poses;
  std::vector<LoopClosure> closures;
  PoseGraphStats stats;
  int submaps = 0;
};

// The scans inserted into submaps at their local poses (30 scans a submap), fed to the graph.
Result Slam(const Trip& trip, bool loop_closure, int threads, double rival_ratio = PoseGraphOptions().rival_ratio) {
  SubmapOptions so;
  so.scans_per_submap = 30;
  ActiveSubmaps2D submaps(so);
  PoseGraphOptions po;
  po.loop_closure = loop_closure;
  po.threads = threads;
  po.search_every_n_scans = 4;
  po.max_search_distance = 8;
  po.apply_every_n_scans = 20;
  po.rival_ratio = rival_ratio;
  PoseGraph2D graph(po);
  for (std::size_t k = 0; k < trip.local.size(); ++k) {
    const SE2d& pose = trip.local[k];
    std::vector<Eigen::Vector2d> in_map;
    for (const Eigen::Vector2d& p : trip.points[k]) in_map.push_back(pose * p);
    const InsertedSubmaps inserted = submaps.InsertScan(pose, pose.translation(), in_map);
    graph.AddScan(pose, trip.points[k], inserted);
  }
  graph.Finish();
  Result out;
  for (int i = 0; i < graph.scan_count(); ++i) out.poses.push_back(graph.ScanPose(i));
  for (int j = 0; j < graph.submap_count(); ++j) out.submap_poses.push_back(graph.SubmapPose(j));
  out.closures = graph.loop_closures();
  out.stats = graph.stats();
  out.submaps = graph.submap_count();
  return out;
}

double Rmse(const std::vector<SE2d>& a, const std::vector<SE2d>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i].translation() - b[i].translation()).squaredNorm();
  return std::sqrt(s / static_cast<double>(a.size()));
}

TEST(PoseGraph2DTest, LoopClosuresUndoTheDriftAndDoNotDependOnThreads) {
  const Trip run = Drive();
  const Result local_only = Slam(run, false, 0);
  EXPECT_EQ(local_only.stats.searches, 0);
  const double drifted = Rmse(local_only.poses, run.truth);
  EXPECT_GT(drifted, 0.3);  // the graph without closures keeps local SLAM's drift
  const Result inline_search = Slam(run, true, 0);
  ASSERT_EQ(inline_search.poses.size(), run.truth.size());
  EXPECT_GT(inline_search.submaps, 10);
  // Loop closures were found (fewer than the searches), and they take the drift out.
  EXPECT_GT(inline_search.closures.size(), 5u);
  EXPECT_GT(inline_search.stats.searches, static_cast<long>(inline_search.closures.size()));
  const double rmse = Rmse(inline_search.poses, run.truth);
  EXPECT_LT(rmse, 0.2 * drifted) << rmse << " against " << drifted;  // measured 0.016 against 0.447 m
  EXPECT_LT(rmse, 0.05);
  // Every closure is true by Hess et al.'s rule: the final solution keeps it (within 0.1 m and
  // 0.02 rad).
  for (const LoopClosure& c : inline_search.closures) {
    const SE2d kept = inline_search.submap_poses[static_cast<std::size_t>(c.submap)].Inverse() *
                      inline_search.poses[static_cast<std::size_t>(c.scan)];
    EXPECT_LT((kept.translation() - c.relative.translation()).norm(), 0.1) << c.scan << " in " << c.submap;
    EXPECT_LT(std::abs(WrapAngle(kept.theta() - c.relative.theta())), 0.02) << c.scan << " in " << c.submap;
    EXPECT_GT(c.score, 0.55);
  }
  // Background threads give the same result, bit for bit.
  for (int threads : {1, 2}) {
    const Result r = Slam(run, true, threads);
    ASSERT_EQ(r.poses.size(), inline_search.poses.size());
    ASSERT_EQ(r.closures.size(), inline_search.closures.size()) << threads;
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      ASSERT_EQ(r.poses[i].x(), inline_search.poses[i].x()) << threads << " scan " << i;
      ASSERT_EQ(r.poses[i].theta(), inline_search.poses[i].theta()) << threads << " scan " << i;
    }
  }
}

// Down a corridor 2 m wide and back, with scans that reach 5 m: the walls look the same
// anywhere along it, and the drift (each step 4% too long) puts the way back up to 3 m off the
// way out. Every match of the way back against the way out's submaps is ambiguous along the
// corridor; without the rival test some become closures the truth contradicts by metres.
TEST(PoseGraph2DTest, AmbiguousMatchesInACorridorAreDropped) {
  std::vector<Segment> world;
  testing::AddRectangle(0, 0, 60, 2, &world);
  Trip trip;
  for (int k = 0; k < 2 * 176; ++k) {
    const bool back = k >= 176;
    const double x = back ? 50 - 0.25 * (k - 176) : 6 + 0.25 * k;
    const SE2d truth(x, 1, back ? M_PI : 0);
    trip.truth.push_back(truth);
    if (k == 0) {
      trip.local.push_back(truth);
    } else {
      const SE2d step = trip.truth[trip.truth.size() - 2].Inverse() * truth;
      trip.local.push_back(trip.local.back() * SE2d(1.04 * step.x(), step.y(), step.theta()));
    }
    trip.points.push_back(testing::ScanPoints(world, truth, 360, 5));
  }
  // The truth's verdict on a closure: its relative pose against the true one.
  // A submap's frame is the local pose of the scan that started it (every 15th: 30 a submap).
  const auto error = [&](const LoopClosure& c) {
    const int first = c.submap * 15;
    const SE2d true_relative =
        trip.truth[static_cast<std::size_t>(first)].Inverse() * trip.truth[static_cast<std::size_t>(c.scan)];
    return (true_relative.translation() - c.relative.translation()).norm();
  };
  const Result kept_all = Slam(trip, true, 0, 0.0);
  ASSERT_GT(kept_all.closures.size(), 0u);
  EXPECT_EQ(kept_all.stats.ambiguous, 0);
  int wrong = 0;
  for (const LoopClosure& c : kept_all.closures) wrong += error(c) > 0.3 ? 1 : 0;
  EXPECT_GT(wrong, 0) << "of " << kept_all.closures.size();
  const Result checked = Slam(trip, true, 0);
  EXPECT_GT(checked.stats.ambiguous, 0);
  EXPECT_GT(checked.stats.on_edge, 0);  // pushed into the submap's known part, to the window's edge
  for (const LoopClosure& c : checked.closures) EXPECT_LT(error(c), 0.3) << c.scan << " in " << c.submap;
}

// Scans left out of the submaps (every second one here, as the motion filter would) are tied to
// the submaps the scan before them went into, by the local poses, and to no scan: no run of them
// hangs from one end only.
TEST(PoseGraph2DTest, ScansLeftOutOfTheSubmapsAreTiedToTheActiveOnes) {
  const Trip trip = Drive();
  SubmapOptions so;
  so.scans_per_submap = 30;
  ActiveSubmaps2D submaps(so);
  PoseGraphOptions po;
  po.loop_closure = false;
  PoseGraph2D graph(po);
  std::vector<std::vector<int>> active(trip.local.size());
  for (std::size_t k = 0; k < trip.local.size(); ++k) {
    const SE2d& pose = trip.local[k];
    InsertedSubmaps inserted;
    if (k % 2 == 0) {
      std::vector<Eigen::Vector2d> in_map;
      for (const Eigen::Vector2d& p : trip.points[k]) in_map.push_back(pose * p);
      inserted = submaps.InsertScan(pose, pose.translation(), in_map);
      for (const auto& [j, submap] : inserted) active[k].push_back(j);
    } else {
      active[k] = active[k - 1];
    }
    graph.AddScan(pose, trip.points[k], inserted);
  }
  graph.Finish();
  FactorGraph g;
  Values v;
  graph.Export(&g, &v);
  const Key n = static_cast<Key>(graph.scan_count());
  std::vector<std::vector<int>> tied(trip.local.size());
  for (std::size_t f = 0; f < g.size(); ++f) {
    const auto* b = dynamic_cast<const BetweenSE2*>(&g.at(f));
    if (b == nullptr) continue;
    const Key a = b->keys()[0], c = b->keys()[1];
    ASSERT_TRUE(a >= n && c < n) << "every edge runs from a submap to a scan, not " << a << " -> " << c;
    tied[c].push_back(static_cast<int>(a - n));
    // The measurement is local SLAM's relative pose.
    const SE2d expected = submaps.submaps()[a - n]->local_pose().Inverse() * trip.local[c];
    EXPECT_NEAR((b->measured().translation() - expected.translation()).norm(), 0, 1e-12);
  }
  for (std::size_t k = 0; k < trip.local.size(); ++k) EXPECT_EQ(tied[k], active[k]) << "scan " << k;
  // Without loop closures the graph keeps local SLAM's poses (up to the first scan's frame).
  for (std::size_t k = 0; k < trip.local.size(); ++k) {
    EXPECT_LT((graph.ScanPose(static_cast<int>(k)).translation() - trip.local[k].translation()).norm(), 1e-6);
  }
}

TEST(PoseGraph2DTest, RefusesInvalidRivalOptions) {
  PoseGraphOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.rival_ratio = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("rival_ratio"), std::string::npos);
  EXPECT_THROW(PoseGraph2D{o}, InvalidArgument);
  o = PoseGraphOptions();
  o.rival_distance = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o = PoseGraphOptions();
  o.rival_angle = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  o = PoseGraphOptions();
  o.search_voxel_size = -0.1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("search_voxel_size"), std::string::npos) << why;
  EXPECT_THROW(PoseGraph2D{o}, InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
