#include "tether/frontends/simulation/lidar_world.h"

#include <algorithm>
#include <cmath>
#include <deque>

#include "tether/core/error.h"
#include "tether/core/so2.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace lidar {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxScans = 10000000;
constexpr int kMaxBeams = 1 << 20;
constexpr double kDoorWidth = 1.0;
constexpr double kTakeDoor = 0.4;  // the probability of entering a room whose door is passed

// The random streams of one seed.
constexpr std::uint64_t kBoxStream = 1, kPathStream = 2, kRangeStream = 3, kOdometryStream = 4;

struct Room {
  double x0, y0, x1, y1;
  Eigen::Vector2d door;    // the door's centre, on the corridor's wall
  Eigen::Vector2d inward;  // unit, from the corridor into the room
};

// The rooms (see the header): the bottom and top rows, left, right, inside the loop.
std::vector<Room> Rooms() {
  const Eigen::Vector2d up(0, 1), down(0, -1), left(-1, 0), right(1, 0);
  return {{0, 0, 9, 6, {8, 6}, down},     {9, 0, 19, 6, {14, 6}, down},     {19, 0, 27, 6, {23, 6}, down},
          {27, 0, 40, 6, {31, 6}, down},  {0, 24, 12, 30, {9, 24}, up},     {12, 24, 20, 30, {16, 24}, up},
          {20, 24, 30, 30, {25, 24}, up}, {30, 24, 40, 30, {32, 24}, up},   {0, 6, 6, 15, {6, 10}, left},
          {0, 15, 6, 24, {6, 20}, left},  {34, 6, 40, 24, {34, 12}, right}, {8, 8, 19, 22, {13, 8}, up},
          {19, 8, 32, 22, {26, 22}, down}};
}

// The corridor's centre line: its corners in anticlockwise order.
const Eigen::Vector2d kCorners[4] = {{7, 7}, {33, 7}, {33, 23}, {7, 23}};

void Add(const Eigen::Vector2d& a, const Eigen::Vector2d& b, std::vector<WallSegment>* w) { w->push_back({a, b}); }

// A horizontal (or vertical) wall along y = c (x = c) from `from` to `to`, with doors of
// kDoorWidth centred at `doors`.
void Wall(bool horizontal, double c, double from, double to, std::vector<double> doors, std::vector<WallSegment>* w) {
  std::sort(doors.begin(), doors.end());
  const auto at = [&](double s) { return horizontal ? Eigen::Vector2d(s, c) : Eigen::Vector2d(c, s); };
  double start = from;
  for (double d : doors) {
    if (d - kDoorWidth / 2 > start) Add(at(start), at(d - kDoorWidth / 2), w);
    start = d + kDoorWidth / 2;
  }
  if (to > start) Add(at(start), at(to), w);
}

void Box(double x0, double y0, double x1, double y1, std::vector<WallSegment>* w) {
  Add({x0, y0}, {x1, y0}, w);
  Add({x1, y0}, {x1, y1}, w);
  Add({x1, y1}, {x0, y1}, w);
  Add({x0, y1}, {x0, y0}, w);
}

bool Fail(std::string* why, const char* what) {
  if (why != nullptr) *why = what;
  return false;
}

// The waypoints of the run, made as they are needed.
class Path {
 public:
  explicit Path(std::uint64_t seed) : random_(seed, kPathStream), rooms_(Rooms()) {
    anticlockwise_ = random_.Chance(0.5);
  }
  Eigen::Vector2d Start() const { return kCorners[0]; }
  // The next waypoint (the run never ends: laps follow laps).
  Eigen::Vector2d Next() {
    if (queue_.empty()) Leg();
    const Eigen::Vector2d p = queue_.front();
    queue_.pop_front();
    return p;
  }
  int laps() const { return laps_; }
  int rooms_visited() const { return rooms_visited_; }

 private:
  // The corridor from the current corner to the next, with the rooms entered on the way.
  void Leg() {
    if (leg_ % 4 == 0) ++laps_;
    const int from = anticlockwise_ ? leg_ % 4 : (4 - leg_ % 4) % 4;
    const int to = anticlockwise_ ? (from + 1) % 4 : (from + 3) % 4;
    ++leg_;
    const Eigen::Vector2d a = kCorners[from], b = kCorners[to];
    const Eigen::Vector2d along = (b - a).normalized();
    const double length = (b - a).norm();
    // The doors on this leg, in the order they are passed.
    std::vector<std::pair<double, const Room*>> doors;
    for (const Room& r : rooms_) {
      const Eigen::Vector2d corridor = r.door - r.inward;
      const double s = (corridor - a).dot(along);
      if ((corridor - (a + s * along)).norm() < 1e-9 && s > 0.5 && s < length - 0.5) doors.push_back({s, &r});
    }
    std::sort(doors.begin(), doors.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
    for (const auto& [s, room] : doors) {
      if (!random_.Chance(kTakeDoor)) continue;
      const Room& r = *room;
      const Eigen::Vector2d corridor = r.door - r.inward, inside = r.door + r.inward;
      const Eigen::Vector2d centre((r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2);
      const Eigen::Vector2d visit(random_.Uniform(r.x0 + 1.5, r.x1 - 1.5), random_.Uniform(r.y0 + 1.5, r.y1 - 1.5));
      for (const Eigen::Vector2d& p : {corridor, r.door, inside, centre, visit, centre, inside, r.door, corridor}) {
        queue_.push_back(p);
      }
      ++rooms_visited_;
    }
    queue_.push_back(b);
  }

  RandomStream random_;
  std::vector<Room> rooms_;
  std::deque<Eigen::Vector2d> queue_;
  bool anticlockwise_ = true;
  int leg_ = 0, laps_ = 0, rooms_visited_ = 0;
};

}  // namespace

bool LidarSimOptions::IsValid(std::string* why) const {
  const auto positive = [](double v) { return v > 0 && std::isfinite(v); };
  const auto noise = [](double v) { return v >= 0 && std::isfinite(v); };
  if (scans < 2 || scans > kMaxScans) return Fail(why, "scans must be in [2, 10000000]");
  if (beams < 2 || beams > kMaxBeams) return Fail(why, "beams must be in [2, 1048576]");
  if (!positive(rate)) return Fail(why, "rate must be positive (scans per second)");
  if (!positive(step) || !positive(max_turn)) return Fail(why, "step and max_turn must be positive");
  if (!positive(fov) || fov > 2 * kPi + 1e-12) return Fail(why, "fov must be in (0, 2 pi] radians");
  if (!positive(max_range)) return Fail(why, "max_range must be positive");
  if (!noise(range_noise) || !noise(translation_noise) || !noise(rotation_noise) || !noise(rotation_per_metre)) {
    return Fail(why, "noise standard deviations must be finite and not negative");
  }
  if (!std::isfinite(start_time)) return Fail(why, "start_time must be finite");
  if (world == LidarWorld::kMaze && !maze.IsValid(why)) return false;
  return true;
}

std::vector<WallSegment> OfficeWorld(std::uint64_t seed) {
  std::vector<WallSegment> w;
  Box(0, 0, 40, 30, &w);  // the building
  // The corridor's outer walls, with the doors of the rooms around it.
  Wall(true, 6, 0, 40, {8, 14, 23, 31}, &w);
  Wall(true, 24, 0, 40, {9, 16, 25, 32}, &w);
  Wall(false, 6, 6, 24, {10, 20}, &w);
  Wall(false, 34, 6, 24, {12}, &w);
  // The block inside the loop: two rooms.
  Wall(true, 8, 8, 32, {13}, &w);
  Wall(true, 22, 8, 32, {26}, &w);
  Wall(false, 8, 8, 22, {}, &w);
  Wall(false, 32, 8, 22, {}, &w);
  Wall(false, 19, 8, 22, {}, &w);
  // The walls between rooms.
  for (double x : {9.0, 19.0, 27.0}) Wall(false, x, 0, 6, {}, &w);
  for (double x : {12.0, 20.0, 30.0}) Wall(false, x, 24, 30, {}, &w);
  Wall(true, 15, 0, 6, {}, &w);
  // One or two boxes in each room's corners away from its door.
  RandomStream random(seed, kBoxStream);
  for (const Room& r : Rooms()) {
    std::vector<Eigen::Vector2d> corners;
    for (const Eigen::Vector2d& c : {Eigen::Vector2d(r.x0, r.y0), Eigen::Vector2d(r.x1, r.y0),
                                     Eigen::Vector2d(r.x1, r.y1), Eigen::Vector2d(r.x0, r.y1)}) {
      if ((c - r.door).norm() > 2.5) corners.push_back(c);
    }
    const int boxes = random.Chance(0.5) ? 2 : 1;
    for (int k = 0; k < boxes && !corners.empty(); ++k) {
      const std::size_t i = std::min(corners.size() - 1, static_cast<std::size_t>(random.Uniform() * corners.size()));
      const Eigen::Vector2d c = corners[i];
      corners.erase(corners.begin() + static_cast<long>(i));
      const double sx = random.Uniform(0.4, 0.8), sy = random.Uniform(0.4, 0.8);
      const double x = c.x() == r.x0 ? r.x0 + 0.2 : r.x1 - 0.2 - sx;
      const double y = c.y() == r.y0 ? r.y0 + 0.2 : r.y1 - 0.2 - sy;
      Box(x, y, x + sx, y + sy, &w);
    }
  }
  return w;
}

namespace {

// The robot's true poses: from path.Start() towards each of path.Next() in turn, turning at
// most max_turn a scan and moving on the spot where the heading is more than 0.35 rad off
// after the turn.
template <class Waypoints>
std::vector<SE2<double>> Drive(const LidarSimOptions& o, Waypoints& path, double* distance) {
  Eigen::Vector2d position = path.Start();
  Eigen::Vector2d target = path.Next();
  if ((target - position).norm() < 1e-9) target = path.Next();
  double heading = std::atan2(target.y() - position.y(), target.x() - position.x());
  std::vector<SE2<double>> poses;
  poses.reserve(static_cast<std::size_t>(o.scans));
  poses.emplace_back(position.x(), position.y(), heading);
  while (static_cast<int>(poses.size()) < o.scans) {
    Eigen::Vector2d to = target - position;
    if (to.norm() < 0.05) {
      target = path.Next();
      continue;
    }
    const double error = WrapAngle(std::atan2(to.y(), to.x()) - heading);
    const double turn = std::clamp(error, -o.max_turn, o.max_turn);
    const double left = std::abs(error - turn);
    heading = WrapAngle(heading + turn);
    const double forward = left > 0.35 ? 0.0 : std::min(to.norm(), o.step) * std::cos(left);
    position += forward * Eigen::Vector2d(std::cos(heading), std::sin(heading));
    *distance += forward;
    poses.emplace_back(position.x(), position.y(), heading);
  }
  return poses;
}

// The scans at the true poses (ray cast on sim->walls, with range noise), the truth and the
// drifting odometry, into sim.
void Record(const LidarSimOptions& o, const std::vector<SE2<double>>& poses, SimulatedLidar* sim) {
  RandomStream range_noise(o.seed, kRangeStream), odometry_noise(o.seed, kOdometryStream);
  sim->log.path = "simulated";
  sim->log.format = LogFormat::kCarmen;
  const bool full = o.fov >= 2 * kPi - 1e-12;
  const double angle_min = full ? -kPi : -o.fov / 2;
  const double increment = full ? 2 * kPi / o.beams : o.fov / (o.beams - 1);
  SE2<double> odometry = poses[0];
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double stamp = o.start_time + static_cast<double>(k) / o.rate;
    sim->truth.push_back({stamp, poses[k]});
    if (k > 0) {
      const SE2<double> step = poses[k - 1].Inverse() * poses[k];
      const double d = step.translation().norm();
      const double nx = odometry_noise.Normal(), ny = odometry_noise.Normal(), nt = odometry_noise.Normal();
      odometry =
          odometry *
          SE2<double>(step.x() + o.translation_noise * d * nx, step.y() + o.translation_noise * d * ny,
                      step.theta() + (o.rotation_noise * std::abs(step.theta()) + o.rotation_per_metre * d) * nt);
    }
    LaserScan s;
    s.stamp = stamp;
    s.logger_stamp = stamp - o.start_time;
    s.angle_min = angle_min;
    s.angle_increment = increment;
    s.range_min = 0;
    s.range_max = o.max_range;
    s.ranges.resize(static_cast<std::size_t>(o.beams));
    for (int i = 0; i < o.beams; ++i) {
      const double a = poses[k].theta() + s.Angle(static_cast<std::size_t>(i));
      double r = CastRay(sim->walls, poses[k].translation(), Eigen::Vector2d(std::cos(a), std::sin(a)));
      const double e = range_noise.Normal();  // drawn for every beam: the stream does not depend on the walls
      r = std::isfinite(r) ? std::max(0.0, r + o.range_noise * e) : o.max_range;
      s.ranges[static_cast<std::size_t>(i)] = static_cast<float>(std::min(r, o.max_range));
    }
    if (o.odometry) {
      s.odometry = odometry;
      s.odometry_origin = OdometryOrigin::kScanLine;
      sim->log.odometry.Add(stamp, odometry);
    }
    s.source_index = static_cast<long>(k);
    sim->log.scans.push_back(std::move(s));
  }
}

}  // namespace

SimulatedLidar SimulateLidar(const LidarSimOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("lidar simulation: " + why);
  SimulatedLidar sim;
  std::vector<SE2<double>> poses;
  if (o.world == LidarWorld::kMaze) {
    const Maze maze = MakeMaze(o.seed, o.maze);
    sim.walls = maze.Walls();
    MazeTour tour(maze, o.seed);
    poses = Drive(o, tour, &sim.distance);
    sim.tours = tour.tours();
    sim.cells_visited = tour.cells_visited();
  } else {
    sim.walls = OfficeWorld(o.seed);
    Path path(o.seed);
    poses = Drive(o, path, &sim.distance);
    sim.laps = path.laps();
    sim.rooms_visited = path.rooms_visited();
  }
  Record(o, poses, &sim);
  return sim;
}

}  // namespace lidar
}  // namespace tether
