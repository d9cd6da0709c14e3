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
  // Along the columns the nearest seed of binary input is a distance in cells: two sweeps over
  // the rows (row after row, so memory is read in order), down and up.
  std::vector<float> d(w * h);
  for (std::size_t i = 0; i < w; ++i) d[i] = seed[i] ? 0.0f : kInf;
  for (std::size_t j = 1; j < h; ++j) {
    for (std::size_t i = 0; i < w; ++i) d[j * w + i] = seed[j * w + i] ? 0.0f : d[(j - 1) * w + i] + 1.0f;
  }
  for (std::size_t j = h - 1; j-- > 0;) {
    for (std::size_t i = 0; i < w; ++i) d[j * w + i] = std::min(d[j * w + i], d[(j + 1) * w + i] + 1.0f);
  }
  for (float& v : d) v = v * v;
  // Then along each row: the lower envelope of the parabolas.
  std::vector<float> out(w), z(w + 1);
  std::vector<int> v(w);
  for (std::size_t j = 0; j < h; ++j) {
    Envelope1D(&d[j * w], width, out.data(), v.data(), z.data());
    std::copy(out.begin(), out.end(), d.begin() + static_cast<std::ptrdiff_t>(j * w));
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
  squared_cells_.resize(distance_.size());
  for (std::size_t k = 0; k < distance_.size(); ++k) {
    const float d2 = distance_[k];
    squared_cells_[k] = d2 < 4e9f ? static_cast<std::uint32_t>(d2) : std::numeric_limits<std::uint32_t>::max();
    distance_[k] = std::sqrt(d2) * static_cast<float>(image.resolution);
  }
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
