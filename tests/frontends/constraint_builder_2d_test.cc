// The loop-closure search on its own: a submap of a simulated room, scans that revisit it with
// a drifted estimate, and a scan of another room placed where the graph thinks it lies.
#include "tether/frontends/lidar/mapping/constraint_builder_2d.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/mapping/probability_grid_inserter.h"

namespace tether {
namespace lidar {
namespace {

using testing::Segment;

constexpr int kBeams = 360;
constexpr double kMaxRange = 15;

std::vector<Eigen::Vector2d> Scan(const std::vector<Segment>& world, const SE2d& pose) {
  return testing::ScanPoints(world, pose, kBeams, kMaxRange);
}

// A room unlike RoomWithBoxes: 10 m x 6 m with one box.
std::vector<Segment> OtherRoom() {
  std::vector<Segment> s;
  testing::AddRectangle(0, 0, 10, 6, &s);
  testing::AddRectangle(6, 2, 7, 2.5, &s);
  return s;
}

// Twenty scans along 4 m of RoomWithBoxes, turning as they go, inserted at their true poses
// into one submap (its frame: the first scan's pose), which is then finished.
struct Room {
  std::vector<Segment> world = testing::RoomWithBoxes();
  std::vector<SE2d> poses;
  std::vector<std::vector<Eigen::Vector2d>> points;
  std::shared_ptr<Submap2D> submap;

  Room() {
    SubmapOptions so;
    const ProbabilityGridInserter inserter(so.insert, so.min_probability, so.max_probability);
    for (int k = 0; k < 20; ++k) poses.emplace_back(4 + 0.2 * k, 7 + 0.05 * k, 0.03 * k);
    submap = std::make_shared<Submap2D>(poses[0], so);
    for (const SE2d& pose : poses) {
      points.push_back(Scan(world, pose));
      std::vector<Eigen::Vector2d> in_map;
      for (const Eigen::Vector2d& p : points.back()) in_map.push_back(pose * p);
      submap->InsertScan(inserter, pose.translation(), in_map);
    }
    submap->Finish();
  }
};

struct Outcome {
  std::vector<LoopClosure> first, second;  // TakeClosures after the submap is finished, and at the end
  ConstraintBuilderStats after_first, stats;
};

struct Trial {
  int threads = 0;
  double confirm_translation = 0.2;
  SE2d b_slip;  // local SLAM's error in b: its local pose is b * b_slip
};

// The graph's estimate of a revisit: 0.58 m and 2.9 degrees off the truth.
SE2d Drifted(const SE2d& truth) { return SE2d(truth.x() + 0.5, truth.y() - 0.3, truth.theta() + 0.05); }

// The room's scans in its submap; then, in no submap, two revisits of it (true poses a and b)
// whose estimates drifted; the submap finished (searching the first revisit); the second
// revisit and a scan of OtherRoom with an estimate beside them searched.
Outcome Revisit(const Room& room, const SE2d& a, const SE2d& b, const Trial& trial = {}) {
  std::vector<SE2d> estimates = room.poses;
  ConstraintBuilderOptions options;
  options.threads = trial.threads;
  options.search_every_n_scans = 1;
  options.confirm_translation = trial.confirm_translation;
  ConstraintBuilder2D builder(options, GraphEstimates{[&](int i) { return estimates[static_cast<std::size_t>(i)]; },
                                                      [&](int) { return room.submap->local_pose(); }});
  builder.AddSubmap(room.submap);
  for (std::size_t k = 0; k < room.poses.size(); ++k) builder.AddScan(room.poses[k], room.points[k], {0});
  // Scans of the submap are never searched against it.
  builder.SearchScan(0);
  Outcome out;
  EXPECT_TRUE(builder.TakeClosures().empty());
  EXPECT_EQ(builder.stats().searches, 0);

  builder.AddScan(a, Scan(room.world, a), {});
  estimates.push_back(Drifted(a));
  builder.FinishSubmap(0);
  out.first = builder.TakeClosures();
  out.after_first = builder.stats();

  builder.AddScan(b * trial.b_slip, Scan(room.world, b), {});
  estimates.push_back(Drifted(b));
  builder.SearchScan(21);
  const SE2d elsewhere(5, 3, 0.2);  // in OtherRoom, its estimate beside b's
  builder.AddScan(b * trial.b_slip, Scan(OtherRoom(), elsewhere), {});
  estimates.push_back(Drifted(b));
  builder.SearchScan(22);
  out.second = builder.TakeClosures();
  out.stats = builder.stats();
  return out;
}

TEST(ConstraintBuilder2DTest, FindsARevisitWithItsRelativePoseAndNotAScanFromElsewhere) {
  const Room room;
  const SE2d a(6.1, 7.6, 0.45), b(6.9, 7.3, 0.6);
  const Outcome run = Revisit(room, a, b);
  // The first revisit alone: found, but no second opinion yet.
  EXPECT_TRUE(run.first.empty());
  EXPECT_EQ(run.after_first.searches, 1);
  EXPECT_EQ(run.after_first.found, 1);
  EXPECT_EQ(run.after_first.unconfirmed, 1);
  // The second agrees with it: both are closures, at the true relative pose.
  ASSERT_EQ(run.second.size(), 2u);
  EXPECT_EQ(run.stats.searches, 3);
  EXPECT_EQ(run.stats.found, 2);
  EXPECT_EQ(run.stats.unconfirmed, 0);
  const SE2d& origin = room.submap->local_pose();
  for (const LoopClosure& c : run.second) {
    EXPECT_EQ(c.submap, 0);
    ASSERT_TRUE(c.scan == 20 || c.scan == 21) << c.scan;  // never 22, the other room's
    const SE2d truth = origin.Inverse() * (c.scan == 20 ? a : b);
    EXPECT_LT((c.relative.translation() - truth.translation()).norm(), 0.05) << c.scan;  // a cell
    EXPECT_LT(std::abs(c.relative.theta() - truth.theta()), 0.01) << c.scan;
    EXPECT_GT(c.score, ConstraintBuilderOptions().min_score);
  }
  EXPECT_NE(run.second[0].scan, run.second[1].scan);
}

// Background threads give the same closures, bit for bit, as searching in the caller's thread.
TEST(ConstraintBuilder2DTest, ClosuresDoNotDependOnThreads) {
  const Room room;
  const SE2d a(6.1, 7.6, 0.45), b(6.9, 7.3, 0.6);
  const Outcome inline_search = Revisit(room, a, b);
  for (int threads : {1, 3}) {
    Trial trial;
    trial.threads = threads;
    const Outcome r = Revisit(room, a, b, trial);
    EXPECT_EQ(r.stats.searches, inline_search.stats.searches) << threads;
    ASSERT_EQ(r.second.size(), inline_search.second.size()) << threads;
    for (std::size_t c = 0; c < r.second.size(); ++c) {
      EXPECT_EQ(r.second[c].scan, inline_search.second[c].scan) << threads;
      EXPECT_EQ(r.second[c].relative.x(), inline_search.second[c].relative.x()) << threads;
      EXPECT_EQ(r.second[c].relative.y(), inline_search.second[c].relative.y()) << threads;
      EXPECT_EQ(r.second[c].relative.theta(), inline_search.second[c].relative.theta()) << threads;
      EXPECT_EQ(r.second[c].score, inline_search.second[c].score) << threads;
    }
  }
}

// Without the second opinion a match is a closure as soon as it is found.
TEST(ConstraintBuilder2DTest, WithoutConfirmationAMatchIsAClosureAtOnce) {
  const Room room;
  Trial trial;
  trial.confirm_translation = 0;
  const Outcome run = Revisit(room, SE2d(6.1, 7.6, 0.45), SE2d(6.9, 7.3, 0.6), trial);
  ASSERT_EQ(run.first.size(), 1u);
  EXPECT_EQ(run.first[0].scan, 20);
  ASSERT_EQ(run.second.size(), 1u);
  EXPECT_EQ(run.second[0].scan, 21);
  EXPECT_EQ(run.stats.unconfirmed, 0);
}

// Two views from the same spot are no second opinion: the match stays unconfirmed.
TEST(ConstraintBuilder2DTest, TheSameViewAgainDoesNotConfirm) {
  const Room room;
  const SE2d a(6.1, 7.6, 0.45);
  const Outcome run = Revisit(room, a, a * SE2d(0.02, 0, 0.01));
  EXPECT_TRUE(run.second.empty());
  EXPECT_EQ(run.stats.found, 2);
  EXPECT_EQ(run.stats.unconfirmed, 2);
}

// Where local SLAM's relative pose between the two revisits is 0.3 m (or 2 degrees) off the
// one their matches imply, neither confirms the other.
TEST(ConstraintBuilder2DTest, MatchesThatDisagreeWithLocalSlamDoNotConfirm) {
  const Room room;
  for (const SE2d& slip : {SE2d(0.3, 0, 0), SE2d(0, 0, 0.035)}) {
    Trial trial;
    trial.b_slip = slip;
    const Outcome run = Revisit(room, SE2d(6.1, 7.6, 0.45), SE2d(6.9, 7.3, 0.6), trial);
    EXPECT_TRUE(run.second.empty()) << slip.x() << " " << slip.theta();
    EXPECT_EQ(run.stats.found, 2);
    EXPECT_EQ(run.stats.unconfirmed, 2);
  }
}

// A trajectory not yet joined (a kidnap) sees submap A of the map (a room), drives 60 m by
// local SLAM, then sees submap B (another room, 38 m away). Local SLAM drifted 1.2 m on the
// way: the motion between the two views that the closures imply is 1.2 m from local SLAM's.
// That is within the drift local SLAM may gather over 60 m (join_drift): the trajectory joins,
// with the closures to both. Held to the fixed tolerance alone (join_drift 0: 1 m), it does
// not.
int JoinAfterADetour(double join_drift, std::vector<LoopClosure>* closures) {
  std::vector<Segment> world = testing::RoomWithBoxes();
  testing::AddRectangle(40, 0, 50, 6, &world);  // OtherRoom, 40 m to the right
  testing::AddRectangle(46, 2, 47, 2.5, &world);
  testing::AddRectangle(48, 4.5, 48.5, 6, &world);  // and a pillar: no two corners alike
  SubmapOptions so;
  const ProbabilityGridInserter inserter(so.insert, so.min_probability, so.max_probability);
  std::vector<SE2d> estimates;
  std::vector<std::shared_ptr<Submap2D>> submaps;
  ConstraintBuilderOptions options;
  options.threads = 0;
  options.search_every_n_scans = 1;
  options.global_search_every_n_scans = 1;
  options.join_drift = join_drift;
  options.global_min_score = 0.5;  // submaps of 20 scans: their far walls barely seen
  ConstraintBuilder2D builder(
      options, GraphEstimates{[&](int i) { return estimates[static_cast<std::size_t>(i)]; },
                              [&](int j) { return submaps[static_cast<std::size_t>(j)]->local_pose(); }});
  for (const Eigen::Vector2d& start : {Eigen::Vector2d(4, 7), Eigen::Vector2d(41.5, 1.5)}) {
    const int j = static_cast<int>(submaps.size());
    submaps.push_back(std::make_shared<Submap2D>(SE2d(start.x(), start.y(), 0), so));
    builder.AddSubmap(submaps.back());
    for (int k = 0; k < 20; ++k) {
      const SE2d pose(start.x() + 0.2 * k, start.y() + 0.05 * k, 0.03 * k);
      const std::vector<Eigen::Vector2d> points = Scan(world, pose);
      std::vector<Eigen::Vector2d> in_map;
      for (const Eigen::Vector2d& p : points) in_map.push_back(pose * p);
      submaps.back()->InsertScan(inserter, pose.translation(), in_map);
      builder.AddScan(pose, points, {j});
      estimates.push_back(pose);
    }
    submaps.back()->Finish();
    builder.FinishSubmap(j);
  }
  builder.TakeClosures();
  builder.StartTrajectory();
  const SE2d frame(-50, 30, 1.0);  // the new trajectory's local frame, from the truth
  const SE2d drift(1.2, 0, 0);     // what local SLAM gathered on the detour (the map's frame)
  const auto add = [&](const SE2d& truth, bool after_detour, const std::vector<Segment>& seen) {
    const SE2d local = frame * (after_detour ? drift * truth : truth);
    builder.AddScan(local, Scan(seen, truth), {});
    estimates.push_back(local);
    return builder.scan_count() - 1;
  };
  for (const SE2d& a : {SE2d(6.1, 7.6, 0.45), SE2d(6.9, 7.3, 0.6)}) builder.SearchScan(add(a, false, world));
  // The detour: 60 m driven where nothing of the map is seen (not searched).
  for (int k = 0; k < 12; ++k) add(SE2d(7 + 5 * (k % 2), -40 - 2.5 * k, 0), false, OtherRoom());
  for (const SE2d& b : {SE2d(42.5, 1.75, 0.15), SE2d(43.3, 1.95, 0.27)}) builder.SearchScan(add(b, true, world));
  *closures = builder.TakeClosures();
  return builder.joined(1) ? 1 : 0;
}

TEST(ConstraintBuilder2DTest, ATrajectoryJoinsWithinTheDriftOfItsLocalSlam) {
  std::vector<LoopClosure> closures;
  EXPECT_EQ(JoinAfterADetour(ConstraintBuilderOptions().join_drift, &closures), 1);
  int to_a = 0, to_b = 0;
  for (const LoopClosure& c : closures) (c.submap == 0 ? to_a : to_b) += c.scan >= 40;
  EXPECT_GE(to_a, 2);
  EXPECT_GE(to_b, 2);
  EXPECT_EQ(JoinAfterADetour(0, &closures), 0);
  EXPECT_TRUE(closures.empty());
  ConstraintBuilderOptions bad;
  bad.join_drift = -0.01;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("join_drift"), std::string::npos) << why;
}

TEST(ConstraintBuilder2DTest, RefusesBadInput) {
  const Room room;
  const GraphEstimates estimates{[](int) { return SE2d(); }, [](int) { return SE2d(); }};
  ConstraintBuilderOptions bad;
  bad.search_every_n_scans = 0;
  EXPECT_THROW(ConstraintBuilder2D(bad, estimates), InvalidArgument);
  EXPECT_THROW(ConstraintBuilder2D(ConstraintBuilderOptions(), GraphEstimates{}), InvalidArgument);
  ConstraintBuilder2D builder(ConstraintBuilderOptions(), estimates);
  EXPECT_THROW(builder.AddSubmap(nullptr), InvalidArgument);
  EXPECT_THROW(builder.AddScan(SE2d(), room.points[0], {0}), InvalidArgument);  // no submap 0 yet
  EXPECT_THROW(builder.SearchScan(0), InvalidArgument);
  EXPECT_THROW(builder.FinishSubmap(0), InvalidArgument);
  builder.AddSubmap(std::make_shared<Submap2D>(SE2d(), SubmapOptions()));
  EXPECT_THROW(builder.FinishSubmap(0), InvalidArgument);  // it still takes scans
  builder.AddScan(SE2d(), room.points[0], {0});
  EXPECT_EQ(builder.scan_count(), 1);
  EXPECT_EQ(builder.submap_count(), 1);
  EXPECT_FALSE(builder.finished(0));
}

}  // namespace
}  // namespace lidar
}  // namespace tether
