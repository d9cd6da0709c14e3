#include "tether/frontends/localization/measurement_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace localization {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool Positive(double v) { return v > 0 && std::isfinite(v); }
bool Weight(double v) { return v >= 0 && v <= 1; }

double Combine(BeamCombination c, double log_sum, double cube_sum) {
  return c == BeamCombination::kProduct ? log_sum : std::log1p(cube_sum);
}

}  // namespace

ScanBeams SelectBeams(const lidar::LaserScan& scan, int max_beams, bool with_no_returns, double range_cap) {
  ScanBeams beams;
  beams.range_max = range_cap > 0 ? std::min(scan.range_max, range_cap) : scan.range_max;
  beams.laser = scan.laser_in_robot.translation();
  std::vector<std::size_t> usable;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    if (scan.Valid(i) || with_no_returns) usable.push_back(i);
  }
  const std::size_t n = max_beams <= 0 ? usable.size() : std::min(usable.size(), static_cast<std::size_t>(max_beams));
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = usable[k * usable.size() / n];
    const bool hit = scan.Valid(i) && scan.ranges[i] < beams.range_max;
    beams.angles.push_back(scan.laser_in_robot.theta() + scan.Angle(i));
    beams.ranges.push_back(hit ? static_cast<double>(scan.ranges[i]) : beams.range_max);
    beams.hit.push_back(hit);
  }
  return beams;
}

bool LikelihoodFieldOptions::IsValid(std::string* why) const {
  std::string w;
  if (!Positive(sigma_hit)) w = "the likelihood field's sigma_hit must be positive";
  if (!Weight(z_hit) || !Weight(z_rand) || !(z_hit + z_rand > 0)) {
    w = "z_hit and z_rand must lie in [0, 1], not both 0";
  }
  if (!Positive(max_distance)) w = "the likelihood field's max_distance must be positive";
  if (why && !w.empty()) *why = w;
  return w.empty();
}

LikelihoodField::LikelihoodField(const OccupancyMap2D& map, const LikelihoodFieldOptions& options, double range_max)
    : geometry_(map.geometry()), options_(options), range_max_(range_max) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("LikelihoodField: " + why);
  if (!Positive(range_max)) throw InvalidArgument("LikelihoodField: range_max must be positive");
  // Squared distances in whole cells take few values below max_distance: each one scored once.
  const double cells_max = options.max_distance / map.resolution();
  const std::uint32_t limit = static_cast<std::uint32_t>(std::min(cells_max * cells_max + 1, 4194304.0));
  std::vector<Cell> table(static_cast<std::size_t>(limit) + 1);
  for (std::uint32_t q = 0; q <= limit; ++q) {
    const double d = std::sqrt(static_cast<double>(q)) * map.resolution();
    table[q] = {static_cast<float>(BeamScore(d)), static_cast<float>(BeamProbability(d))};
  }
  const std::vector<std::uint32_t>& squared = map.squared_cell_distances();
  cells_.resize(squared.size());
  for (std::size_t k = 0; k < cells_.size(); ++k) {
    // Beyond the table (a grid far finer than max_distance, where the table stops at 2^22
    // entries), scored directly.
    cells_[k] = squared[k] < limit ? table[squared[k]]
                                   : Cell{static_cast<float>(BeamScore(map.distances()[k])),
                                          static_cast<float>(BeamProbability(map.distances()[k]))};
  }
  outside_ = {static_cast<float>(BeamScore(options.max_distance)),
              static_cast<float>(BeamProbability(options.max_distance))};
}

double LikelihoodField::BeamProbability(double distance) const {
  const double d = std::min(distance, options_.max_distance);
  return options_.z_hit * std::exp(-d * d / (2 * options_.sigma_hit * options_.sigma_hit)) +
         options_.z_rand / range_max_;
}

double LikelihoodField::BeamScore(double distance) const {
  const double p = BeamProbability(distance);
  return options_.combination == BeamCombination::kProduct ? std::log(p) : p * p * p;
}

double LikelihoodField::LogLikelihood(const SE2d& pose, const ScanBeams& beams) const {
  const double p[3] = {pose.x(), pose.y(), pose.theta()};
  double out = 0;
  LogLikelihoods(p, 1, beams, &out);
  return out;
}

void LikelihoodField::LogLikelihoods(const double* poses, std::size_t count, const ScanBeams& beams, double* out,
                                     double* mean_probability) const {
  // The end points in the robot's frame, in cells.
  const std::size_t n = beams.angles.size();
  std::vector<float> ex, ey;
  ex.reserve(n);
  ey.reserve(n);
  const double s = geometry_.inverse_resolution;
  for (std::size_t b = 0; b < n; ++b) {
    if (!beams.hit[b]) continue;
    ex.push_back(static_cast<float>((beams.laser.x() + beams.ranges[b] * std::cos(beams.angles[b])) * s));
    ey.push_back(static_cast<float>((beams.laser.y() + beams.ranges[b] * std::sin(beams.angles[b])) * s));
  }
  const std::size_t m = ex.size();
  const Cell* cells = cells_.data();
  const std::size_t w = static_cast<std::size_t>(geometry_.width);
  const float fw = static_cast<float>(geometry_.width), fh = static_cast<float>(geometry_.height);
  for (std::size_t k = 0; k < count; ++k) {
    const double* pose = poses + 3 * k;
    const float cx = static_cast<float>((pose[0] - geometry_.origin.x()) * s);
    const float cy = static_cast<float>((pose[1] - geometry_.origin.y()) * s);
    const float c = static_cast<float>(std::cos(pose[2])), sn = static_cast<float>(std::sin(pose[2]));
    float sum = 0, p = 0;
    for (std::size_t b = 0; b < m; ++b) {
      const float fx = cx + c * ex[b] - sn * ey[b];
      const float fy = cy + sn * ex[b] + c * ey[b];
      // Inside the map the coordinates are not negative, so truncation is the floor.
      const bool inside = fx >= 0 && fy >= 0 && fx < fw && fy < fh;
      const Cell& cell = inside ? cells[static_cast<std::size_t>(fy) * w + static_cast<std::size_t>(fx)] : outside_;
      sum += cell.score;
      p += cell.p;
    }
    if (mean_probability) mean_probability[k] = m > 0 ? static_cast<double>(p) / static_cast<double>(m) : 0.0;
    out[k] = options_.combination == BeamCombination::kProduct ? static_cast<double>(sum)
                                                               : Combine(options_.combination, 0, sum);
  }
}

bool BeamModelOptions::IsValid(std::string* why) const {
  std::string w;
  if (!Weight(z_hit) || !Weight(z_short) || !Weight(z_max) || !Weight(z_rand) ||
      !(z_hit + z_short + z_max + z_rand > 0)) {
    w = "the beam model's z_hit, z_short, z_max and z_rand must lie in [0, 1], not all 0";
  }
  if (!Positive(sigma_hit)) w = "the beam model's sigma_hit must be positive";
  if (!Positive(lambda_short)) w = "the beam model's lambda_short must be positive";
  if (why && !w.empty()) *why = w;
  return w.empty();
}

BeamModel::BeamModel(const OccupancyMap2D& map, const BeamModelOptions& options) : map_(&map), options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("BeamModel: " + why);
}

double BeamModel::CastRay(const Eigen::Vector2d& origin, double angle, double range_max) const {
  // Cell by cell along the ray (the crossings of cell borders in x and in y, whichever is next).
  const GridGeometry& g = map_->geometry();
  const double dx = std::cos(angle), dy = std::sin(angle);
  const double fx = (origin.x() - g.origin.x()) * g.inverse_resolution;
  const double fy = (origin.y() - g.origin.y()) * g.inverse_resolution;
  int i = static_cast<int>(std::floor(fx)), j = static_cast<int>(std::floor(fy));
  const int step_i = dx > 0 ? 1 : -1, step_j = dy > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double delta_i = dx != 0 ? std::abs(1 / dx) : inf, delta_j = dy != 0 ? std::abs(1 / dy) : inf;
  double next_i = dx != 0 ? (dx > 0 ? (i + 1 - fx) : (fx - i)) * delta_i : inf;
  double next_j = dy != 0 ? (dy > 0 ? (j + 1 - fy) : (fy - j)) * delta_j : inf;
  const double limit = range_max * g.inverse_resolution;
  double t = 0;
  while (t < limit) {
    if (i < 0 || j < 0 || i >= g.width || j >= g.height) return range_max;
    if (map_->State(i, j) == CellState::kOccupied) return t * g.resolution;
    if (next_i < next_j) {
      t = next_i;
      next_i += delta_i;
      i += step_i;
    } else {
      t = next_j;
      next_j += delta_j;
      j += step_j;
    }
  }
  return range_max;
}

double BeamModel::BeamProbability(double z, double expected, double range_max) const {
  const BeamModelOptions& o = options_;
  double p = 0;
  if (z < range_max) {
    const double e = (z - expected) / o.sigma_hit;
    p += o.z_hit * std::exp(-0.5 * e * e) / (o.sigma_hit * std::sqrt(2 * kPi));
    if (z < expected) {
      p += o.z_short * o.lambda_short * std::exp(-o.lambda_short * z) / (1 - std::exp(-o.lambda_short * expected));
    }
    p += o.z_rand / range_max;
  } else {
    p += o.z_max;
  }
  return p;
}

double BeamModel::LogLikelihood(const SE2d& pose, const ScanBeams& beams, double* mean_probability) const {
  const Eigen::Vector2d laser = pose * beams.laser;
  double log_sum = 0, cube_sum = 0, sum = 0;
  for (std::size_t b = 0; b < beams.angles.size(); ++b) {
    const double expected = CastRay(laser, pose.theta() + beams.angles[b], beams.range_max);
    const double p = BeamProbability(beams.ranges[b], expected, beams.range_max);
    log_sum += std::log(p);
    cube_sum += p * p * p;
    sum += p;
  }
  if (mean_probability)
    mean_probability[0] = beams.angles.empty() ? 0.0 : sum / static_cast<double>(beams.angles.size());
  return Combine(options_.combination, log_sum, cube_sum);
}

}  // namespace localization
}  // namespace tether
