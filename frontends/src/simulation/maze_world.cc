#include "tether/frontends/simulation/maze_world.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

namespace {

// The random streams of a seed (the office's are 1 to 4, lidar_world.cc).
constexpr std::uint64_t kMazeStream = 5, kTourStream = 6;
constexpr int kMaxCells = 1000;  // along an axis
constexpr int kDx[4] = {1, 0, -1, 0}, kDy[4] = {0, 1, 0, -1};

// An index in [0, n).
std::size_t Pick(RandomStream& random, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(random.Uniform() * static_cast<double>(n)));
}

void Connect(Maze* maze, int cell, int direction) {
  maze->open[static_cast<std::size_t>(cell)][static_cast<std::size_t>(direction)] = true;
  const int other = maze->Neighbour(cell, direction);
  maze->open[static_cast<std::size_t>(other)][static_cast<std::size_t>((direction + 2) % 4)] = true;
}

// The randomised depth-first search: from a random cell, into a random unvisited neighbour,
// back up where there is none.
void Carve(RandomStream& random, Maze* maze) {
  std::vector<bool> visited(static_cast<std::size_t>(maze->Cells()), false);
  std::vector<int> stack = {static_cast<int>(Pick(random, static_cast<std::size_t>(maze->Cells())))};
  visited[static_cast<std::size_t>(stack.back())] = true;
  while (!stack.empty()) {
    const int cell = stack.back();
    std::vector<int> ways;
    for (int d = 0; d < 4; ++d) {
      const int n = maze->Neighbour(cell, d);
      if (n >= 0 && !visited[static_cast<std::size_t>(n)]) ways.push_back(d);
    }
    if (ways.empty()) {
      stack.pop_back();
      continue;
    }
    const int d = ways[Pick(random, ways.size())];
    Connect(maze, cell, d);
    const int n = maze->Neighbour(cell, d);
    visited[static_cast<std::size_t>(n)] = true;
    stack.push_back(n);
  }
}

// Removes round(fraction x the inner walls standing), chosen at random.
void OpenLoops(RandomStream& random, double fraction, Maze* maze) {
  std::vector<std::pair<int, int>> standing;  // (cell, direction +x or +y)
  for (int cell = 0; cell < maze->Cells(); ++cell) {
    for (int d : {0, 1}) {
      if (maze->Neighbour(cell, d) >= 0 && !maze->open[static_cast<std::size_t>(cell)][static_cast<std::size_t>(d)]) {
        standing.emplace_back(cell, d);
      }
    }
  }
  const std::size_t remove = static_cast<std::size_t>(std::lround(fraction * static_cast<double>(standing.size())));
  for (std::size_t i = 0; i < remove; ++i) {  // a partial Fisher-Yates shuffle
    std::swap(standing[i], standing[i + Pick(random, standing.size() - i)]);
    Connect(maze, standing[i].first, standing[i].second);
  }
}

bool Fail(std::string* why, const char* what) {
  if (why != nullptr) *why = what;
  return false;
}

}  // namespace

bool MazeOptions::IsValid(std::string* why) const {
  if (cells_x < 2 || cells_x > kMaxCells || cells_y < 2 || cells_y > kMaxCells) {
    return Fail(why, "maze cells_x and cells_y must be in [2, 1000]");
  }
  if (!(cell_size > 0) || !std::isfinite(cell_size)) return Fail(why, "maze cell_size must be positive (metres)");
  if (!(loops >= 0 && loops <= 1)) return Fail(why, "maze loops must be in [0, 1]");
  return true;
}

int Maze::Neighbour(int cell, int direction) const {
  const int x = cell % cells_x + kDx[direction], y = cell / cells_x + kDy[direction];
  return x < 0 || x >= cells_x || y < 0 || y >= cells_y ? -1 : y * cells_x + x;
}

Eigen::Vector2d Maze::Centre(int cell) const {
  return cell_size * Eigen::Vector2d(cell % cells_x + 0.5, cell / cells_x + 0.5);
}

int Maze::CellOf(const Eigen::Vector2d& p) const {
  const double x = std::floor(p.x() / cell_size), y = std::floor(p.y() / cell_size);
  if (!(x >= 0 && x < cells_x && y >= 0 && y < cells_y)) return -1;
  return static_cast<int>(y) * cells_x + static_cast<int>(x);
}

std::vector<WallSegment> Maze::Walls() const {
  std::vector<WallSegment> walls;
  const auto closed = [&](int x, int y, int d) {  // the side of cell (x, y) that way
    return !open[static_cast<std::size_t>(y * cells_x + x)][static_cast<std::size_t>(d)];
  };
  // Along each line between rows (y = j cell_size), then between columns, runs of closed sides.
  for (int horizontal = 1; horizontal >= 0; --horizontal) {
    const int lines = horizontal ? cells_y : cells_x, length = horizontal ? cells_x : cells_y;
    for (int j = 0; j <= lines; ++j) {
      int start = -1;
      for (int i = 0; i <= length; ++i) {
        bool wall = false;
        if (i < length) {
          // The side below (left of) the line's j-th row (column), or above (right of) the last.
          wall = j == 0 || j == lines || (horizontal ? closed(i, j - 1, 1) : closed(j - 1, i, 0));
        }
        if (wall && start < 0) start = i;
        if (!wall && start >= 0) {
          const auto at = [&](int s) {
            return horizontal ? Eigen::Vector2d(s * cell_size, j * cell_size)
                              : Eigen::Vector2d(j * cell_size, s * cell_size);
          };
          walls.push_back({at(start), at(i)});
          start = -1;
        }
      }
    }
  }
  return walls;
}

Maze MakeMaze(std::uint64_t seed, const MazeOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("maze: " + why);
  Maze maze;
  maze.cells_x = options.cells_x;
  maze.cells_y = options.cells_y;
  maze.cell_size = options.cell_size;
  maze.open.assign(static_cast<std::size_t>(maze.Cells()), {false, false, false, false});
  RandomStream random(seed, kMazeStream);
  Carve(random, &maze);
  OpenLoops(random, options.loops, &maze);
  return maze;
}

std::vector<WallSegment> MazeWorld(std::uint64_t seed, const MazeOptions& options) {
  return MakeMaze(seed, options).Walls();
}

MazeTour::MazeTour(const Maze& maze, std::uint64_t seed, int start_cell)
    : maze_(maze), random_(seed, kTourStream), start_(start_cell), current_(start_cell) {
  if (maze.Cells() < 2 || maze.open.size() != static_cast<std::size_t>(maze.Cells())) {
    throw InvalidArgument("maze tour: the maze has fewer than 2 cells or not one entry of open sides per cell");
  }
  if (start_cell < 0 || start_cell >= maze.Cells())
    throw InvalidArgument("maze tour: the start cell is not in the maze");
  visited_.assign(static_cast<std::size_t>(maze.Cells()), false);
  ever_ = visited_;
  visited_[static_cast<std::size_t>(start_)] = ever_[static_cast<std::size_t>(start_)] = true;
}

Eigen::Vector2d MazeTour::Next() {
  if (next_ >= queue_.size()) Plan();
  current_ = queue_[next_++];
  const std::size_t c = static_cast<std::size_t>(current_);
  visited_[c] = true;
  if (!ever_[c]) {
    ever_[c] = true;
    ++cells_visited_;
  }
  return maze_.Centre(current_);
}

// Breadth-first from the current cell to the nearest unvisited cells, one of them by the seed;
// the cells on the way to it are queued. Where every cell is visited a new tour begins.
void MazeTour::Plan() {
  const std::size_t cells = static_cast<std::size_t>(maze_.Cells());
  if (std::find(visited_.begin(), visited_.end(), false) == visited_.end()) {
    visited_.assign(cells, false);
    visited_[static_cast<std::size_t>(current_)] = true;
    ++tours_;
  }
  std::vector<int> parent(cells, -1), distance(cells, -1), nearest;
  std::vector<int> frontier = {current_};
  distance[static_cast<std::size_t>(current_)] = 0;
  for (std::size_t head = 0; head < frontier.size(); ++head) {
    const int cell = frontier[head];
    if (!nearest.empty() && distance[static_cast<std::size_t>(cell)] > distance[static_cast<std::size_t>(nearest[0])]) {
      break;
    }
    if (!visited_[static_cast<std::size_t>(cell)]) nearest.push_back(cell);
    for (int d = 0; d < 4; ++d) {
      const int n = maze_.Neighbour(cell, d);
      if (n < 0 || !maze_.open[static_cast<std::size_t>(cell)][static_cast<std::size_t>(d)]) continue;
      if (distance[static_cast<std::size_t>(n)] >= 0) continue;
      distance[static_cast<std::size_t>(n)] = distance[static_cast<std::size_t>(cell)] + 1;
      parent[static_cast<std::size_t>(n)] = cell;
      frontier.push_back(n);
    }
  }
  if (nearest.empty()) throw InvalidArgument("maze tour: a cell cannot be reached (the maze is not connected)");
  std::vector<int> way;
  for (int cell = nearest[Pick(random_, nearest.size())]; cell != current_;
       cell = parent[static_cast<std::size_t>(cell)]) {
    way.push_back(cell);
  }
  queue_.assign(way.rbegin(), way.rend());
  next_ = 0;
}

}  // namespace lidar
}  // namespace tether
