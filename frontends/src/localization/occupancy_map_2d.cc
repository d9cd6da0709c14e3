#include "tether/frontends/localization/occupancy_map_2d.h"

#include <cmath>
#include <limits>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace localization {

namespace {

// The lower envelope of the parabolas (q - v)^2 + f[v] over one line of n values, written to
// d (Felzenszwalb and Huttenlocher's one-dimensional transform). v and z are scratch space of
// n and n + 1 entries.
void Envelope1D(const float* f, int n, float* d, int* v, float* z) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  int k = 0;
  v[0] = 0;
  z[0] = -kInf;
  z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    if (f[q] == kInf) continue;
    if (f[v[k]] == kInf) {  // no parabola yet: this one is the first
      v[0] = q;
      k = 0;
      z[1] = kInf;
      continue;
    }
    float s;
    while (true) {
      const int p = v[k];
      s = ((f[q] + static_cast<float>(q) * q) - (f[p] + static_cast<float>(p) * p)) / (2.0f * (q - p));
      if (s > z[k]) break;
      --k;
      if (k < 0) break;
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -kInf : s;
    z[k + 1] = kInf;
  }
  if (f[v[0]] == kInf) {
    for (int q = 0; q < n; ++q) d[q] = kInf;
    return;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < static_cast<float>(q)) ++k;
    const float dq = static_cast<float>(q - v[k]);
    d[q] = dq * dq + f[v[k]];
  }
}

}  // namespace

std::vector<float> SquaredDistanceTransform(int width, int height, const std::vector<bool>& seed) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const std::size_t w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  std::vector<float> d(w * h);
  for (std::size_t k = 0; k < d.size(); ++k) d[k] = seed[k] ? 0.0f : kInf;
  const int n = std::max(width, height);
  std::vector<float> f(static_cast<std::size_t>(n)), out(static_cast<std::size_t>(n)),
      z(static_cast<std::size_t>(n) + 1);
  std::vector<int> v(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < w; ++i) {  // along each column
    for (std::size_t j = 0; j < h; ++j) f[j] = d[j * w + i];
    Envelope1D(f.data(), height, out.data(), v.data(), z.data());
    for (std::size_t j = 0; j < h; ++j) d[j * w + i] = out[j];
  }
  for (std::size_t j = 0; j < h; ++j) {  // then along each row
    Envelope1D(&d[j * w], width, out.data(), v.data(), z.data());
    std::copy(out.begin(), out.begin() + width, d.begin() + static_cast<std::ptrdiff_t>(j * w));
  }
  return d;
}

OccupancyMap2D::OccupancyMap2D(const lidar::OccupancyImage& image, double occupied_thresh, double free_thresh,
                               bool negate) {
  if (image.width < 1 || image.height < 1) throw InvalidArgument("OccupancyMap2D: an empty image");
  if (image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw InvalidArgument("OccupancyMap2D: " + std::to_string(image.pixels.size()) + " pixels for a " +
                          std::to_string(image.width) + " x " + std::to_string(image.height) + " image");
  }
  if (!(image.resolution > 0) || !std::isfinite(image.resolution) || !image.origin.allFinite()) {
    throw InvalidArgument("OccupancyMap2D: resolution " + FormatDouble(image.resolution) +
                          " (it must be positive and finite) or an origin that is not finite");
  }
  geometry_.width = image.width;
  geometry_.height = image.height;
  geometry_.resolution = image.resolution;
  geometry_.inverse_resolution = 1.0 / image.resolution;
  geometry_.origin = image.origin;
  const std::size_t cells = image.pixels.size();
  state_.resize(cells);
  std::vector<bool> occupied(cells, false);
  for (int j = 0; j < image.height; ++j) {
    for (int i = 0; i < image.width; ++i) {
      const double v = image.Pixel(i, image.height - 1 - j);
      const double p = negate ? v / 255.0 : (255.0 - v) / 255.0;
      const std::size_t k = Index(i, j);
      state_[k] =
          p > occupied_thresh ? CellState::kOccupied : (p < free_thresh ? CellState::kFree : CellState::kUnknown);
      if (state_[k] == CellState::kOccupied) {
        occupied[k] = true;
        ++occupied_count_;
      } else if (state_[k] == CellState::kFree) {
        free_cells_.push_back(static_cast<std::uint32_t>(k));
      }
    }
  }
  distance_ = SquaredDistanceTransform(image.width, image.height, occupied);
  for (float& d : distance_) d = std::sqrt(d) * static_cast<float>(image.resolution);
}

OccupancyMap2D OccupancyMap2D::Read(const std::string& yaml_path) {
  const lidar::MapFile file = lidar::ReadMapYaml(yaml_path);
  return OccupancyMap2D(file.image, file.occupied_thresh, file.free_thresh, file.negate);
}

Costmap2D::Costmap2D(const OccupancyMap2D& map, double robot_radius)
    : geometry_(map.geometry()), robot_radius_(robot_radius) {
  if (!(robot_radius >= 0) || !std::isfinite(robot_radius)) {
    throw InvalidArgument("Costmap2D: robot radius " + FormatDouble(robot_radius) + " (it must be 0 or more, finite)");
  }
  valid_.assign(map.distances().size(), false);
  for (const std::uint32_t k : map.free_cells()) {
    // A cell's centre at least the radius from an occupied cell's centre, with half a cell
    // for the occupied cell's own extent.
    if (map.distances()[k] >= robot_radius + 0.5 * map.resolution()) {
      valid_[k] = true;
      valid_cells_.push_back(k);
    }
  }
}

bool Costmap2D::PathValid(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
  const double length = (b - a).norm();
  const int steps = static_cast<int>(std::ceil(length / (0.5 * geometry_.resolution)));
  for (int s = 0; s <= steps; ++s) {
    const double t = steps == 0 ? 0.0 : static_cast<double>(s) / steps;
    if (!Valid(a + t * (b - a))) return false;
  }
  return true;
}

}  // namespace localization
}  // namespace tether
