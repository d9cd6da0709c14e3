#include "tether/frontends/simulation/walls.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

namespace {

constexpr double kMaxPixels = 1e8;
constexpr std::uint8_t kOccupiedPixel = 0, kFreePixel = 254;

}  // namespace

double CastRay(const std::vector<WallSegment>& walls, const Eigen::Vector2d& origin, const Eigen::Vector2d& d) {
  double best = INFINITY;
  for (const WallSegment& s : walls) {
    // origin + t d = a + u (b - a)
    const Eigen::Vector2d e = s.b - s.a, w = s.a - origin;
    const double den = -d.x() * e.y() + d.y() * e.x();
    if (std::abs(den) < 1e-12) continue;
    const double t = (-w.x() * e.y() + w.y() * e.x()) / den;
    const double u = (d.x() * w.y() - d.y() * w.x()) / den;
    if (t > 1e-9 && u >= 0 && u <= 1) best = std::min(best, t);
  }
  return best;
}

double DistanceToWalls(const std::vector<WallSegment>& walls, const Eigen::Vector2d& p) {
  double best = INFINITY;
  for (const WallSegment& s : walls) {
    const Eigen::Vector2d e = s.b - s.a;
    const double n = e.squaredNorm();
    const double u = n > 0 ? std::clamp((p - s.a).dot(e) / n, 0.0, 1.0) : 0.0;
    best = std::min(best, (s.a + u * e - p).norm());
  }
  return best;
}

OccupancyImage RasterizeWalls(const std::vector<WallSegment>& walls, double resolution, int padding) {
  if (walls.empty()) throw InvalidArgument("RasterizeWalls: no walls");
  if (!(resolution > 0) || !std::isfinite(resolution)) {
    throw InvalidArgument("RasterizeWalls: the resolution must be positive (metres a pixel)");
  }
  if (padding < 0) throw InvalidArgument("RasterizeWalls: the padding must not be negative");
  Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
  for (const WallSegment& s : walls) {
    if (!s.a.allFinite() || !s.b.allFinite()) throw InvalidArgument("RasterizeWalls: a wall is not finite");
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
  }
  const double pixels_x = (hi.x() - lo.x()) / resolution + 2.0 * padding + 1;
  const double pixels_y = (hi.y() - lo.y()) / resolution + 2.0 * padding + 1;
  if (pixels_x * pixels_y > kMaxPixels) throw InvalidArgument("RasterizeWalls: the image would be too large");

  OccupancyImage image;
  image.resolution = resolution;
  image.origin = lo - padding * resolution * Eigen::Vector2d::Ones();
  // A point's column and row from the bottom: one formula for the size, the free box and the walls.
  const auto column = [&](double x) { return static_cast<int>(std::floor((x - image.origin.x()) / resolution)); };
  const auto up = [&](double y) { return static_cast<int>(std::floor((y - image.origin.y()) / resolution)); };
  image.width = column(hi.x()) + 1 + padding;
  image.height = up(hi.y()) + 1 + padding;
  image.pixels.assign(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height), kUnknownPixel);
  const auto set = [&](int c, int u, std::uint8_t v) {
    if (c < 0 || c >= image.width || u < 0 || u >= image.height) return;
    image.pixels[static_cast<std::size_t>(image.height - 1 - u) * static_cast<std::size_t>(image.width) +
                 static_cast<std::size_t>(c)] = v;
  };
  for (int u = std::max(0, up(lo.y())); u <= up(hi.y()); ++u) {
    for (int c = std::max(0, column(lo.x())); c <= column(hi.x()); ++c) set(c, u, kFreePixel);
  }
  for (const WallSegment& s : walls) {
    const double length = (s.b - s.a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / (resolution / 2))));
    for (int i = 0; i <= steps; ++i) {
      const Eigen::Vector2d p = s.a + (s.b - s.a) * (static_cast<double>(i) / steps);
      set(column(p.x()), up(p.y()), kOccupiedPixel);
    }
  }
  return image;
}

}  // namespace lidar
}  // namespace tether
