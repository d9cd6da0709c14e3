// The simulated maze: connected, the same for a seed and different for another; the robot's
// route stays on the cells' centre lines clear of the walls, its scans are the ray casts at the
// true poses; the rasterised map has the walls occupied and the corridors free; the office run
// is the one it was before the maze came (numbers printed by the code before the change).
#include "tether/frontends/simulation/maze_world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <set>

#include "tether/core/error.h"
#include "tether/frontends/simulation/lidar_world.h"
#include "tether/frontends/simulation/walls.h"

namespace tether {
namespace lidar {
namespace {

// The cells reachable from cell 0 through open sides.
int Reachable(const Maze& maze) {
  std::vector<bool> seen(static_cast<std::size_t>(maze.Cells()), false);
  std::deque<int> queue = {0};
  seen[0] = true;
  int count = 0;
  while (!queue.empty()) {
    const int c = queue.front();
    queue.pop_front();
    ++count;
    for (int d = 0; d < 4; ++d) {
      const int n = maze.Neighbour(c, d);
      if (n >= 0 && maze.open[static_cast<std::size_t>(c)][static_cast<std::size_t>(d)] &&
          !seen[static_cast<std::size_t>(n)]) {
        seen[static_cast<std::size_t>(n)] = true;
        queue.push_back(n);
      }
    }
  }
  return count;
}

// The pixel (column, row) holding p, as RasterizeWalls places it.
std::pair<int, int> PixelOf(const OccupancyImage& image, const Eigen::Vector2d& p) {
  const int c = static_cast<int>(std::floor((p.x() - image.origin.x()) / image.resolution));
  const int u = static_cast<int>(std::floor((p.y() - image.origin.y()) / image.resolution));
  return {c, image.height - 1 - u};
}

// The pixels reached from `from` through free pixels (4-neighbours).
std::vector<bool> FloodFree(const OccupancyImage& image, std::pair<int, int> from) {
  std::vector<bool> seen(image.pixels.size(), false);
  std::deque<std::pair<int, int>> queue = {from};
  seen[static_cast<std::size_t>(from.second * image.width + from.first)] = true;
  while (!queue.empty()) {
    const auto [c, r] = queue.front();
    queue.pop_front();
    for (const auto& [dc, dr] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
      const int nc = c + dc, nr = r + dr;
      if (nc < 0 || nr < 0 || nc >= image.width || nr >= image.height) continue;
      const std::size_t i = static_cast<std::size_t>(nr * image.width + nc);
      if (seen[i] || image.pixels[i] != 254) continue;
      seen[i] = true;
      queue.push_back({nc, nr});
    }
  }
  return seen;
}

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// True where the segments p0-p1 and q0-q1 meet (touching included).
bool Meet(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& q0, const Eigen::Vector2d& q1) {
  const double d1 = Cross(p1 - p0, q0 - p0), d2 = Cross(p1 - p0, q1 - p0);
  const double d3 = Cross(q1 - q0, p0 - q0), d4 = Cross(q1 - q0, p1 - q0);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  const auto on = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
    return std::abs(Cross(b - a, p - a)) < 1e-12 && (p - a).dot(p - b) <= 0;
  };
  return on(p0, p1, q0) || on(p0, p1, q1) || on(q0, q1, p0) || on(q0, q1, p1);
}

LidarSimOptions MazeRun(int scans, std::uint64_t seed) {
  LidarSimOptions o;
  o.world = LidarWorld::kMaze;
  o.scans = scans;
  o.seed = seed;
  return o;
}

TEST(MazeWorldTest, EveryCellIsReachableAndTheOuterWallClosed) {
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    for (const MazeOptions& options : {MazeOptions{}, MazeOptions{5, 7, 1.5, 0.0}, MazeOptions{12, 3, 2.0, 0.3}}) {
      const Maze maze = MakeMaze(seed, options);
      ASSERT_EQ(maze.Cells(), options.cells_x * options.cells_y);
      EXPECT_EQ(Reachable(maze), maze.Cells()) << seed;
      int passages = 0;
      for (int c = 0; c < maze.Cells(); ++c) {
        for (int d = 0; d < 4; ++d) {
          const bool open = maze.open[static_cast<std::size_t>(c)][static_cast<std::size_t>(d)];
          const int n = maze.Neighbour(c, d);
          if (n < 0) {
            EXPECT_FALSE(open) << "an open side to the outside, cell " << c;
            continue;
          }
          EXPECT_EQ(open, maze.open[static_cast<std::size_t>(n)][static_cast<std::size_t>((d + 2) % 4)]);
          passages += open ? 1 : 0;
        }
      }
      passages /= 2;
      // A perfect maze has cells - 1 passages (a tree); the loops add a fraction of the rest.
      const int inner = options.cells_x * (options.cells_y - 1) + options.cells_y * (options.cells_x - 1);
      const int standing = inner - (maze.Cells() - 1);
      EXPECT_EQ(passages, maze.Cells() - 1 + static_cast<int>(std::lround(options.loops * standing))) << seed;

      // The map's free pixels join every cell's centre to cell 0's.
      const OccupancyImage image = RasterizeWalls(maze.Walls(), 0.05, 4);
      const std::vector<bool> reached = FloodFree(image, PixelOf(image, maze.Centre(0)));
      for (int c = 0; c < maze.Cells(); ++c) {
        const auto [col, row] = PixelOf(image, maze.Centre(c));
        EXPECT_TRUE(reached[static_cast<std::size_t>(row * image.width + col)]) << "seed " << seed << " cell " << c;
      }
      // Nothing leaks out: the padding outside the outer wall is not reached.
      EXPECT_FALSE(reached[0]);
    }
  }
}

TEST(MazeWorldTest, TheSameSeedGivesTheSameMazeAnotherSeedAnother) {
  const std::vector<WallSegment> a = MazeWorld(3), b = MazeWorld(3), c = MazeWorld(4);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].a, b[i].a);
    EXPECT_EQ(a[i].b, b[i].b);
  }
  std::set<std::array<double, 4>> sa, sc;
  for (const WallSegment& w : a) sa.insert({w.a.x(), w.a.y(), w.b.x(), w.b.y()});
  for (const WallSegment& w : c) sc.insert({w.a.x(), w.a.y(), w.b.x(), w.b.y()});
  EXPECT_NE(sa, sc);
  // 16 m x 16 m, the walls on the 2 m lines, merged: fewer segments than closed cell sides.
  const Maze maze = MakeMaze(3);
  int sides = 0;
  for (const auto& open : maze.open) {
    for (bool o : open) sides += o ? 0 : 1;
  }
  sides = (sides + 2 * 8 + 2 * 8) / 2;  // inner sides are counted twice, outer ones once
  EXPECT_LT(static_cast<int>(a.size()), sides);
  double length = 0;
  for (const WallSegment& w : a) {
    length += (w.b - w.a).norm();
    for (const Eigen::Vector2d& p : {w.a, w.b}) {
      EXPECT_GE(p.minCoeff(), 0);
      EXPECT_LE(p.maxCoeff(), 16);
      EXPECT_NEAR(std::remainder(p.x(), 2.0), 0, 1e-12);
      EXPECT_NEAR(std::remainder(p.y(), 2.0), 0, 1e-12);
    }
  }
  EXPECT_NEAR(length, 2.0 * sides, 1e-9);
  // The simulation's walls are the maze's.
  const SimulatedLidar sim = SimulateLidar(MazeRun(20, 3));
  EXPECT_EQ(sim.walls.size(), a.size());
}

TEST(MazeWorldTest, TheTourGoesThroughOpenSidesAndBeginsAgain) {
  const Maze maze = MakeMaze(5);
  MazeTour tour(maze, 5);
  EXPECT_EQ(tour.Start(), maze.Centre(0));
  int previous = 0;
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector2d p = tour.Next();
    const int cell = maze.CellOf(p);
    ASSERT_EQ(cell, tour.cell());
    ASSERT_LT((p - maze.Centre(cell)).norm(), 1e-12);
    int way = -1;
    for (int d = 0; d < 4; ++d) way = maze.Neighbour(previous, d) == cell ? d : way;
    ASSERT_GE(way, 0) << "not a neighbour, step " << k;
    ASSERT_TRUE(maze.open[static_cast<std::size_t>(previous)][static_cast<std::size_t>(way)]) << "through a wall";
    previous = cell;
  }
  EXPECT_EQ(tour.cells_visited(), maze.Cells());
  EXPECT_GT(tour.tours(), 3);  // a tour of the 64 cells takes a few hundred steps at most
  EXPECT_THROW(MazeTour(maze, 5, 64), InvalidArgument);
}

TEST(MazeWorldTest, TheRouteKeepsClearOfTheWalls) {
  const SimulatedLidar sim = SimulateLidar(MazeRun(4000, 7));
  ASSERT_EQ(sim.truth.size(), 4000u);
  EXPECT_EQ(sim.cells_visited, 64);
  EXPECT_GE(sim.tours, 1);
  EXPECT_EQ(sim.laps, 0);
  double closest = INFINITY;
  for (std::size_t k = 0; k < sim.truth.size(); ++k) {
    const Eigen::Vector2d p = sim.truth[k].pose.translation();
    closest = std::min(closest, DistanceToWalls(sim.walls, p));
    if (k == 0) continue;
    const Eigen::Vector2d q = sim.truth[k - 1].pose.translation();
    EXPECT_LE((p - q).norm(), 0.1 + 1e-12);
    for (const WallSegment& w : sim.walls) ASSERT_FALSE(Meet(q, p, w.a, w.b)) << "step " << k;
  }
  // On the centre lines (1 m from the walls), cutting corners a little.
  EXPECT_GT(closest, 0.8);
  EXPECT_NEAR(sim.distance, 4000 * 0.1, 150);
}

TEST(MazeWorldTest, TheScansAreTheRayCastsAtTheTruth) {
  LidarSimOptions o = MazeRun(600, 2);
  o.beams = 90;
  const SimulatedLidar sim = SimulateLidar(o);
  std::size_t beams = 0, far = 0;
  for (std::size_t k = 0; k < sim.log.scans.size(); k += 13) {
    const LaserScan& s = sim.log.scans[k];
    EXPECT_EQ(s.stamp, sim.truth[k].stamp);
    for (std::size_t i = 0; i < s.ranges.size(); ++i) {
      const double a = sim.truth[k].pose.theta() + s.Angle(i);
      const double r = CastRay(sim.walls, sim.truth[k].pose.translation(), {std::cos(a), std::sin(a)});
      ASSERT_TRUE(std::isfinite(r));  // closed: every beam meets a wall
      ++beams;
      EXPECT_NEAR(s.ranges[i], std::min(r, o.max_range), 6 * o.range_noise);
      far += std::abs(s.ranges[i] - r) > 3 * o.range_noise ? 1 : 0;
    }
  }
  EXPECT_GT(beams, 4000u);
  EXPECT_LT(far, beams / 100 + 1);  // 3 sigmas: about 3 in 1000
  // Without noise, to float rounding.
  o.range_noise = 0;
  o.scans = 60;
  const SimulatedLidar exact = SimulateLidar(o);
  for (std::size_t k = 0; k < exact.log.scans.size(); k += 7) {
    const LaserScan& s = exact.log.scans[k];
    for (std::size_t i = 0; i < s.ranges.size(); ++i) {
      const double a = exact.truth[k].pose.theta() + s.Angle(i);
      const double r = CastRay(exact.walls, exact.truth[k].pose.translation(), {std::cos(a), std::sin(a)});
      EXPECT_NEAR(s.ranges[i], r, 1e-5 * r);
    }
  }
  // The odometry drifts from the truth as the office's does.
  EXPECT_EQ(sim.log.odometry.size(), 600u);
  EXPECT_GT((sim.log.scans.back().odometry.translation() - sim.truth.back().pose.translation()).norm(), 1e-3);
}

TEST(MazeWorldTest, TheMapHasTheWallsOccupiedAndTheCorridorsFree) {
  const std::vector<WallSegment> walls = MazeWorld(9);
  const OccupancyImage image = RasterizeWalls(walls, 0.05, 10);
  EXPECT_EQ(image.resolution, 0.05);
  EXPECT_NEAR(image.origin.x(), -0.5, 1e-12);
  EXPECT_NEAR(image.origin.y(), -0.5, 1e-12);
  EXPECT_NEAR(image.width, 16 / 0.05 + 21, 1);
  EXPECT_NEAR(image.height, 16 / 0.05 + 21, 1);
  ASSERT_EQ(image.pixels.size(), static_cast<std::size_t>(image.width * image.height));
  for (const WallSegment& w : walls) {
    for (int i = 0; i <= 97; ++i) {
      const auto [c, r] = PixelOf(image, w.a + (w.b - w.a) * (i / 97.0));
      EXPECT_EQ(image.Pixel(c, r), 0) << c << " " << r;
    }
  }
  int free = 0, occupied = 0;
  for (int r = 0; r < image.height; ++r) {
    for (int c = 0; c < image.width; ++c) {
      const Eigen::Vector2d centre =
          image.origin + image.resolution * Eigen::Vector2d(c + 0.5, image.height - 1 - r + 0.5);
      const std::uint8_t v = image.Pixel(c, r);
      const bool inside = centre.minCoeff() > 0 && centre.maxCoeff() < 16;
      if (!inside) {
        EXPECT_NE(v, 254) << c << " " << r;  // the padding is unknown, the outer wall occupied
        if (centre.minCoeff() < -0.1 || centre.maxCoeff() > 16.1) {
          EXPECT_EQ(v, kUnknownPixel);
        }
      } else if (DistanceToWalls(walls, centre) > image.resolution) {
        EXPECT_EQ(v, 254) << c << " " << r;
      }
      free += v == 254 ? 1 : 0;
      occupied += v == 0 ? 1 : 0;
    }
  }
  EXPECT_GT(free, 300 * 300);
  EXPECT_GT(occupied, 16 * 4 / 0.05);
  // The office too; bad arguments are refused.
  const OccupancyImage office = RasterizeWalls(OfficeWorld(1), 0.1, 0);
  EXPECT_EQ(office.width, 401);
  EXPECT_EQ(office.height, 301);
  EXPECT_THROW(RasterizeWalls({}, 0.05), InvalidArgument);
  EXPECT_THROW(RasterizeWalls(walls, 0), InvalidArgument);
  EXPECT_THROW(RasterizeWalls(walls, 0.05, -1), InvalidArgument);
  EXPECT_THROW(RasterizeWalls(walls, 1e-6), InvalidArgument);
}

TEST(MazeWorldTest, OptionsAndNames) {
  std::string why;
  LidarSimOptions o = MazeRun(100, 1);
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.maze.cells_x = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("cells_x"), std::string::npos) << why;
  EXPECT_THROW(SimulateLidar(o), InvalidArgument);
  o.world = LidarWorld::kOffice;  // the maze's options do not matter to the office
  EXPECT_TRUE(o.IsValid(&why)) << why;
  MazeOptions m;
  m.loops = 1.5;
  EXPECT_FALSE(m.IsValid(&why));
  m.loops = 1;
  m.cell_size = -1;
  EXPECT_FALSE(m.IsValid(&why));
  EXPECT_THROW(MakeMaze(1, m), InvalidArgument);
  EXPECT_STREQ(ToString(LidarWorld::kMaze), "maze");
  LidarWorld w = LidarWorld::kMaze;
  EXPECT_TRUE(FromString("office", &w));
  EXPECT_EQ(w, LidarWorld::kOffice);
  EXPECT_FALSE(FromString("castle", &w));
  EXPECT_EQ((EnumNameList<LidarWorld>()), "office or maze");
}

// The office's run for these options, printed by the simulator before the maze was added: the
// shared motion, scanner and odometry must give it unchanged.
TEST(MazeWorldTest, TheOfficeRunIsUnchanged) {
  LidarSimOptions o;
  o.scans = 400;
  o.beams = 16;
  o.seed = 7;
  const SimulatedLidar s = SimulateLidar(o);
  ASSERT_EQ(s.truth.size(), 400u);
  EXPECT_EQ(s.walls.size(), 117u);
  EXPECT_NEAR(s.distance, 30.984492114334852, 1e-9);
  struct Expected {
    std::size_t k;
    double truth[3], odometry[3];
    std::vector<float> ranges;
  };
  const Expected expected[] = {
      {25,
       {9.4999999999999911, 7, 0},
       {9.4934553823447505, 7.0297326707741838, -0.00061897210366562596},
       {3.51325989f, 2.60497618f, 9.89953518f, 1.0869242f, 1.00045359f, 1.0625751f, 1.41987753f, 2.60989308f, 20.f,
        2.61743116f, 1.40786159f, 1.09882569f, 1.00815439f, 1.1017226f, 1.42442942f, 3.77496648f}},
      {250,
       {13.99999594534877, 6.1871876207393148, 1.5707913383728049},
       {13.920221873983223, 6.2370944782799409, 1.5954054024041984},
       {6.18071175f, 6.68763733f, 7.06255865f, 5.41829395f, 20.f, 4.74641085f, 2.56335044f, 1.96042073f, 1.81990147f,
        15.6831131f, 2.57228756f, 4.74580765f, 8.01455784f, 5.41197634f, 7.0449872f, 6.69316339f}},
      {399,
       {26.889419005991041, 7.0090446961300463, -0.0022003413985965878},
       {26.797984262286988, 7.0487796028076648, -0.011460157612652856},
       {20.f, 2.66855979f, 1.42778528f, 1.08030403f, 1.01920724f, 1.09073031f, 1.42043078f, 2.62251687f, 7.10521173f,
        2.61043811f, 1.40796912f, 1.0868727f, 0.981357634f, 1.0659591f, 1.39662671f, 2.56790257f}},
  };
  for (const Expected& e : expected) {
    const SE2<double>& p = s.truth[e.k].pose;
    const SE2<double>& q = s.log.scans[e.k].odometry;
    EXPECT_NEAR(p.x(), e.truth[0], 1e-9) << e.k;
    EXPECT_NEAR(p.y(), e.truth[1], 1e-9) << e.k;
    EXPECT_NEAR(p.theta(), e.truth[2], 1e-9) << e.k;
    EXPECT_NEAR(q.x(), e.odometry[0], 1e-9) << e.k;
    EXPECT_NEAR(q.y(), e.odometry[1], 1e-9) << e.k;
    EXPECT_NEAR(q.theta(), e.odometry[2], 1e-9) << e.k;
    ASSERT_EQ(s.log.scans[e.k].ranges.size(), 16u);
    for (std::size_t i = 0; i < 16; ++i) EXPECT_NEAR(s.log.scans[e.k].ranges[i], e.ranges[i], 1e-5) << e.k << " " << i;
  }
}

}  // namespace
}  // namespace lidar
}  // namespace tether
