#pragma once
// A simulated maze for a 2D scanner, with known truth: a grid of square cells (by default 8 x 8
// cells of 2 m, a 16 m x 16 m maze with its lower-left corner at the origin), made a perfect
// maze by a seeded randomised depth-first search (one way between any two cells), then a
// `loops` fraction of the inner walls still standing removed so that it has loops; the outer
// wall is closed. Collinear walls of neighbouring cells are merged into one segment.
// SimulateLidar (lidar_world.h) with world = LidarWorld::kMaze drives a MazeTour through it.
//
//   const tether::lidar::Maze maze = tether::lidar::MakeMaze(/*seed=*/3, {});
//   const std::vector<WallSegment> walls = maze.Walls();  // == MazeWorld(3)
//
// Deterministic for a seed on every platform (tether/frontends/simulation/random_stream.h).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tether/frontends/simulation/random_stream.h"
#include "tether/frontends/simulation/walls.h"

namespace tether {
namespace lidar {

struct MazeOptions {
  int cells_x = 8;         ///< cells along x
  int cells_y = 8;         ///< cells along y
  double cell_size = 2.0;  ///< metres: the side of a cell (the corridors' width)
  double loops = 0.1;      ///< the fraction of the inner walls left by the search that is removed

  /// False (and why) for fewer than 2 or more than 1000 cells along an axis, a cell size that is
  /// not positive and finite, loops outside [0, 1].
  bool IsValid(std::string* why) const;
};

/// The maze's cells and passages. Cell (x, y) is number y * cells_x + x, its lower-left corner
/// at (x, y) * cell_size. Directions: 0 +x, 1 +y, 2 -x, 3 -y.
struct Maze {
  int cells_x = 0, cells_y = 0;
  double cell_size = 0;
  /// open[cell][direction]: no wall between the cell and its neighbour that way (never towards
  /// the outside).
  std::vector<std::array<bool, 4>> open;

  int Cells() const { return cells_x * cells_y; }
  /// The neighbour that way; -1 outside the maze.
  int Neighbour(int cell, int direction) const;
  Eigen::Vector2d Centre(int cell) const;
  /// The cell holding p; -1 outside the maze.
  int CellOf(const Eigen::Vector2d& p) const;
  /// The walls: every side of a cell that is not open, collinear neighbours merged.
  std::vector<WallSegment> Walls() const;
};

/// The maze for a seed. Throws InvalidArgument where the options are not valid.
Maze MakeMaze(std::uint64_t seed, const MazeOptions& options = {});

/// MakeMaze(seed, options).Walls().
std::vector<WallSegment> MazeWorld(std::uint64_t seed, const MazeOptions& options = {});

/// A route through a maze along the cells' centre lines: from the start cell, again and again
/// the shortest way (breadth-first over the passages) to an unvisited cell nearest to the one
/// reached (ties broken by the seed), passing only through open sides; once every cell has been
/// visited a new tour begins. Next() never ends.
class MazeTour {
 public:
  MazeTour(const Maze& maze, std::uint64_t seed, int start_cell = 0);
  /// The start cell's centre.
  Eigen::Vector2d Start() const { return maze_.Centre(start_); }
  /// The next waypoint: the centre of a cell next to the previous one, through an open side.
  Eigen::Vector2d Next();
  int cell() const { return current_; }                 ///< the cell of the last waypoint given
  int tours() const { return tours_; }                  ///< tours begun (1 at the start)
  int cells_visited() const { return cells_visited_; }  ///< distinct cells reached so far

 private:
  void Plan();

  Maze maze_;
  RandomStream random_;
  int start_ = 0, current_ = 0;
  std::vector<bool> visited_;  // in this tour
  std::vector<bool> ever_;     // in any tour
  std::vector<int> queue_;     // the cells still to pass, first first
  std::size_t next_ = 0;       // the next in queue_
  int tours_ = 1, cells_visited_ = 1;
};

}  // namespace lidar
}  // namespace tether
