// The LiDAR pose graph: local SLAM's scans and submaps in, loop closures by branch and bound,
// the incremental smoother; on a simulated room driven twice around with drifting odometry.
#include "tether/frontends/lidar/mapping/pose_graph_2d.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"

namespace tether {
namespace lidar {
namespace {

using testing::Segment;

std::vector<Segment> World() { return testing::RoomWithBoxes(); }

// Two laps of a circle of radius 5 m around the room's centre in 0.25 m steps, and scans
// from the true poses. What local SLAM would give drifts: each step's relative motion turned by
// 0.0006 rad more than the truth's (4.3 degrees a lap).
struct Trip {
  std::vector<SE2d> truth, local;
  std::vector<std::vector<Eigen::Vector2d>> points;  // the robot's frame
  // Scan k -> the points the graph gets instead (the submaps still get `points`).
  std::map<std::size_t, std::vector<Eigen::Vector2d>> graph_points;
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

// The options of these tests: closures searched for every 4th scan, applied every 20, the
// smoother updated every 4th scan (as the defaults update at every searched scan).
PoseGraphOptions TestOptions(bool loop_closure, int threads) {
  PoseGraphOptions po;
  po.loop_closure = loop_closure;
  po.threads = threads;
  po.search_every_n_scans = 4;
  po.update_every_n_scans = 4;
  po.max_search_distance = 8;
  po.apply_every_n_scans = 20;
  return po;
}

// The scans inserted into submaps at their local poses (30 scans a submap), fed to the graph;
// the graph exported too where `exported` is given.
Result SlamWith(const Trip& trip, const PoseGraphOptions& po, FactorGraph* exported = nullptr) {
  SubmapOptions so;
  so.scans_per_submap = 30;
  ActiveSubmaps2D submaps(so);
  PoseGraph2D graph(po);
  for (std::size_t k = 0; k < trip.local.size(); ++k) {
    const SE2d& pose = trip.local[k];
    std::vector<Eigen::Vector2d> in_map;
    for (const Eigen::Vector2d& p : trip.points[k]) in_map.push_back(pose * p);
    const InsertedSubmaps inserted = submaps.InsertScan(pose, pose.translation(), in_map);
    const auto other = trip.graph_points.find(k);
    graph.AddScan(pose, other != trip.graph_points.end() ? other->second : trip.points[k], inserted);
  }
  graph.Finish();
  Result out;
  for (int i = 0; i < graph.scan_count(); ++i) out.poses.push_back(graph.ScanPose(i));
  for (int j = 0; j < graph.submap_count(); ++j) out.submap_poses.push_back(graph.SubmapPose(j));
  out.closures = graph.loop_closures();
  out.stats = graph.stats();
  out.submaps = graph.submap_count();
  if (exported != nullptr) {
    Values v;
    graph.Export(exported, &v);
  }
  return out;
}

Result Slam(const Trip& trip, bool loop_closure, int threads, double rival_ratio = PoseGraphOptions().rival_ratio,
            double window_growth = PoseGraphOptions().search_window_growth,
            double local_huber = PoseGraphOptions().local_huber_delta) {
  PoseGraphOptions po = TestOptions(loop_closure, threads);
  po.rival_ratio = rival_ratio;
  po.search_window_growth = window_growth;
  po.local_huber_delta = local_huber;
  return SlamWith(trip, po);
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

// Once around a block: a corridor 5 m wide between a 40 m x 30 m outer wall and the block,
// with pillars along both sides, driven along its centre line in 0.25 m steps and on past the
// start. Local SLAM creeps 1.5 cm east a step (turns exact): back at the start it is 7.2 m off,
// beyond branch and bound's 5 m half window. A search window that grows with the graph
// distance between the scan and the submap (a lap, 120 m) finds the way back; a fixed one
// does not.
Trip Lap() {
  std::vector<Segment> world;
  testing::AddRectangle(0, 0, 40, 30, &world);
  testing::AddRectangle(5, 5, 35, 25, &world);
  const auto pillar = [&](double x, double y) {
    testing::AddRectangle(x - 0.25, y - 0.25, x + 0.25, y + 0.25, &world);
  };
  for (double x : {3.1, 8.7, 12.2, 19.5, 24.1, 31.8, 36.3}) pillar(x, 0.25);
  for (double x : {4.4, 10.9, 17.3, 22.6, 29.9, 34.2}) pillar(x, 29.75);
  for (double y : {6.2, 11.8, 17.1, 23.4}) pillar(0.25, y);
  for (double y : {5.3, 9.9, 15.6, 21.7, 26.8}) pillar(39.75, y);
  for (double x : {7.5, 14.4, 21.1, 27.7, 33.0}) pillar(x, 4.75);
  for (double x : {9.2, 16.8, 25.3, 30.6}) pillar(x, 25.25);
  for (double y : {8.1, 13.9, 20.2}) pillar(4.75, y);
  for (double y : {7.4, 12.6, 18.8, 22.9}) pillar(35.25, y);
  const std::vector<Eigen::Vector2d> corners = {{2.5, 2.5},  {37.5, 2.5}, {37.5, 27.5},
                                                {2.5, 27.5}, {2.5, 2.5},  {17.5, 2.5}};
  Trip trip;
  for (std::size_t c = 0; c + 1 < corners.size(); ++c) {
    const Eigen::Vector2d d = corners[c + 1] - corners[c];
    const int n = static_cast<int>(std::lround(d.norm() / 0.25));
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2d at = corners[c] + d * (static_cast<double>(k) / n);
      const SE2d truth(at.x(), at.y(), std::atan2(d.y(), d.x()));
      const double creep = 0.015 * static_cast<double>(trip.truth.size());
      trip.truth.push_back(truth);
      trip.local.push_back(SE2d(truth.x() + creep, truth.y(), truth.theta()));
      trip.points.push_back(testing::ScanPoints(world, truth, 360, 10));
    }
  }
  return trip;
}

TEST(PoseGraph2DTest, AFarRevisitIsSearchedWithAWiderWindow) {
  const Trip lap = Lap();
  const std::size_t back = 480;  // the first scan back at the start
  // Closures of the way back against the first two submaps, and the worst of them against the
  // truth (a submap's frame is the local pose of the scan that started it: every 15th).
  const auto way_back = [&](const Result& r, double* worst) {
    int n = 0;
    *worst = 0;
    for (const LoopClosure& c : r.closures) {
      if (static_cast<std::size_t>(c.scan) < back || c.submap > 1) continue;
      ++n;
      const std::size_t first = static_cast<std::size_t>(c.submap) * 15;
      const SE2d truth = lap.truth[first].Inverse() * lap.truth[static_cast<std::size_t>(c.scan)];
      *worst = std::max(*worst, (truth.translation() - c.relative.translation()).norm());
    }
    return n;
  };
  const auto error = [&](const Result& r) {
    return (r.poses.back().translation() - lap.truth.back().translation()).norm();
  };
  double worst = 0;
  const Result fixed = Slam(lap, true, 0, PoseGraphOptions().rival_ratio, 0.0);
  // The fixed window never reaches the first submaps from the way back. (Where the end lands
  // then is not asserted: along the corridor, matches 7 m off that agree with local SLAM's
  // creep get through, and with them the end has come out 0.8 m to 8 m off under different
  // update schedules.)
  EXPECT_EQ(way_back(fixed, &worst), 0);
  const Result growing = Slam(lap, true, 0);
  EXPECT_GT(way_back(growing, &worst), 3);
  EXPECT_LT(worst, 0.5);           // the submaps are stretched by the creep; measured 0.17 m
  EXPECT_LT(error(growing), 1.0);  // measured 0.63 m
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
  po.consecutive_translation_sigma = po.consecutive_rotation_sigma = 0;  // only the scan-submap edges
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

// Consecutive scans tied by local SLAM's relative pose: the graph holds one such edge per pair,
// and the solution keeps consecutive scans nearer to local SLAM's relative poses than the
// scan-submap edges alone do, while the loop closures still take the drift out.
TEST(PoseGraph2DTest, ConsecutiveScansAreTiedByLocalSlamsRelativePose) {
  const Trip trip = Drive();
  const auto run = [&](double sigma_t, double sigma_r, std::vector<SE2d>* poses, FactorGraph* g) {
    PoseGraphOptions po = TestOptions(true, 0);
    po.consecutive_translation_sigma = sigma_t;
    po.consecutive_rotation_sigma = sigma_r;
    const Result r = SlamWith(trip, po, g);
    *poses = r.poses;
    return r.closures.size();
  };
  // The RMS difference between the solution's consecutive relative poses and local SLAM's.
  const auto local_gap = [&](const std::vector<SE2d>& poses) {
    double s = 0;
    for (std::size_t k = 1; k < poses.size(); ++k) {
      const SE2d solved = poses[k - 1].Inverse() * poses[k];
      const SE2d local = trip.local[k - 1].Inverse() * trip.local[k];
      s += (solved.translation() - local.translation()).squaredNorm();
    }
    return std::sqrt(s / static_cast<double>(poses.size() - 1));
  };
  std::vector<SE2d> loose, tied;
  FactorGraph g_loose, g_tied;
  const std::size_t closures_loose = run(0, 0, &loose, &g_loose);
  const std::size_t closures_tied = run(0.01, 0.002, &tied, &g_tied);
  ASSERT_GT(closures_loose, 5u);
  ASSERT_GT(closures_tied, 5u);
  const Key n = static_cast<Key>(trip.local.size());
  std::vector<int> edges(trip.local.size(), 0);
  for (std::size_t f = 0; f < g_tied.size(); ++f) {
    const auto* b = dynamic_cast<const BetweenSE2*>(&g_tied.at(f));
    if (b == nullptr || b->keys()[0] >= n || b->keys()[1] >= n) continue;
    const Key a = b->keys()[0], c = b->keys()[1];
    ASSERT_EQ(c, a + 1) << "a scan-scan edge joins consecutive scans";
    ++edges[c];
    const SE2d expected = trip.local[a].Inverse() * trip.local[c];
    EXPECT_NEAR((b->measured().translation() - expected.translation()).norm(), 0, 1e-12);
    EXPECT_NEAR(WrapAngle(b->measured().theta() - expected.theta()), 0, 1e-12);
  }
  for (std::size_t k = 1; k < edges.size(); ++k) EXPECT_EQ(edges[k], 1) << "scan " << k;
  EXPECT_EQ(g_tied.size(), g_loose.size() + (trip.local.size() - 1) + (closures_tied - closures_loose));
  const double gap_loose = local_gap(loose), gap_tied = local_gap(tied);
  // Measured 0.00033 m against 0.0026 m.
  EXPECT_LT(gap_tied, 0.5 * gap_loose) << gap_tied << " against " << gap_loose;
  EXPECT_LT(Rmse(tied, trip.truth), 0.05) << Rmse(loose, trip.truth);  // measured 0.034 (0.0078 untied)
  // Both sigmas or neither.
  PoseGraphOptions o;
  std::string why;
  EXPECT_GT(o.consecutive_translation_sigma, 0);  // on by default
  o.consecutive_rotation_sigma = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("consecutive"), std::string::npos) << why;
  o.consecutive_rotation_sigma = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  o.consecutive_rotation_sigma = 0.002;
  EXPECT_TRUE(o.IsValid(&why)) << why;
}

// Two laps of the room where local SLAM slips 0.4 m sideways once, at scan 40 of the first
// lap, and is right otherwise. The submaps around the slip hold scans from both sides of it,
// and every scan after it is tied to the ones before by the slip. The second lap's closures
// against the first submaps say where the scans after the slip really are. With quadratic ties
// across the slip pulling back, the scans after it stay further from the truth than with a
// Huber loss on the ties.
TEST(PoseGraph2DTest, ARobustLossOnTheLocalTiesLetsClosuresUndoASlip) {
  Trip trip = Drive();
  const std::size_t slip = 40;
  for (std::size_t k = 0; k < trip.local.size(); ++k) {
    trip.local[k] = k < slip ? trip.truth[k] : SE2d(0.4, 0, 0) * trip.truth[k];
  }
  const auto after_slip = [&](const Result& r) {
    double s = 0;
    for (std::size_t k = slip; k < trip.truth.size(); ++k) {
      s += (r.poses[k].translation() - trip.truth[k].translation()).squaredNorm();
    }
    return std::sqrt(s / static_cast<double>(trip.truth.size() - slip));
  };
  const Result quadratic =
      Slam(trip, true, 0, PoseGraphOptions().rival_ratio, PoseGraphOptions().search_window_growth, 0.0);
  const Result robust = Slam(trip, true, 0);  // the default delta
  ASSERT_GT(PoseGraphOptions().local_huber_delta, 0);
  // Measured 0.0048 m against 0.026 m (0.0084 m with a delta of 1).
  EXPECT_LT(after_slip(robust), 0.5 * after_slip(quadratic))
      << after_slip(robust) << " against " << after_slip(quadratic);
}

// Scans reach the smoother in batches: in between, a scan's estimate is the last estimate
// composed with local SLAM's motion, and the export holds the waiting nodes and ties too.
TEST(PoseGraph2DTest, ScansWaitingForAnUpdateFollowLocalSlam) {
  const Trip run = Drive();
  PoseGraphOptions po = TestOptions(false, 0);
  po.update_every_n_scans = 5;
  SubmapOptions so;
  so.scans_per_submap = 30;
  ActiveSubmaps2D submaps(so);
  PoseGraph2D graph(po);
  for (int k = 0; k < 48; ++k) {
    const SE2d& pose = run.local[static_cast<std::size_t>(k)];
    std::vector<Eigen::Vector2d> in_map;
    for (const Eigen::Vector2d& p : run.points[static_cast<std::size_t>(k)]) in_map.push_back(pose * p);
    graph.AddScan(pose, run.points[static_cast<std::size_t>(k)], submaps.InsertScan(pose, pose.translation(), in_map));
    EXPECT_EQ(graph.smoother().Estimate().Has(ScanKey(k)), k % 5 == 0) << k;
    if (k % 5 != 0) {
      const SE2d expect = graph.ScanPose(k - 1) * (run.local[static_cast<std::size_t>(k - 1)].Inverse() * pose);
      EXPECT_NEAR(graph.ScanPose(k).x(), expect.x(), 1e-12);
      EXPECT_NEAR(graph.ScanPose(k).y(), expect.y(), 1e-12);
      EXPECT_NEAR(graph.ScanPose(k).theta(), expect.theta(), 1e-12);
    }
  }
  EXPECT_EQ(graph.stats().updates, 10);  // scans 0, 5, ..., 45
  FactorGraph before;
  Values before_values;
  graph.Export(&before, &before_values);
  EXPECT_EQ(before_values.size(), static_cast<std::size_t>(graph.scan_count() + graph.submap_count()));
  graph.Finish();
  EXPECT_TRUE(graph.smoother().Estimate().Has(ScanKey(47)));
  FactorGraph after;
  Values after_values;
  graph.Export(&after, &after_values);
  EXPECT_EQ(before.size(), after.size());
  EXPECT_EQ(graph.smoother().graph().size(), after.size());
}

// Updating the smoother every 7th scan finds the loop closures and takes the drift out as
// updating after every scan does, in far fewer updates, and again the same on any thread count.
TEST(PoseGraph2DTest, UpdatesEveryFewScansGiveTheSameQuality) {
  const Trip run = Drive();
  PoseGraphOptions po = TestOptions(true, 0);
  po.update_every_n_scans = 1;
  const Result every = SlamWith(run, po);
  po.update_every_n_scans = 7;
  const Result batched = SlamWith(run, po);
  EXPECT_LT(batched.stats.updates, every.stats.updates / 3)
      << batched.stats.updates << " against " << every.stats.updates;
  EXPECT_GT(batched.closures.size(), 5u);
  const double rmse = Rmse(batched.poses, run.truth), rmse_every = Rmse(every.poses, run.truth);
  EXPECT_LT(rmse, 0.05) << rmse << " against " << rmse_every;
  po.threads = 2;
  const Result threaded = SlamWith(run, po);
  ASSERT_EQ(threaded.closures.size(), batched.closures.size());
  for (std::size_t i = 0; i < threaded.poses.size(); ++i) {
    ASSERT_EQ(threaded.poses[i].x(), batched.poses[i].x()) << i;
    ASSERT_EQ(threaded.poses[i].theta(), batched.poses[i].theta()) << i;
  }
}

// The drive, with the points the graph gets for scan 200 taken 2 m east of where the robot is
// (a glitch; the submaps get the true ones): that scan's match lands 2 m off, and no match of
// a neighbouring scan agrees with it, so it is never added. Without confirmation it is.
TEST(PoseGraph2DTest, AMatchNoOtherConfirmsIsNotAdded) {
  Trip run = Drive();
  const int glitch = 200;
  run.graph_points[glitch] = testing::ScanPoints(World(), SE2d(2, 0, 0) * run.truth[glitch], 360, 15);
  const auto slam = [&](const PoseGraphOptions& po) { return SlamWith(run, po); };
  // The truth's verdict on a closure (a submap's frame: the local pose of every 15th scan).
  const auto error = [&](const LoopClosure& c) {
    const SE2d true_relative =
        run.truth[static_cast<std::size_t>(c.submap) * 15].Inverse() * run.truth[static_cast<std::size_t>(c.scan)];
    return (true_relative.translation() - c.relative.translation()).norm();
  };
  PoseGraphOptions po = TestOptions(true, 0);
  po.confirm_translation = 0;
  const Result as_found = slam(po);
  EXPECT_EQ(as_found.stats.unconfirmed, 0);
  EXPECT_EQ(as_found.stats.found, static_cast<long>(as_found.closures.size()));
  double glitch_error = 0;
  for (const LoopClosure& c : as_found.closures) {
    if (c.scan == glitch) glitch_error = std::max(glitch_error, error(c));
  }
  EXPECT_GT(glitch_error, 1.0);
  const Result confirmed = slam(TestOptions(true, 0));
  EXPECT_GT(confirmed.stats.unconfirmed, 0);
  EXPECT_EQ(confirmed.stats.found - confirmed.stats.unconfirmed, static_cast<long>(confirmed.closures.size()));
  EXPECT_GT(confirmed.closures.size(), 5u);
  for (const LoopClosure& c : confirmed.closures) {
    EXPECT_NE(c.scan, glitch);
    EXPECT_LT(error(c), 0.3) << c.scan << " in " << c.submap;
    // Every closure added has a partner that agrees with it by the rule.
    bool partner = false;
    for (const LoopClosure& d : confirmed.closures) {
      if (d.submap != c.submap || d.scan == c.scan || std::abs(d.scan - c.scan) > 200) continue;
      const SE2d local =
          run.local[static_cast<std::size_t>(c.scan)].Inverse() * run.local[static_cast<std::size_t>(d.scan)];
      const SE2d e = local.Inverse() * (c.relative.Inverse() * d.relative);
      partner = partner ||
                (local.translation().norm() >= 0.1 && e.translation().norm() < 0.2 && std::abs(e.theta()) < 0.0175);
    }
    EXPECT_TRUE(partner) << c.scan << " in " << c.submap;
  }
}

// The scans searched for loop closures: every search_every_n_scans-th, and sooner where the
// robot travelled search_every_metres since the last searched one (a log thinned in time or
// recorded only where the robot moved far is searched as densely in space).
std::vector<int> SampledScans(double metres) {
  PoseGraphOptions po;
  po.loop_closure = false;
  po.threads = 0;
  po.search_every_n_scans = 10;
  po.search_every_metres = metres;
  PoseGraph2D graph(po);
  const std::vector<Eigen::Vector2d> points{{1, 0}, {0, 1}, {-1, 0}};
  double x = 0;
  for (int i = 0; i < 40; ++i) {
    x += i == 0 ? 0.0 : (i <= 15 ? 0.75 : 0.01);  // 0.75 m a scan, then nearly standing
    graph.AddScan(SE2d(x, 0, 0), points, {});
  }
  std::vector<int> sampled;
  for (int i = 0; i < graph.scan_count(); ++i) {
    if (graph.constraint_builder().sampled(i)) sampled.push_back(i);
  }
  return sampled;
}

TEST(PoseGraph2DTest, ScansAreSearchedByCountOrByTheDistanceTravelled) {
  EXPECT_EQ(SampledScans(2.0), (std::vector<int>{0, 3, 6, 9, 12, 15, 25, 35}));
  EXPECT_EQ(SampledScans(0.0), (std::vector<int>{0, 10, 20, 30}));
  PoseGraphOptions o;
  std::string why;
  o.search_every_metres = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("search_every_metres"), std::string::npos) << why;
  o.search_every_metres = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.IsValid(&why));
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
  o = PoseGraphOptions();
  o.search_window_growth = -0.01;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("search_window_growth"), std::string::npos) << why;
  o = PoseGraphOptions();
  o.max_search_window = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_search_window"), std::string::npos) << why;
  o = PoseGraphOptions();
  o.local_huber_delta = -0.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("local_huber_delta"), std::string::npos) << why;
  o.local_huber_delta = 0;  // quadratic ties
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o = PoseGraphOptions();
  o.confirm_rotation = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("confirm_rotation"), std::string::npos) << why;
  o = PoseGraphOptions();
  o.confirm_max_scans = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o = PoseGraphOptions();
  o.confirm_translation = -1;
  EXPECT_FALSE(o.IsValid(&why));
  o.confirm_translation = 0;  // every match added
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o = PoseGraphOptions();
  o.update_every_n_scans = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("update_every_n_scans"), std::string::npos) << why;
  o = PoseGraphOptions();
  o.max_search_window = 1;  // below the base window: the base window is searched
  EXPECT_TRUE(o.IsValid(&why)) << why;
}

}  // namespace
}  // namespace lidar
}  // namespace tether

namespace tether {
namespace lidar {
namespace {

// A kidnap: the first lap as trajectory 0; then the robot is carried a quarter lap on and
// local SLAM starts afresh (its own frame: the first scan of the new trajectory at the
// origin, turned). The new trajectory is held out of the smoother until the global search
// finds it in the first lap's submaps; then it is moved there, and after Finish both laps lie
// on the truth in the first trajectory's frame.
TEST(PoseGraph2DTest, ANewTrajectoryJoinsTheMapByAGlobalSearch) {
  const Trip run = Drive();
  PoseGraphOptions po = TestOptions(true, 0);
  po.global_search_every_n_scans = 8;
  SubmapOptions so;
  so.scans_per_submap = 30;
  auto submaps = std::make_unique<ActiveSubmaps2D>(so);
  PoseGraph2D graph(po);
  const std::size_t cut = 126, resume = 160;
  const SE2d new_frame = SE2d(-3, 40, 2.0) * run.truth[resume].Inverse();  // truth -> the new local frame
  std::vector<std::size_t> used;                                           // the trip's scan of each graph scan
  for (std::size_t k = 0; k < run.truth.size(); ++k) {
    if (k >= cut && k < resume) continue;
    if (k == resume) {
      graph.StartTrajectory(submaps->FinishActive());
      submaps = std::make_unique<ActiveSubmaps2D>(so);
    }
    const SE2d pose = k < cut ? run.truth[k] : new_frame * run.truth[k];
    std::vector<Eigen::Vector2d> in_map;
    for (const Eigen::Vector2d& p : run.points[k]) in_map.push_back(pose * p);
    graph.AddScan(pose, run.points[k], submaps->InsertScan(pose, pose.translation(), in_map));
    used.push_back(k);
    if (k == resume) {
      // Held out, placed where the last scan before ended: not yet where it belongs.
      EXPECT_EQ(graph.trajectory_count(), 2);
      EXPECT_EQ(graph.TrajectoryJoinedAt(1), -1);
      const int last = graph.scan_count() - 1;
      // (the update at this scan may have moved the scan before a little since)
      EXPECT_LT((graph.ScanPose(last).translation() - graph.ScanPose(last - 1).translation()).norm(), 0.1);
      EXPECT_GT((graph.ScanPose(last).translation() - run.truth[resume].translation()).norm(), 1);
    }
  }
  graph.Finish();
  EXPECT_EQ(graph.TrajectoryFirstScan(1), static_cast<int>(cut));
  ASSERT_GE(graph.TrajectoryJoinedAt(1), static_cast<int>(cut) + 1);
  EXPECT_GT(graph.stats().global_searches, 0);
  double worst = 0;
  for (int i = 0; i < graph.scan_count(); ++i) {
    worst = std::max(
        worst, (graph.ScanPose(i).translation() - run.truth[used[static_cast<std::size_t>(i)]].translation()).norm());
  }
  EXPECT_LT(worst, 0.05);
  // Closures of the second trajectory reach the first's submaps.
  int cross = 0;
  for (const LoopClosure& c : graph.loop_closures())
    cross += c.scan >= static_cast<int>(cut) && c.submap < graph.TrajectoryFirstSubmap(1);
  EXPECT_GE(cross, 2);
}

// A trajectory that never sees the map again stays out of it: placed to its right, held by a
// prior, its own shape kept.
TEST(PoseGraph2DTest, ATrajectoryNeverJoinedIsPlacedBesideTheMap) {
  const Trip run = Drive();
  PoseGraphOptions po = TestOptions(false, 0);  // no searches at all: nothing can join it
  SubmapOptions so;
  so.scans_per_submap = 30;
  auto submaps = std::make_unique<ActiveSubmaps2D>(so);
  PoseGraph2D graph(po);
  for (std::size_t k = 0; k < 120; ++k) {
    if (k == 60) {
      graph.StartTrajectory(submaps->FinishActive());
      submaps = std::make_unique<ActiveSubmaps2D>(so);
    }
    const SE2d& pose = run.truth[k];
    std::vector<Eigen::Vector2d> in_map;
    for (const Eigen::Vector2d& p : run.points[k]) in_map.push_back(pose * p);
    graph.AddScan(pose, run.points[k], submaps->InsertScan(pose, pose.translation(), in_map));
  }
  graph.Finish();
  EXPECT_EQ(graph.TrajectoryJoinedAt(1), -1);
  double right = -1e9, left = 1e9;
  for (int i = 0; i < 60; ++i) right = std::max(right, graph.ScanPose(i).x());
  for (int i = 60; i < 120; ++i) left = std::min(left, graph.ScanPose(i).x());
  EXPECT_NEAR(left - right, 5, 1e-6);
  for (int i = 61; i < 120; ++i) {
    const SE2d a = graph.ScanPose(i - 1).Inverse() * graph.ScanPose(i);
    const SE2d b = run.truth[static_cast<std::size_t>(i - 1)].Inverse() * run.truth[static_cast<std::size_t>(i)];
    EXPECT_LT((a.translation() - b.translation()).norm(), 1e-6) << i;
  }
  // Submaps given to StartTrajectory must be finished.
  SubmapOptions other;
  ActiveSubmaps2D fresh(other);
  const InsertedSubmaps unfinished = fresh.InsertScan(SE2d(), Eigen::Vector2d::Zero(), run.points[0]);
  PoseGraph2D g2(po);
  EXPECT_THROW(g2.StartTrajectory(unfinished), InvalidArgument);
  EXPECT_THROW(g2.StartTrajectory({{0, nullptr}}), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
