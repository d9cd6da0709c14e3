// Local scan matching: in a synthetic room (scans made by ray casting into polygons), a scan
// displaced by a known pose is recovered to a fraction of a cell; the correlative matcher finds
// the basin the nonlinear refinement alone misses from a poor guess; on the Intel log, local
// SLAM (each scan matched against the submap of the scans before it) is scored with the
// relations metric and timed per scan.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <random>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/mapping/local_slam_2d.h"
#include "tether/frontends/lidar/mapping/submap_2d.h"
#include "tether/frontends/lidar/scan_matching/real_time_correlative_scan_matcher_2d.h"
#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"

namespace tether {
namespace lidar {
namespace {

constexpr double kPi = 3.14159265358979323846;

// An L-shaped room with a pillar and a box: no symmetry, so one pose explains a scan.
struct Room {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls;
  Room() {
    const auto poly = [&](std::vector<Eigen::Vector2d> v) {
      for (std::size_t i = 0; i < v.size(); ++i) walls.emplace_back(v[i], v[(i + 1) % v.size()]);
    };
    poly({{0, 0}, {10, 0}, {10, 6}, {6, 6}, {6, 9}, {0, 9}});
    poly({{3, 3}, {4, 3}, {4, 4}, {3, 4}});
    poly({{7, 2}, {8.2, 2}, {8.2, 2.5}, {7, 2.5}});
    poly({{1.5, 6.5}, {2.0, 7.5}, {1.0, 7.5}});
  }
  // Distance along the ray from p in direction d to the nearest wall (infinity: none).
  double Cast(const Eigen::Vector2d& p, const Eigen::Vector2d& d) const {
    double best = INFINITY;
    for (const auto& w : walls) {
      const Eigen::Vector2d e = w.second - w.first;
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::abs(den) < 1e-12) continue;
      const Eigen::Vector2d q = w.first - p;
      const double t = (q.x() * e.y() - q.y() * e.x()) / den, s = (q.x() * d.y() - q.y() * d.x()) / den;
      if (t > 1e-9 && s >= 0 && s <= 1) best = std::min(best, t);
    }
    return best;
  }
  // A 360-beam scan (one per degree) from `pose`, points in the scan's frame.
  std::vector<Eigen::Vector2d> Scan(const SE2d& pose, int beams = 360, double fov = 2 * kPi) const {
    std::vector<Eigen::Vector2d> pts;
    for (int i = 0; i < beams; ++i) {
      const double a = -fov / 2 + fov * i / beams;
      const Eigen::Vector2d d(std::cos(pose.theta() + a), std::sin(pose.theta() + a));
      const double r = Cast(pose.translation(), d);
      if (r < 30) pts.push_back(r * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
    return pts;
  }
};

// A submap grid of the room from scans at a few known poses. The first pose anchors the grid's
// lattice: 2.025 puts the walls (at whole metres) through the cells' centres. (On a cell
// boundary, a wall's hits would all fall into the cells on one side of it, moving the wall by
// half a cell: a bias of the synthetic world, not of the matcher.)
std::shared_ptr<const ProbabilityGrid> RoomGrid(const Room& room) {
  SubmapOptions o;
  o.scans_per_submap = 100;
  ActiveSubmaps2D maps(o);
  for (const SE2d& pose : {SE2d(2.025, 2.025, 0), SE2d(5, 1.5, 1), SE2d(8, 4.5, 2), SE2d(3, 7, -1), SE2d(5, 5, 0.3)}) {
    std::vector<Eigen::Vector2d> pts = room.Scan(pose);
    for (Eigen::Vector2d& p : pts) p = pose * p;
    maps.InsertScan(pose, pose.translation(), pts);
  }
  return maps.matching_submap()->grid();
}

// Weak regularisers: these tests start from guesses that are wrong on purpose.
ScanRefinerOptions WeakRegularisers() {
  ScanRefinerOptions o;
  o.weights.translation = 1e-3;
  o.weights.rotation = 1e-3;
  return o;
}

double TranslationError(const SE2d& a, const SE2d& b) { return (a.translation() - b.translation()).norm(); }
double AngleError(const SE2d& a, const SE2d& b) { return std::abs(SE2d(0, 0, a.theta() - b.theta()).theta()); }

TEST(LocalScanMatching, RecoversAKnownDisplacementToAFractionOfACell) {
  const Room room;
  const auto grid = RoomGrid(room);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  int trials = 0;
  double worst_t = 0, worst_r = 0;
  for (const SE2d& truth : {SE2d(4.5, 2.2, 0.4), SE2d(2.5, 5.0, -2.0), SE2d(7.5, 3.5, 2.8), SE2d(1.2, 1.0, 0.9)}) {
    const std::vector<Eigen::Vector2d> scan = room.Scan(truth);
    for (int k = 0; k < 3; ++k) {
      const SE2d guess = truth * SE2d(0.08 * u(rng), 0.08 * u(rng), 0.1 * u(rng));
      const CorrelativeMatch c = MatchCorrelative(*grid, guess, scan);
      const ScanRefinement r = RefineScanPose(grid, c.pose, guess, scan, WeakRegularisers());
      EXPECT_LT(TranslationError(r.pose, truth), 0.3 * grid->resolution()) << truth << " from " << guess;
      EXPECT_LT(AngleError(r.pose, truth), 0.3 * kPi / 180) << truth << " from " << guess;
      // The correlative result alone is within a cell and a step; the refinement improves it.
      EXPECT_LE(TranslationError(c.pose, truth), 1.5 * grid->resolution());
      worst_t = std::max(worst_t, TranslationError(r.pose, truth));
      worst_r = std::max(worst_r, AngleError(r.pose, truth));
      ++trials;
    }
  }
  std::cout << "synthetic room: " << trials << " displaced scans, worst error " << worst_t * 100 << " cm, "
            << worst_r * 180 / kPi << " deg (cell 5 cm)\n";
}

// With a weak preference for the guess's translation (0.1 per m). The default, 2 per m, is for
// real logs, where a guess is a few centimetres off and a corridor's walls fit anywhere along
// it; at 9 cm and 17 degrees off, (2 * 0.09 + 0.3)^2 against 0.3^2 costs the true translation
// 13% of its score, more than the sharp room gives it, and the search keeps the guess's.
TEST(LocalScanMatching, CorrelativeSearchFindsTheBasinTheRefinementAloneMisses) {
  const Room room;
  const auto grid = RoomGrid(room);
  CorrelativeMatcherOptions correlative;
  correlative.translation_delta_cost_weight = 0.1;
  int refinement_alone_failed = 0, trials = 0;
  for (const SE2d& truth : {SE2d(4.5, 2.2, 0.4), SE2d(2.5, 5.0, -2.0), SE2d(7.5, 3.5, 2.8)}) {
    const std::vector<Eigen::Vector2d> scan = room.Scan(truth);
    // 9 cm and 17 degrees off: inside the search window (10 cm, 20 degrees).
    for (const SE2d& offset : {SE2d(0.09, -0.06, 0.30), SE2d(-0.07, 0.09, -0.30)}) {
      const SE2d guess = truth * offset;
      const ScanRefinement alone = RefineScanPose(grid, guess, guess, scan, WeakRegularisers());
      const CorrelativeMatch c = MatchCorrelative(*grid, guess, scan, correlative);
      const ScanRefinement both = RefineScanPose(grid, c.pose, guess, scan, WeakRegularisers());
      EXPECT_LT(TranslationError(both.pose, truth), 0.3 * grid->resolution()) << truth;
      EXPECT_LT(AngleError(both.pose, truth), 0.3 * kPi / 180) << truth;
      if (TranslationError(alone.pose, truth) > grid->resolution() || AngleError(alone.pose, truth) > 0.02) {
        ++refinement_alone_failed;
      }
      ++trials;
    }
  }
  // The refinement alone ends in another basin for every one of these guesses.
  EXPECT_EQ(refinement_alone_failed, trials);
}

TEST(LocalScanMatching, CorrelativeMatcherOptionsAndInput) {
  const ProbabilityGrid grid(0.05);
  CorrelativeMatcherOptions o;
  o.linear_search_window = -1;
  EXPECT_THROW(MatchCorrelative(grid, SE2d(), {Eigen::Vector2d(1, 0)}, o), InvalidArgument);
  o = CorrelativeMatcherOptions();
  o.unknown_probability = 1.5;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("unknown_probability"), std::string::npos) << why;
  // An unknown cell scores unknown_probability: one point in an empty grid.
  o = CorrelativeMatcherOptions();
  o.unknown_probability = 0.3;
  EXPECT_DOUBLE_EQ(MatchCorrelative(grid, SE2d(), {Eigen::Vector2d(1, 0)}, o).mean_probability, 0.3);
  EXPECT_THROW(MatchCorrelative(grid, SE2d(), {}), InvalidArgument);
  EXPECT_THROW(MatchCorrelative(grid, SE2d(), {Eigen::Vector2d(NAN, 0)}), InvalidArgument);
  // The window's size: (2 * 2 + 1)^2 translations times (2 * 3 + 1) rotations.
  o = CorrelativeMatcherOptions();
  o.angular_step = 0.01;
  o.angular_search_window = 0.03;
  const CorrelativeMatch m = MatchCorrelative(grid, SE2d(), {Eigen::Vector2d(1, 0)}, o);
  EXPECT_EQ(m.candidates, 5 * 5 * 7);
  // The default step: arccos(1 - r^2 / (2 d^2)), d the farthest point.
  const CorrelativeMatch d = MatchCorrelative(grid, SE2d(), {Eigen::Vector2d(10, 0), Eigen::Vector2d(1, 1)});
  EXPECT_NEAR(d.angular_step, std::acos(1 - 0.0025 / 200), 1e-12);
  ScanRefinerOptions r;
  r.max_iterations = 0;
  EXPECT_THROW(RefineScanPose(std::make_shared<ProbabilityGrid>(0.05), SE2d(), SE2d(), {Eigen::Vector2d(1, 0)}, r),
               InvalidArgument);
  LocalSlamOptions l;
  l.matching_voxel_size = -1;
  EXPECT_THROW(LocalSlam2D bad(l), InvalidArgument);
}

// The correlative matcher against a plain reference: every rotation and translation scored
// one at a time, the mean of the cells' probabilities (unknown_probability where unknown)
// weighted by exp(-penalty^2). The same pose and score, to the last bit, with points inside
// the grid, near its edges and far outside it.
TEST(LocalScanMatching, CorrelativeMatcherEqualsTheCandidateByCandidateSearch) {
  using Cell = ProbabilityGrid::Cell;
  ProbabilityGrid grid(0.05);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> p(0.12, 0.97), u(-3, 3);
  for (int y = -40; y < 40; ++y) {
    for (int x = -40; x < 40; ++x) {
      if (rng() % 3 != 0) grid.SetProbability(Cell(x, y), p(rng));
    }
  }
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 150; ++i) points.emplace_back(u(rng), u(rng));
  points.emplace_back(40, -35);  // far outside the grid
  CorrelativeMatcherOptions o;
  o.angular_step = 0.01;
  o.angular_search_window = 0.05;
  o.linear_search_window = 0.15;
  o.unknown_probability = 0.4;
  for (const SE2d& guess : {SE2d(0.1, -0.2, 0.3), SE2d(1.9, 1.8, -1.0)}) {
    const CorrelativeMatch m = MatchCorrelative(grid, guess, points, o);
    double best = -1;
    SE2d best_pose;
    long candidates = 0;
    const int a_max = 5, l_max = 3;
    for (int a = -a_max; a <= a_max; ++a) {
      const double dtheta = a * o.angular_step;
      const SE2d rotated(guess.x(), guess.y(), guess.theta() + dtheta);
      for (int iy = -l_max; iy <= l_max; ++iy) {
        for (int ix = -l_max; ix <= l_max; ++ix) {
          double sum = 0;
          for (const Eigen::Vector2d& q : points) {
            sum += grid.Probability(grid.CellOf(rotated * q) + Cell(ix, iy), o.unknown_probability);
          }
          const double mean = sum * (1.0 / static_cast<double>(points.size()));
          const double penalty = o.translation_delta_cost_weight * 0.05 * std::hypot(ix, iy) +
                                 o.rotation_delta_cost_weight * std::abs(dtheta);
          const double score = mean * std::exp(-penalty * penalty);
          ++candidates;
          if (score > best) {
            best = score;
            best_pose = SE2d(guess.x() + ix * 0.05, guess.y() + iy * 0.05, guess.theta() + dtheta);
          }
        }
      }
    }
    EXPECT_EQ(m.candidates, candidates);
    EXPECT_EQ(m.score, best);
    EXPECT_EQ(m.pose.x(), best_pose.x());
    EXPECT_EQ(m.pose.y(), best_pose.y());
    EXPECT_EQ(m.pose.theta(), best_pose.theta());
  }
}

// The default options, or those the environment sets: knobs for the comparisons in RESULTS
// (docs/lidar_mapping.md lists them).
LocalSlamOptions OptionsFromEnvironment() {
  LocalSlamOptions options;
  if (const char* w = std::getenv("TETHER_LIDAR_TRANSLATION_WEIGHT"))
    options.refiner.weights.translation = std::atof(w);
  if (const char* w = std::getenv("TETHER_LIDAR_ROTATION_WEIGHT")) options.refiner.weights.rotation = std::atof(w);
  if (const char* n = std::getenv("TETHER_LIDAR_SCANS_PER_SUBMAP")) options.submaps.scans_per_submap = std::atoi(n);
  if (std::getenv("TETHER_LIDAR_NO_CORRELATIVE") != nullptr) options.use_correlative_matcher = false;
  if (const char* u = std::getenv("TETHER_LIDAR_UNKNOWN_PROBABILITY")) {
    options.correlative.unknown_probability = options.refiner.weights.unknown_probability = std::atof(u);
  }
  if (std::getenv("TETHER_LIDAR_NO_MOTION_FILTER") != nullptr) {
    options.insert_min_distance = options.insert_min_angle = options.insert_max_seconds = 0;
  }
  return options;
}

// A LaserScan of the room: 361 beams over 180 degrees (a SICK LMS at 0.5 degrees). At 1 degree
// the walls 8 m away are hit every 14 cm, and a map made of a few such scans has unknown cells
// between its hits, so that the next scan's points prefer the free cells in front of the wall.
LaserScan RoomLaserScan(const Room& room, const SE2d& truth, const SE2d& odometry, double stamp) {
  LaserScan s;
  s.stamp = stamp;
  s.angle_min = -kPi / 2;
  s.angle_increment = kPi / 360;
  s.range_min = 0.1;
  s.range_max = 30;
  for (int i = 0; i <= 360; ++i) {
    const double a = truth.theta() + s.Angle(static_cast<std::size_t>(i));
    s.ranges.push_back(static_cast<float>(room.Cast(truth.translation(), Eigen::Vector2d(std::cos(a), std::sin(a)))));
  }
  s.odometry = odometry;
  s.odometry_origin = OdometryOrigin::kScanLine;
  return s;
}

TEST(LocalSlam2D, FollowsASeededPathThroughTheRoomDespiteOdometryDrift) {
  const Room room;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 1);
  // A loop around the pillar: 0.05 m a step along the sides, 2.9 degrees a step in the corners
  // (turning in place), and a pause of 10 scans at the start. Odometry drifts by 2 % of the
  // distance and 0.17 degrees a step (plus noise).
  // (Starting at 1.525 puts the walls through the cells' centres, see RoomGrid.)
  std::vector<SE2d> truth = {SE2d(1.525, 1.525, 0.0)};
  std::vector<bool> paused = {false};
  const auto go = [&](int steps, double forward, double turn, bool pause = false) {
    for (int i = 0; i < steps; ++i) {
      truth.push_back(truth.back() * SE2d(forward, 0, turn));
      paused.push_back(pause);
    }
  };
  go(10, 0, 0, true);
  for (int side = 0; side < 4; ++side) {
    go(side % 2 == 0 ? 80 : 70, 0.05, 0);
    go(31, 0, kPi / 2 / 31);
  }
  LocalSlam2D slam(OptionsFromEnvironment());
  SE2d odometry = truth[0];
  int inserted = 0, matched = 0, still = 0;
  double worst = 0, worst_angle = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const SE2d step = truth[i - 1].Inverse() * truth[i];
      odometry = odometry * SE2d(step.x() * (1.02 + 0.01 * noise(rng)), 0.002 * noise(rng),
                                 step.theta() + 0.003 + 0.003 * noise(rng));
    }
    const LocalScanResult r = slam.AddScan(RoomLaserScan(room, truth[i], odometry, 0.1 * i));
    inserted += r.inserted;
    if (paused[i]) {
      EXPECT_FALSE(r.inserted) << "scan " << i << " while the robot stands still";
    }
    matched += r.matched;
    still += r.still;
    worst = std::max(worst, TranslationError(r.pose, truth[i]));
    worst_angle = std::max(worst_angle, AngleError(r.pose, truth[i]));
  }
  ASSERT_EQ(slam.trajectory().size(), truth.size());
  EXPECT_EQ(matched, static_cast<int>(truth.size()) - 1);
  EXPECT_EQ(still, 0) << "off by default";
  // The motion filter: 0.2 m or 1 degree between inserted scans; the pause inserts nothing.
  EXPECT_LT(inserted, static_cast<int>(truth.size()) * 6 / 10);
  EXPECT_GT(inserted, 100);
  EXPECT_LT(worst, 0.03) << "worst translation error";
  EXPECT_LT(worst_angle, 0.01) << "worst rotation error";
  std::cout << "synthetic path: " << truth.size() << " scans, " << inserted << " inserted, "
            << slam.submaps().submaps().size() << " submaps, worst error " << worst * 100 << " cm, "
            << worst_angle * 180 / kPi << " deg\n";
}

// A scan whose points the submap cannot place is not trusted: the scan keeps the odometry's
// prediction. Here it sees a box around the robot: three of its walls lie in the room's free
// space, the fourth 4.5 cm beside the room's wall y = 0, which pulls the matchers (with the
// gate off they move the scan towards it). A scan of the room itself is trusted.
TEST(LocalSlam2D, AMatchTheSubmapCannotSupportTakesThePrediction) {
  const Room room;
  Room box;
  box.walls.clear();
  const Eigen::Vector2d c(2.225, 2.025);
  const Eigen::Vector2d corners[4] = {Eigen::Vector2d(c.x() - 0.8, 0.045), Eigen::Vector2d(c.x() + 0.8, 0.045),
                                      c + Eigen::Vector2d(0.8, 0.8), c + Eigen::Vector2d(-0.8, 0.8)};
  for (int i = 0; i < 4; ++i) box.walls.emplace_back(corners[i], corners[(i + 1) % 4]);
  const std::vector<SE2d> truth = {SE2d(2.025, 2.025, 0), SE2d(2.125, 2.025, 0), SE2d(2.225, 2.025, 0)};

  for (const double gate : {0.52, 0.0}) {
    LocalSlamOptions options;
    options.min_match_probability = gate;
    LocalSlam2D slam(options);
    // Odometry 5% long: the prediction differs from the truth, so a match is seen to move it.
    const SE2d odometry[3] = {truth[0], SE2d(2.130, 2.025, 0), SE2d(2.235, 2.025, 0)};
    slam.AddScan(RoomLaserScan(room, truth[0], odometry[0], 0.0));
    const LocalScanResult room_scan = slam.AddScan(RoomLaserScan(room, truth[1], odometry[1], 0.1));
    ASSERT_TRUE(room_scan.matched);
    EXPECT_TRUE(room_scan.trusted) << "gate " << gate << ": a scan of the mapped room, probability "
                                   << room_scan.match_probability;
    EXPECT_GE(room_scan.match_probability, 0.52);
    EXPECT_LT(TranslationError(room_scan.pose, truth[1]), 0.015);

    const LocalScanResult box_scan = slam.AddScan(RoomLaserScan(box, truth[2], odometry[2], 0.2));
    ASSERT_TRUE(box_scan.matched);
    EXPECT_LT(box_scan.match_probability, 0.52) << "three of the box's walls lie in the room's free space";
    const double moved =
        TranslationError(box_scan.pose, box_scan.predicted) + AngleError(box_scan.pose, box_scan.predicted);
    if (gate > 0) {
      EXPECT_FALSE(box_scan.trusted);
      EXPECT_EQ(moved, 0.0) << "an untrusted match keeps the prediction";
    } else {
      EXPECT_TRUE(box_scan.trusted);
      EXPECT_GT(moved, 0.02) << "without the gate the matchers pull the scan to the room's wall";
    }
  }
}

// A robot standing in a corridor (walls 2 m apart, longer than the laser's reach; ranges with
// 2 cm of noise): with the odometry still, the scans are not matched and keep the first pose
// exactly; matched anyway (still_* 0, the default), they slide along the corridor, where
// nothing holds them.
TEST(LocalSlam2D, ScansWhileTheOdometryStandsStillKeepThePose) {
  Room corridor;
  corridor.walls = {{Eigen::Vector2d(-60, 0), Eigen::Vector2d(60, 0)},
                    {Eigen::Vector2d(-60, 2), Eigen::Vector2d(60, 2)}};
  const SE2d truth(0.025, 1.025, 0.0);
  double slide[2] = {0, 0};
  for (const bool still_rule : {true, false}) {
    LocalSlamOptions options;
    if (still_rule) {
      options.still_distance = 0.001;
      options.still_angle = 0.001;
    }
    LocalSlam2D slam(options);
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0, 0.02);
    int matched = 0, still = 0;
    for (int i = 0; i < 60; ++i) {
      LaserScan scan = RoomLaserScan(corridor, truth, truth, 0.1 * i);
      for (float& r : scan.ranges) {
        if (std::isfinite(r)) r += static_cast<float>(noise(rng));
      }
      const LocalScanResult r = slam.AddScan(scan);
      matched += r.matched;
      still += r.still;
      slide[still_rule ? 0 : 1] = std::max(slide[still_rule ? 0 : 1], std::abs(r.pose.x() - truth.x()));
      if (still_rule && i > 0) {
        EXPECT_TRUE(r.still) << "scan " << i;
        EXPECT_EQ(r.pose.x(), slam.trajectory().front().pose.x()) << "scan " << i;
        EXPECT_EQ(r.pose.theta(), slam.trajectory().front().pose.theta()) << "scan " << i;
      }
    }
    EXPECT_EQ(matched, still_rule ? 0 : 59);
    EXPECT_EQ(still, still_rule ? 59 : 0);
  }
  EXPECT_EQ(slide[0], 0.0);
  // 8 mm with this seed; the rule's pose does not move at all.
  EXPECT_GT(slide[1], 0.004) << "matched while standing still, the pose slides along the corridor";
  std::cout << "standing in a corridor: matched anyway, the pose slides up to " << slide[1] * 100 << " cm\n";
}

TEST(LocalSlam2D, MinMatchProbabilityAndStillThresholdsAreValidated) {
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    LocalSlamOptions options;
    options.min_match_probability = bad;
    std::string why;
    EXPECT_FALSE(options.IsValid(&why)) << bad;
    EXPECT_NE(why.find("min_match_probability"), std::string::npos) << why;
    EXPECT_THROW(LocalSlam2D{options}, InvalidArgument);
  }
  for (const double bad : {-0.1, std::nan("")}) {
    LocalSlamOptions options;
    options.still_angle = bad;
    std::string why;
    EXPECT_FALSE(options.IsValid(&why)) << bad;
    EXPECT_NE(why.find("still_"), std::string::npos) << why;
  }
}

// Intel: scans sorted by time (the log is not), matched one after another.
TEST(LocalScanMatching, IntelLogRelationsAndTiming) {
  const std::string path = testing::LidarDataset("raw/intel.clf.gz");
  const std::string relations_path = testing::LidarDataset("raw/intel.relations");
  if (path.empty() || relations_path.empty()) {
    GTEST_SKIP() << "../shared/datasets/lidar/raw/intel.clf.gz or intel.relations is absent; the real-data test "
                    "needs both";
  }
  LidarLog log = ReadLidarLog(path);
  std::stable_sort(log.scans.begin(), log.scans.end(),
                   [](const LaserScan& a, const LaserScan& b) { return a.stamp < b.stamp; });
  // TETHER_LIDAR_LOCAL_SCANS=all runs the whole log (RESULTS); the default is its first part.
  std::size_t n = 2500;
  if (const char* env = std::getenv("TETHER_LIDAR_LOCAL_SCANS")) {
    n = std::string(env) == "all" ? log.scans.size() : static_cast<std::size_t>(std::atol(env));
  }
  n = std::min(n, log.scans.size());
  LocalSlam2D slam(OptionsFromEnvironment());
  std::vector<double> match_ms;
  double correlative_ms = 0, insert_ms = 0, candidates = 0, points = 0;
  int inserted = 0;
  std::vector<StampedPose2> odometry;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < n; ++i) {
    const LocalScanResult r = slam.AddScan(log.scans[i]);
    if (r.matched) {
      match_ms.push_back(1e3 * (r.correlative_seconds + r.refine_seconds));
      correlative_ms += 1e3 * r.correlative_seconds;
      candidates += r.correlative_candidates;
      points += r.matching_points;
    }
    insert_ms += 1e3 * r.insert_seconds;
    inserted += r.inserted;
    odometry.push_back(StampedPose2{log.scans[i].stamp, log.scans[i].odometry});
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_GT(match_ms.size(), n / 2);
  // Relations with both ends among the scans processed.
  std::vector<Relation> relations;
  for (const Relation& rel : ReadRelationsFile(relations_path)) {
    if (std::max(rel.t1, rel.t2) <= log.scans[n - 1].stamp) relations.push_back(rel);
  }
  ASSERT_GT(relations.size(), 50u);
  const RelationsResult slam_err = EvaluateRelations(slam.trajectory(), relations);
  const RelationsResult odom_err = EvaluateRelations(odometry, relations);
  std::sort(match_ms.begin(), match_ms.end());
  double mean = 0;
  for (double m : match_ms) mean += m;
  mean /= match_ms.size();
  std::cout << "intel, first " << n << " scans (" << log.scans[n - 1].stamp - log.scans[0].stamp
            << " s of log): " << slam.submaps().submaps().size() << " submaps\n"
            << "  local SLAM: " << slam_err.Report() << "\n"
            << "  odometry:   " << odom_err.Report() << "\n"
            << "  matching per scan (correlative + refinement): mean " << mean << " ms, median "
            << match_ms[match_ms.size() / 2] << " ms, 95% " << match_ms[match_ms.size() * 95 / 100] << " ms, max "
            << match_ms.back() << " ms (correlative " << correlative_ms / match_ms.size() << " ms of it; "
            << candidates / match_ms.size() << " candidates of " << points / match_ms.size() << " points on average); "
            << inserted << " scans inserted, insertion " << insert_ms / n << " ms per scan; whole loop " << total
            << " s (" << 1e3 * total / n << " ms per scan)\n";
  EXPECT_EQ(slam_err.matched, relations.size());
  EXPECT_LT(slam_err.translation.mean, odom_err.translation.mean);
  EXPECT_LT(slam_err.rotation.mean, odom_err.rotation.mean);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
