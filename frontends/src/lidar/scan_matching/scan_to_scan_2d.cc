#include "tether/frontends/lidar/scan_matching/scan_to_scan_2d.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

bool ScanToScanOptions::IsValid(std::string* why) const {
  const auto fail = [why](const char* what) {
    if (why != nullptr) *why = what;
    return false;
  };
  if (max_iterations < 1) return fail("max_iterations must be at least 1");
  for (double v : {max_pair_distance, final_pair_distance, max_neighbour_gap, huber}) {
    if (!(std::isfinite(v) && v > 0)) {
      return fail("max_pair_distance, final_pair_distance, max_neighbour_gap and huber must be finite and positive");
    }
  }
  if (!(std::isfinite(guess_translation_weight) && guess_translation_weight >= 0 &&
        std::isfinite(guess_rotation_weight) && guess_rotation_weight >= 0)) {
    return fail("the guess weights must be finite and not negative");
  }
  if (!(std::isfinite(normal_radius) && normal_radius >= 0))
    return fail("normal_radius must be finite and not negative");
  if (!(std::isfinite(degenerate_information) && degenerate_information >= 0)) {
    return fail("degenerate_information must be finite and not negative");
  }
  if (min_pairs < 3) return fail("min_pairs must be at least 3");
  return true;
}

namespace {

// The previous scan's points with the unit normal of the line through each (none where no
// neighbour in beam order lies near enough), hashed by cells of the pair distance.
class LineTargets {
 public:
  LineTargets(const std::vector<Eigen::Vector2d>& points, double max_gap, double radius, double cell)
      : points_(points), normals_(points.size(), Eigen::Vector2d::Zero()), cell_(cell) {
    const std::size_t n = points.size();
    for (std::size_t i = 0; i < n; ++i) {
      // The run of neighbours in beam order around i, each step within max_gap, within radius
      // of point i (at least the next one each way).
      std::size_t lo = i, hi = i;
      while (lo > 0 && (points[lo - 1] - points[lo]).norm() <= max_gap &&
             (lo == i || (points[lo - 1] - points[i]).norm() <= radius)) {
        --lo;
      }
      while (hi + 1 < n && (points[hi + 1] - points[hi]).norm() <= max_gap &&
             (hi == i || (points[hi + 1] - points[i]).norm() <= radius)) {
        ++hi;
      }
      if (lo == hi) continue;
      Eigen::Vector2d d;
      if (hi - lo == 1 || radius == 0) {
        d = points[hi] - points[lo];
      } else {
        Eigen::Vector2d mean = Eigen::Vector2d::Zero();
        for (std::size_t k = lo; k <= hi; ++k) mean += points[k];
        mean /= static_cast<double>(hi - lo + 1);
        Eigen::Matrix2d c = Eigen::Matrix2d::Zero();
        for (std::size_t k = lo; k <= hi; ++k) c += (points[k] - mean) * (points[k] - mean).transpose();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> e(c);
        d = e.eigenvectors().col(1);
      }
      if (d.norm() < 1e-9) continue;
      normals_[i] = Eigen::Vector2d(-d.y(), d.x()).normalized();
      cells_[Key(points[i])].push_back(static_cast<int>(i));
    }
  }

  // The nearest point with a normal within `max_distance` of q; -1 where none.
  int Nearest(const Eigen::Vector2d& q, double max_distance) const {
    const std::int64_t cx = Cell(q.x()), cy = Cell(q.y());
    int best = -1;
    double best_d2 = max_distance * max_distance;
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(Pack(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (int i : it->second) {
          const double d2 = (points_[static_cast<std::size_t>(i)] - q).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best = i;
          }
        }
      }
    }
    return best;
  }
  const Eigen::Vector2d& point(int i) const { return points_[static_cast<std::size_t>(i)]; }
  const Eigen::Vector2d& normal(int i) const { return normals_[static_cast<std::size_t>(i)]; }

 private:
  // Clamped so that an absurd coordinate (a range of 1e30 m) cannot overflow the cast.
  std::int64_t Cell(double v) const {
    return static_cast<std::int64_t>(std::floor(std::max(-1e15, std::min(1e15, v / cell_))));
  }
  // Two cell indices in one key (unsigned: shifting a negative index is undefined).
  static std::uint64_t Pack(std::int64_t x, std::int64_t y) {
    return (static_cast<std::uint64_t>(x) << 32) ^ (static_cast<std::uint64_t>(y) & 0xffffffffu);
  }
  std::uint64_t Key(const Eigen::Vector2d& p) const { return Pack(Cell(p.x()), Cell(p.y())); }

  const std::vector<Eigen::Vector2d>& points_;
  std::vector<Eigen::Vector2d> normals_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

}  // namespace

Eigen::Matrix2d DegenerateTranslations(const Eigen::Matrix3d& information, double min_information) {
  Eigen::Matrix2d t = information.topLeftCorner<2, 2>();
  // The rotation marginalised out: what the pairs say about the translation whatever the turn.
  if (information(2, 2) > 0)
    t -= information.topRightCorner<2, 1>() * information.bottomLeftCorner<1, 2>() / information(2, 2);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> e(0.5 * (t + t.transpose()));
  Eigen::Matrix2d projector = Eigen::Matrix2d::Zero();
  for (int i = 0; i < 2; ++i) {
    if (!(e.eigenvalues()[i] >= min_information))
      projector += e.eigenvectors().col(i) * e.eigenvectors().col(i).transpose();
  }
  return projector;
}

ScanToScanMatch MatchScanToScan(const std::vector<Eigen::Vector2d>& previous,
                                const std::vector<Eigen::Vector2d>& current, const SE2d& guess,
                                const ScanToScanOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("ScanToScanOptions: " + why);
  ScanToScanMatch result;
  result.motion = guess;
  if (!guess.translation().allFinite() || !std::isfinite(guess.theta())) return result;
  const LineTargets targets(previous, options.max_neighbour_gap, options.normal_radius, options.max_pair_distance);
  SE2d t = guess;
  for (int it = 0; it < options.max_iterations; ++it) {
    const double reach = it < options.max_iterations / 2 ? options.max_pair_distance : options.final_pair_distance;
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    int pairs = 0;
    double squared = 0;
    const double c = std::cos(t.theta()), s = std::sin(t.theta());
    for (const Eigen::Vector2d& q : current) {
      const Eigen::Vector2d moved = t * q;
      const int k = targets.Nearest(moved, reach);
      if (k < 0) continue;
      const Eigen::Vector2d& n = targets.normal(k);
      const double r = n.dot(moved - targets.point(k));
      // d(moved)/d(theta) = dR/dtheta * q.
      const Eigen::Vector2d dtheta(-s * q.x() - c * q.y(), c * q.x() - s * q.y());
      const Eigen::Vector3d j(n.x(), n.y(), n.dot(dtheta));
      const double w = std::abs(r) <= options.huber ? 1.0 : options.huber / std::abs(r);
      h += w * j * j.transpose();
      g += w * j * r;
      squared += r * r;
      ++pairs;
    }
    result.pairs = pairs;
    result.iterations = it + 1;
    if (pairs < options.min_pairs) return result;
    result.rms = std::sqrt(squared / pairs);
    result.information = h;
    // The pull towards the guess (in the parameters x, y, theta).
    const Eigen::Vector3d prior(options.guess_translation_weight, options.guess_translation_weight,
                                options.guess_rotation_weight);
    const Eigen::Vector3d off(t.x() - guess.x(), t.y() - guess.y(), WrapAngle(t.theta() - guess.theta()));
    for (int a = 0; a < 3; ++a) {
      h(a, a) += prior[a] * prior[a];
      g[a] += prior[a] * prior[a] * off[a];
    }
    // Translations the pairs do not see keep the guess's: a stiff pull along them.
    if (options.degenerate_information > 0) {
      result.degenerate = DegenerateTranslations(result.information, options.degenerate_information);
      constexpr double kStiff = 1e6;
      h.topLeftCorner<2, 2>() += kStiff * result.degenerate;
      g.head<2>() += kStiff * result.degenerate * off.head<2>();
    }
    const Eigen::Vector3d step = -h.ldlt().solve(g);
    if (!step.allFinite()) return result;
    t = SE2d(t.x() + step[0], t.y() + step[1], t.theta() + step[2]);
    if (step.head<2>().norm() < 1e-5 && std::abs(step[2]) < 1e-6 && reach == options.final_pair_distance) break;
  }
  result.ok = true;
  result.motion = t;
  return result;
}

ScanToScanMatch MatchMovingOrStill(const std::vector<Eigen::Vector2d>& previous,
                                   const std::vector<Eigen::Vector2d>& current, const SE2d& moving, double turn,
                                   const ScanToScanOptions& options) {
  const ScanToScanMatch from_moving = MatchScanToScan(previous, current, moving, options);
  const ScanToScanMatch still = MatchScanToScan(previous, current, SE2d(0, 0, turn), options);
  const bool take_still = still.ok && (!from_moving.ok || still.pairs * 10 > from_moving.pairs * 11);
  return take_still ? still : from_moving;
}

}  // namespace lidar
}  // namespace tether
