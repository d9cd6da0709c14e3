// The fast correlative scan matcher: its precomputation grids against brute force, branch and
// bound against the exhaustive search of the same candidates (synthetic room and a real log),
// and its refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "testing/lidar_files.h"
#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"

namespace tether {
namespace lidar {
namespace {

using Cell = ProbabilityGrid::Cell;

TEST(PrecomputationGridsTest, EachHeightBoundsItsWindowWithinOneLevel) {
  ProbabilityGrid grid(0.1, Eigen::Vector2d(-1, 2));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> p(0.12, 0.97);
  for (int y = -3; y < 12; ++y) {
    for (int x = 4; x < 24; ++x) {
      if (rng() % 5 != 0) grid.SetProbability(Cell(x, y), p(rng));  // a fifth stays unknown
    }
  }
  // Two cells one value apart: the byte levels must still order them.
  grid.SetProbability(Cell(30, 30), 0.5);
  grid.SetProbability(Cell(31, 30), grid.ValueToProbability(static_cast<std::uint16_t>(grid.Value(Cell(30, 30)) + 1)));
  const PrecomputationGrids pre(grid, 5);
  ASSERT_EQ(pre.depth(), 5);
  const double level = (grid.max_probability() - grid.min_probability()) / 255;
  int tight = 0;
  for (int h = 0; h < 5; ++h) {
    const int w = 1 << h;
    for (int y = -3 - w - 2; y < 34; ++y) {
      for (int x = 4 - w - 2; x < 34; ++x) {
        float expect = static_cast<float>(grid.min_probability());
        for (int j = 0; j < w; ++j) {
          for (int i = 0; i < w; ++i)
            expect = std::max(expect, static_cast<float>(grid.Probability(Cell(x + i, y + j))));
        }
        const float bound = pre.Bound(h, Cell(x, y));
        if (h == 0) {
          ASSERT_EQ(bound, expect) << "cell " << x << ", " << y;  // exact: the leaves' scores
        } else {
          ASSERT_GE(bound, expect) << "h " << h << " cell " << x << ", " << y;
          ASSERT_LE(bound, expect + level + 1e-6) << "h " << h << " cell " << x << ", " << y;
          tight += bound < expect + 0.5 * level;
        }
      }
    }
  }
  EXPECT_GT(tight, 0);
  EXPECT_THROW(PrecomputationGrids(grid, 0), InvalidArgument);
}

// Accumulate adds, per offset, the same floats in the same order as one offset at a time,
// for cells inside the box, past its edges, and far outside it.
TEST(PrecomputationGridsTest, AccumulateEqualsOneOffsetAtATime) {
  ProbabilityGrid grid(0.05);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> p(0.12, 0.97);
  for (int y = 0; y < 60; ++y) {
    for (int x = -20; x < 50; ++x) {
      if (rng() % 4 != 0) grid.SetProbability(Cell(x, y), p(rng));
    }
  }
  const PrecomputationGrids pre(grid, 4);
  std::uniform_int_distribution<int> c(-60, 110), o(-30, 30);
  std::vector<Cell> cells;
  for (int i = 0; i < 300; ++i) cells.emplace_back(c(rng), c(rng));
  cells.emplace_back(100000, -100000);
  for (int h = 0; h < 4; ++h) {
    for (int count : {1, 4, 17, PrecomputationGrids::kMaxOffsets}) {
      std::vector<Cell> offsets;
      for (int j = 0; j < count; ++j) offsets.emplace_back(o(rng), o(rng));
      std::vector<float> sums(static_cast<std::size_t>(count), 0.0f);
      pre.Accumulate(h, cells, offsets.data(), count, sums.data());
      for (int j = 0; j < count; ++j) {
        float expect = 0;
        for (const Cell& cell : cells) expect += pre.Bound(h, cell + offsets[static_cast<std::size_t>(j)]);
        ASSERT_EQ(sums[static_cast<std::size_t>(j)], expect) << "h " << h << " offset " << j;
      }
    }
  }
  std::vector<Cell> too_many(PrecomputationGrids::kMaxOffsets + 1, Cell::Zero());
  std::vector<float> sums(too_many.size());
  EXPECT_THROW(pre.Accumulate(0, cells, too_many.data(), static_cast<int>(too_many.size()), sums.data()),
               InvalidArgument);
  EXPECT_THROW(pre.Accumulate(4, cells, too_many.data(), 1, sums.data()), InvalidArgument);
}

// A grid whose stored box is far larger than its known cells (it grew by doubling) gives the
// same precomputation as the same grid cropped.
TEST(PrecomputationGridsTest, AGrownBoxAndItsCropGiveTheSameLevels) {
  ProbabilityGrid grown(0.05);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> p(0.12, 0.97);
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 30; ++x) grown.SetProbability(Cell(x, y), p(rng));
  }
  grown.SetProbability(Cell(200, 150), 0.9);
  ProbabilityGrid cropped = grown;
  cropped.ShrinkToKnown();
  ASSERT_LT(cropped.size().prod(), grown.size().prod());
  const PrecomputationGrids a(grown, 5), b(cropped, 5);
  for (int h = 0; h < 5; ++h) {
    for (int y = -20; y < 170; ++y) {
      for (int x = -20; x < 220; ++x) ASSERT_EQ(a.Bound(h, Cell(x, y)), b.Bound(h, Cell(x, y))) << h;
    }
  }
}

using testing::Segment;

// A room of 10 m x 8 m with a 2 m x 1 m box inside (so that no rotation or shift of the room
// maps it onto itself).
std::vector<Segment> Room() {
  std::vector<Segment> s;
  testing::AddRectangle(0, 0, 10, 8, &s);
  testing::AddRectangle(6, 5, 8, 6, &s);
  return s;
}

// The grid of a set of walls: `floor` cells (the box x0..x1, y0..y1) 0.2, wall cells 0.9.
ProbabilityGrid WallGrid(const std::vector<Segment>& walls, double r, double x0, double y0, double x1, double y1) {
  ProbabilityGrid grid(r);
  for (double y = y0 + r / 2; y < y1; y += r) {
    for (double x = x0 + r / 2; x < x1; x += r) grid.SetProbability(grid.CellOf({x, y}), 0.2);
  }
  for (const Segment& s : walls) {
    const int n = static_cast<int>((s.b - s.a).norm() / (r / 4));
    for (int i = 0; i <= n; ++i) grid.SetProbability(grid.CellOf(s.a + (s.b - s.a) * i / n), 0.9);
  }
  return grid;
}

// The grid of the room, and a scan from `pose` into it (every beam hits a wall).
ProbabilityGrid RoomGrid(double r) { return WallGrid(Room(), r, 0, 0, 10, 8); }
std::vector<Eigen::Vector2d> RoomScan(const SE2d& pose) { return testing::ScanPoints(Room(), pose, 181, 1e9); }

// The room case of the tests below: the truth, a guess 1.1 m, 0.8 m and 0.2 rad off it, and
// a window of +-`linear` m and +-0.3 rad.
const SE2d kRoomTruth(3.2, 2.7, 0.4);
const SE2d kRoomGuess(kRoomTruth.x() + 1.1, kRoomTruth.y() - 0.8, kRoomTruth.theta() - 0.2);
FastMatcherOptions RoomWindow(double linear) {
  FastMatcherOptions o;
  o.linear_search_window = linear;
  o.angular_search_window = 0.3;
  return o;
}

TEST(FastCorrelativeScanMatcherTest, FindsTheExhaustiveBestInARoom) {
  const ProbabilityGrid grid = RoomGrid(0.05);
  const FastMatcherOptions o = RoomWindow(1.5);
  const FastCorrelativeScanMatcher2D matcher(grid, o);
  const SE2d& truth = kRoomTruth;
  const std::vector<Eigen::Vector2d> points = RoomScan(truth);
  ASSERT_GT(points.size(), 150u);
  const SE2d& guess = kRoomGuess;
  const FastMatch fast = matcher.Match(guess, points, 0.5);
  const FastMatch full = matcher.MatchExhaustive(guess, points, 0.5);
  ASSERT_TRUE(fast.found);
  ASSERT_TRUE(full.found);
  EXPECT_EQ(fast.score, full.score);  // the same candidates, scored the same way
  EXPECT_EQ(fast.rotations, full.rotations);
  EXPECT_EQ(full.nodes, static_cast<long>(full.rotations) * full.translations * full.translations);
  EXPECT_LT(fast.nodes * 20, full.nodes) << fast.nodes << " of " << full.nodes;
  // The truth is a candidate; the walls lie on cell boundaries, so the best may be a cell off.
  EXPECT_LT((fast.pose.translation() - truth.translation()).norm(), 1.5 * 0.05);
  EXPECT_LT(std::abs(WrapAngle(fast.pose.theta() - truth.theta())), fast.angular_step);
  EXPECT_FALSE(fast.on_edge);
  EXPECT_FALSE(full.on_edge);
  // A window that does not reach the truth: the best lies on its edge.
  const FastCorrelativeScanMatcher2D short_reach(grid, RoomWindow(0.5));
  const FastMatch edge = short_reach.Match(guess, points, 0.2);
  ASSERT_TRUE(edge.found);
  EXPECT_TRUE(edge.on_edge);
  EXPECT_TRUE(short_reach.MatchExhaustive(guess, points, 0.2).on_edge);
  // A threshold above the best: nothing found, the guess returned.
  const FastMatch none = matcher.Match(guess, points, fast.score + 0.01);
  EXPECT_FALSE(none.found);
  EXPECT_EQ(none.pose.translation(), guess.translation());
}

// MatchChecked searches the window it is given for the call, and counts a best whose
// translation lies within the rival distance of that window's edge as on the edge: the
// candidates that count as the same match reach past it.
TEST(FastCorrelativeScanMatcherTest, ACallsWindowAndABestNearItsEdge) {
  const ProbabilityGrid grid = RoomGrid(0.05);
  const FastCorrelativeScanMatcher2D matcher(grid, RoomWindow(0.5));
  const SE2d& truth = kRoomTruth;
  const std::vector<Eigen::Vector2d> points = RoomScan(truth);
  const SE2d& guess = kRoomGuess;  // 1.1 m off in x
  // The options' window does not reach the truth; 1.5 m for this call does, 0.4 m inside.
  EXPECT_GT((matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0).pose.translation() - truth.translation()).norm(),
            0.3);
  const FastMatch wide = matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0, 1.5);
  ASSERT_TRUE(wide.found);
  EXPECT_LT((wide.pose.translation() - truth.translation()).norm(), 1.5 * 0.05);
  EXPECT_EQ(wide.translations, 2 * 30 + 1);
  EXPECT_FALSE(wide.on_edge);
  // 1.3 m: the truth is found 0.2 m inside the edge, nearer than the rival distance (0.3 m);
  // Match alone does not call that the edge, MatchChecked does.
  const FastMatch near = matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0, 1.3);
  ASSERT_TRUE(near.found);
  EXPECT_LT((near.pose.translation() - truth.translation()).norm(), 1.5 * 0.05);
  EXPECT_TRUE(near.on_edge);
  EXPECT_FALSE(near.ambiguous);  // not searched for rivals
  EXPECT_FALSE(FastCorrelativeScanMatcher2D(grid, RoomWindow(1.3)).Match(guess, points, 0.5).on_edge);
  EXPECT_FALSE(matcher.MatchChecked(guess, points, 0.5, 0.15, 0.035, 0, 1.3).on_edge);  // a smaller neighbourhood
  EXPECT_THROW(matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0, std::nan("")), InvalidArgument);
}

// MatchChecked searches the rotations it is given for the call: a guess turned 0.5 rad from
// the truth is out of the options' 0.3 rad, within 0.6 rad.
TEST(FastCorrelativeScanMatcherTest, ACallsRotations) {
  const ProbabilityGrid grid = RoomGrid(0.05);
  const FastCorrelativeScanMatcher2D matcher(grid, RoomWindow(0.5));
  const std::vector<Eigen::Vector2d> points = RoomScan(kRoomTruth);
  const SE2d guess(kRoomTruth.x() + 0.2, kRoomTruth.y(), kRoomTruth.theta() + 0.5);
  const FastMatch narrow = matcher.MatchChecked(guess, points, 0.3, 0.3, 0.035, 0, 0.5);
  EXPECT_FALSE(narrow.found && std::abs(WrapAngle(narrow.pose.theta() - kRoomTruth.theta())) < narrow.angular_step);
  const FastMatch wide = matcher.MatchChecked(guess, points, 0.3, 0.3, 0.035, 0, 0.5, 0.6);
  ASSERT_TRUE(wide.found);
  EXPECT_LT(std::abs(WrapAngle(wide.pose.theta() - kRoomTruth.theta())), wide.angular_step);
  EXPECT_LT((wide.pose.translation() - kRoomTruth.translation()).norm(), 1.5 * 0.05);
  EXPECT_GT(wide.rotations, narrow.rotations);
  EXPECT_THROW(matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0, 0.5, INFINITY), InvalidArgument);
}

// A global search (a kidnap): the whole room from its centre, every rotation. The truth turned
// by nearly half a turn from the guess is found, and a best at the guess's rotation +- pi is
// not on an edge: the rotations go all the way round.
TEST(FastCorrelativeScanMatcherTest, AGlobalSearchGoesAllTheWayRound) {
  const ProbabilityGrid grid = RoomGrid(0.05);
  const FastCorrelativeScanMatcher2D matcher(grid, RoomWindow(0.5));
  for (const double turn : {3.0, -2.9, M_PI}) {
    const SE2d truth(kRoomTruth.x(), kRoomTruth.y(), turn);
    const std::vector<Eigen::Vector2d> points = RoomScan(truth);
    const SE2d centre(5, 4, 0);
    const FastMatch m = matcher.MatchChecked(centre, points, 0.6, 0.3, 0.035, 0.9, 5.2, M_PI);
    ASSERT_TRUE(m.found) << turn;
    EXPECT_FALSE(m.on_edge) << turn;
    EXPECT_FALSE(m.ambiguous) << turn;  // the box in the corner tells the room's ends apart
    EXPECT_LT((m.pose.translation() - truth.translation()).norm(), 1.5 * 0.05) << turn;
    // The rotations step from the guess's: the truth lies between two of them.
    EXPECT_LT(std::abs(WrapAngle(m.pose.theta() - truth.theta())), 1.5 * m.angular_step) << turn;
  }
  // All the way round: the rotations cover the circle once (to within a step).
  const FastMatch m = matcher.MatchChecked(SE2d(5, 4, 0), RoomScan(kRoomTruth), 0.6, 0.3, 0.035, 0, 5.2, M_PI);
  EXPECT_NEAR(m.rotations * m.angular_step, 2 * M_PI, 3 * m.angular_step);
}

TEST(FastCorrelativeScanMatcherTest, EveryDepthGivesTheSameAnswer) {
  const ProbabilityGrid grid = RoomGrid(0.1);
  const SE2d truth(7.0, 3.0, -2.0);
  const std::vector<Eigen::Vector2d> points = RoomScan(truth);
  const SE2d guess(6.4, 3.5, -1.85);
  double score = -1;
  for (int depth : {1, 2, 4, 7, 9}) {
    FastMatcherOptions o;
    o.linear_search_window = 1.0;
    o.angular_search_window = 0.25;
    o.branch_and_bound_depth = depth;
    const FastMatch m = FastCorrelativeScanMatcher2D(grid, o).Match(guess, points, 0.3);
    ASSERT_TRUE(m.found) << depth;
    if (score < 0) score = m.score;
    EXPECT_EQ(m.score, score) << depth;
    EXPECT_LT((m.pose.translation() - truth.translation()).norm(), 1.5 * 0.1) << depth;  // a cell
  }
}

TEST(FastCorrelativeScanMatcherTest, RefusesBadInput) {
  const ProbabilityGrid grid = RoomGrid(0.1);
  FastMatcherOptions bad;
  bad.branch_and_bound_depth = 0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("depth"), std::string::npos);
  EXPECT_THROW(FastCorrelativeScanMatcher2D(grid, bad), InvalidArgument);
  bad = FastMatcherOptions();
  bad.linear_search_window = std::nan("");
  EXPECT_THROW(FastCorrelativeScanMatcher2D(grid, bad), InvalidArgument);
  const FastCorrelativeScanMatcher2D m(grid);
  EXPECT_THROW(m.Match(SE2d(), {}, 0.5), InvalidArgument);
  EXPECT_THROW(m.Match(SE2d(std::nan(""), 0, 0), {Eigen::Vector2d(1, 0)}, 0.5), InvalidArgument);
  EXPECT_THROW(m.MatchExhaustive(SE2d(), {Eigen::Vector2d(1, std::nan(""))}, 0.5), InvalidArgument);
  // An empty grid: every cell unknown, nothing above a threshold of 0.5.
  const ProbabilityGrid empty(0.1);
  EXPECT_FALSE(FastCorrelativeScanMatcher2D(empty).Match(SE2d(), {Eigen::Vector2d(1, 0)}, 0.5).found);
}

// By brute force: the best score of the candidates of `m`'s window that are not within
// `distance` (m) and `angle` (rad) of m.pose, scored as the matcher scores them.
float BestRival(const ProbabilityGrid& grid, const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                const FastMatch& m, double distance, double angle) {
  const double r = grid.resolution();
  const int K = (m.rotations - 1) / 2, W = (m.translations - 1) / 2;
  const double kb = WrapAngle(m.pose.theta() - guess.theta()) / m.angular_step;
  const double xb = (m.pose.x() - guess.x()) / r, yb = (m.pose.y() - guess.y()) / r;
  float best = 0;
  for (int k = -K; k <= K; ++k) {
    std::vector<Cell> cells;
    const SE2d turned(guess.x(), guess.y(), guess.theta() + k * m.angular_step);
    for (const Eigen::Vector2d& p : points) cells.push_back(grid.CellOf(turned * p));
    for (int dx = -W; dx <= W; ++dx) {
      for (int dy = -W; dy <= W; ++dy) {
        if (std::abs(k - kb) < angle / m.angular_step && std::hypot(dx - xb, dy - yb) < distance / r) continue;
        float sum = 0;
        for (const Cell& c : cells) sum += static_cast<float>(grid.Probability(c + Cell(dx, dy)));
        best = std::max(best, sum / static_cast<float>(points.size()));
      }
    }
  }
  return best;
}

// In a corridor whose ends the scan does not reach, the walls match anywhere along it: the
// match has a rival 0.3 m away scoring about as well. HasRival finds exactly the candidates
// the brute force finds.
TEST(FastCorrelativeScanMatcherTest, ACorridorMatchHasARival) {
  std::vector<Segment> walls;
  testing::AddRectangle(0, 0, 40, 2, &walls);
  const ProbabilityGrid grid = WallGrid(walls, 0.05, 0, 0, 40, 2);
  FastMatcherOptions o;
  o.linear_search_window = 1.0;
  o.angular_search_window = 0.1;
  const FastCorrelativeScanMatcher2D matcher(grid, o);
  const SE2d truth(20.0, 0.9, 0.05);
  const std::vector<Eigen::Vector2d> points = testing::ScanPoints(walls, truth, 181, 6.0);
  ASSERT_GT(points.size(), 100u);
  const SE2d guess(20.4, 1.1, 0.0);
  const FastMatch m = matcher.Match(guess, points, 0.5);
  ASSERT_TRUE(m.found);
  EXPECT_LT(std::abs(m.pose.y() - truth.y()), 0.08);  // across the corridor: well defined
  const float rival = BestRival(grid, guess, points, m, 0.3, 0.035);
  EXPECT_GT(rival, 0.9 * m.score) << rival << " against " << m.score;
  EXPECT_TRUE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, 0.9 * m.score));
  EXPECT_TRUE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, rival - 1e-4));
  EXPECT_FALSE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, rival + 1e-4));
  // Both in one call, the candidates prepared once: the same match, found ambiguous where it
  // is not on the window's edge (there the rival search is skipped; along a uniform corridor
  // the best may lie anywhere, the edge too). The pose graph's corridor test sees both.
  const FastMatch checked = matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0.9);
  EXPECT_EQ(checked.score, m.score);
  EXPECT_EQ(checked.pose.translation(), m.pose.translation());
  EXPECT_EQ(checked.on_edge, m.on_edge);
  EXPECT_EQ(checked.ambiguous, !m.on_edge);
  EXPECT_FALSE(matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0).ambiguous);  // ratio 0: not checked
  EXPECT_FALSE(m.ambiguous);                                                        // Match never checks
}

// In the room (a box inside breaks its symmetry) the best match has no rival near its score.
TEST(FastCorrelativeScanMatcherTest, ARoomMatchHasNoRival) {
  const ProbabilityGrid grid = RoomGrid(0.05);
  FastMatcherOptions o;
  o.linear_search_window = 1.0;
  o.angular_search_window = 0.2;
  const FastCorrelativeScanMatcher2D matcher(grid, o);
  const SE2d truth(3.2, 2.7, 0.4);
  const std::vector<Eigen::Vector2d> points = RoomScan(truth);
  const SE2d guess(truth.x() + 0.6, truth.y() - 0.5, truth.theta() - 0.1);
  const FastMatch m = matcher.Match(guess, points, 0.5);
  ASSERT_TRUE(m.found);
  const float rival = BestRival(grid, guess, points, m, 0.3, 0.035);
  EXPECT_LT(rival, 0.9 * m.score) << rival << " against " << m.score;
  EXPECT_FALSE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, 0.9 * m.score));
  EXPECT_TRUE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, rival - 1e-4));
  EXPECT_FALSE(matcher.HasRival(guess, points, m.pose, 0.3, 0.035, rival + 1e-4));
  // A neighbourhood larger than the window leaves no candidate at all.
  EXPECT_FALSE(matcher.HasRival(guess, points, m.pose, 10, 1, 0));
  const FastMatch checked = matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 0.9);
  EXPECT_EQ(checked.score, m.score);
  EXPECT_FALSE(checked.ambiguous);
  EXPECT_THROW(matcher.MatchChecked(guess, points, 0.5, 0.3, 0.035, 1.5), InvalidArgument);
  EXPECT_THROW(matcher.HasRival(guess, points, m.pose, -1, 0.035, 0.5), InvalidArgument);
  EXPECT_THROW(matcher.HasRival(guess, points, m.pose, 0.3, std::nan(""), 0.5), InvalidArgument);
}

// On a real log: a map of the first 60 scans of the corrected Intel log (their scan endpoints
// as hits), and scan 40 matched from a guess 1.2 m and 8 degrees off. Branch and bound equals
// the exhaustive search and lands on the scan's corrected pose.
TEST(FastCorrelativeScanMatcherTest, RealScansMatchTheExhaustiveSearch) {
  const std::string path = testing::LidarDataset("corrected/intel-corrected.log.gz");
  if (path.empty())
    GTEST_SKIP()
        << "dataset lidar/corrected/intel-corrected.log.gz absent (../shared/datasets not beside the repository)";
  LidarReadOptions ro;
  ro.limits.max_range = 15;
  const LidarLog log = ReadLidarLog(path, ro);
  ASSERT_GT(log.scans.size(), 60u);
  ProbabilityGrid grid(0.05);
  for (std::size_t i = 0; i < 60; ++i) {
    const SE2d laser = log.scans[i].odometry * log.scans[i].laser_in_robot;
    for (const Eigen::Vector2d& p : ScanToPoints(log.scans[i], ro.limits))
      grid.SetProbability(grid.CellOf(laser * p), 0.9);
  }
  const LaserScan& scan = log.scans[40];
  const SE2d truth = scan.odometry * scan.laser_in_robot;
  const std::vector<Eigen::Vector2d> points = ScanToPoints(scan, ro.limits);
  FastMatcherOptions o;
  o.linear_search_window = 1.5;
  o.angular_search_window = 0.2;
  const FastCorrelativeScanMatcher2D matcher(grid, o);
  const SE2d guess(truth.x() + 0.9, truth.y() - 0.8, truth.theta() + 0.14);
  const FastMatch fast = matcher.Match(guess, points, 0.4);
  const FastMatch full = matcher.MatchExhaustive(guess, points, 0.4);
  ASSERT_TRUE(fast.found);
  EXPECT_EQ(fast.score, full.score);
  EXPECT_LT(fast.nodes * 20, full.nodes) << fast.nodes << " of " << full.nodes;
  EXPECT_LT((fast.pose.translation() - truth.translation()).norm(), 0.1);
  EXPECT_LT(std::abs(WrapAngle(fast.pose.theta() - truth.theta())), 0.02);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
