// Localisation in a saved map (Localizer2D): a simulated robot mapped over its first 800 scans,
// then localised over the rest from an unknown start (global localisation) and from a given
// pose, against the simulator's truth; a saved state read back localises alike; memory stays
// bounded (local SLAM keeps its newest submaps only); the rest mapped as a second session.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "tether/core/error.h"
#include "tether/frontends/lidar/io/lidar_state.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/localizer_2d.h"
#include "tether/frontends/simulation/lidar_world.h"

namespace tether {
namespace lidar {
namespace {

constexpr std::size_t kMapped = 800;

struct Fixture {
  SimulatedLidar sim;
  LidarState state;
  SE2d world_from_map;  ///< the truth's frame from the map's (the mapping run's first pose on the truth)
};

const Fixture& Mapped() {
  static const Fixture f = [] {
    Fixture x;
    LidarSimOptions o;
    o.scans = 1400;
    o.seed = 4;
    x.sim = SimulateLidar(o);
    LidarSlamOptions options;
    options.pose_graph.threads = 0;
    LidarSlam2D slam(options);
    slam.Run(x.sim.log, kMapped);
    x.state = slam.State();
    x.world_from_map = x.sim.truth[0].pose * slam.Trajectory()[0].pose.Inverse();
    return x;
  }();
  return f;
}

// Localises the scans after the mapped ones; the position errors of the localised scans.
std::vector<double> Localize(const LidarState& state, const LocalizationOptions& options, Localizer2D** keep,
                             LocalizationReport* report, long max_scans = 0) {
  const Fixture& f = Mapped();
  static std::unique_ptr<Localizer2D> loc;
  loc = std::make_unique<Localizer2D>(state, options);
  loc->Run(f.sim.log, kMapped, max_scans);
  std::vector<double> errors;
  for (const LocalizedScan& r : loc->results()) {
    if (!r.localized) continue;
    const SE2d truth = f.sim.truth[kMapped + static_cast<std::size_t>(r.scan)].pose;
    errors.push_back(((f.world_from_map * r.pose).translation() - truth.translation()).norm());
  }
  if (keep != nullptr) *keep = loc.get();
  *report = loc->report();
  return errors;
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

TEST(LidarLocalizeTest, AnUnknownStartIsFoundAndTracked) {
  LocalizationReport r;
  Localizer2D* loc = nullptr;
  const std::vector<double> e = Localize(Mapped().state, {}, &loc, &r);
  ASSERT_GE(r.first_fix_scan, 0) << r.Summary();
  // Within 10 s of log (100 scans at 10 Hz), and right: the fix and every pose after it.
  EXPECT_LE(r.first_fix_seconds, 10) << r.Summary();
  ASSERT_FALSE(e.empty());
  EXPECT_LT(e.front(), 0.3) << "the fix is " << e.front() << " m from the truth";
  double worst = 0;
  for (double x : e) worst = std::max(worst, x);
  EXPECT_LT(worst, 0.3) << r.Summary();
  EXPECT_LT(Mean(e), 0.05) << r.Summary();
  EXPECT_EQ(r.losses, 0);
  EXPECT_GT(r.localized, static_cast<long>(0.9 * (1400 - kMapped))) << r.Summary();
  // The robot drives beyond the mapped area (the first 800 scans did not see it all): local
  // SLAM carries it there, and that is not being lost.
  EXPECT_GT(r.outside, 20) << r.Summary();
  EXPECT_GT(r.dead_reckoned, r.outside) << r.Summary();
  // Every result is there, the ones before the fix not localised.
  ASSERT_EQ(loc->results().size(), 1400 - kMapped);
  EXPECT_FALSE(loc->results().front().localized);
  EXPECT_TRUE(loc->results()[static_cast<std::size_t>(r.first_fix_scan)].fix);
}

TEST(LidarLocalizeTest, AGivenStartIsTrackedFromTheFirstScan) {
  const Fixture& f = Mapped();
  LocalizationOptions o;
  o.has_initial_pose = true;
  o.initial_pose = f.world_from_map.Inverse() * f.sim.truth[kMapped].pose;
  LocalizationReport r;
  const std::vector<double> e = Localize(f.state, o, nullptr, &r);
  EXPECT_EQ(r.first_fix_scan, 0);
  EXPECT_EQ(r.global_searches, 0);
  EXPECT_EQ(r.localized, static_cast<long>(1400 - kMapped)) << r.Summary();
  // Where the map knows the scans, the map tracks them and local SLAM rests.
  EXPECT_LT(r.dead_reckoned, r.localized - r.outside) << r.Summary();
  EXPECT_LT(Mean(e), 0.05) << r.Summary();
}

TEST(LidarLocalizeTest, AStateReadBackLocalisesAlike) {
  const LidarState again = ParseLidarState(LidarStateBytes(Mapped().state), "again");
  LocalizationReport a, b;
  Localizer2D* la = nullptr;
  Localize(Mapped().state, {}, &la, &a, 150);
  const std::vector<LocalizedScan> first = la->results();
  Localize(again, {}, &la, &b, 150);
  ASSERT_EQ(first.size(), la->results().size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i].localized, la->results()[i].localized);
    EXPECT_EQ(first[i].pose.x(), la->results()[i].pose.x());
  }
}

// A robot standing still shows one view: four alike candidates from it are the fix; without
// that rule none comes (two views are needed).
TEST(LidarLocalizeTest, ARobotStandingStillIsFixedFromOneView) {
  const Fixture& f = Mapped();
  const std::size_t at = 500;  // inside the mapped part
  SE2d fixed;
  const auto run = [&](int still) {
    LocalizationOptions o;
    o.confirm_still_candidates = still;
    Localizer2D loc(f.state, o);
    for (int k = 0; k < 40; ++k) {
      LaserScan s = f.sim.log.scans[at];
      s.stamp += 0.1 * k;
      const LocalizedScan r = loc.AddScan(s);
      if (r.fix) fixed = r.pose;
    }
    return loc.report();
  };
  const LocalizationReport r = run(4);
  ASSERT_GE(r.first_fix_scan, 0) << r.Summary();
  EXPECT_LE(r.first_fix_scan, 20) << r.Summary();
  EXPECT_LT(((f.world_from_map * fixed).translation() - f.sim.truth[at].pose.translation()).norm(), 0.1);
  EXPECT_EQ(run(0).first_fix_scan, -1);
}

TEST(LidarLocalizeTest, LocalSlamKeepsOnlyItsNewestSubmaps) {
  LocalSlamOptions o;
  o.keep_submaps = 3;
  o.submaps.scans_per_submap = 20;
  LocalSlam2D local(o);
  const Fixture& f = Mapped();
  for (std::size_t i = 0; i < 600; ++i) local.AddScan(f.sim.log.scans[i]);
  EXPECT_LE(local.submaps().submaps().size(), 3u);
  EXPECT_GT(local.submaps().dropped(), 10);
  EXPECT_LE(local.trajectory().size(), 64u);
  // Indices go on counting across the dropped ones.
  const LocalScanResult r = local.AddScan(f.sim.log.scans[600]);
  for (const auto& [index, submap] : r.inserted_into) EXPECT_GE(index, local.submaps().dropped());
}

// Multi-session mapping: the rest of the run mapped as a second session of the saved map,
// joined to it by the global search, both sessions placed against the truth.
TEST(LidarLocalizeTest, ASecondSessionJoinsTheSavedMap) {
  const Fixture& f = Mapped();
  LidarLog rest = f.sim.log;
  rest.scans.erase(rest.scans.begin(), rest.scans.begin() + static_cast<std::ptrdiff_t>(kMapped));
  LidarSlamOptions options;
  options.pose_graph.threads = 0;
  LidarSlam2D slam(options);
  slam.Continue(f.state);
  EXPECT_EQ(slam.scan_count(), static_cast<long>(kMapped));
  slam.Run(rest);
  const LidarSlamReport& r = slam.report();
  ASSERT_EQ(r.trajectories.size(), 2u) << r.KidnapSummary();
  EXPECT_TRUE(r.trajectories[1].session);
  EXPECT_EQ(r.trajectories[1].first_scan, static_cast<long>(kMapped));
  ASSERT_GE(r.trajectories[1].joined_scan, 0) << r.KidnapSummary();
  EXPECT_NE(r.KidnapSummary().find("a new session"), std::string::npos);
  EXPECT_NE(r.KidnapSummary().find("no kidnap detected"), std::string::npos);
  // Every pose of both sessions against the truth, in the map's frame.
  const std::vector<StampedPose2> t = slam.Trajectory();
  ASSERT_EQ(t.size(), 1400u);
  double worst = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    worst = std::max(worst, ((f.world_from_map * t[i].pose).translation() - f.sim.truth[i].pose.translation()).norm());
  }
  EXPECT_LT(worst, 0.2);
  // The merged state holds both sessions.
  const LidarState both = slam.State();
  EXPECT_EQ(both.scans.size(), 1400u);
  EXPECT_EQ(both.trajectories, 2);
  EXPECT_GT(both.submaps.size(), f.state.submaps.size());
  // Only before the first scan.
  EXPECT_THROW(slam.Continue(f.state), InvalidArgument);
}

TEST(LidarLocalizeTest, BadOptionsAndAStateWithoutAMapAreRefused) {
  LocalizationOptions o;
  o.global_every_n_scans = 0;
  EXPECT_THROW(Localizer2D(Mapped().state, o), InvalidArgument);
  LidarState empty;
  EXPECT_THROW(Localizer2D(empty, {}), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
