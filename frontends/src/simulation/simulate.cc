#include "tether/frontends/simulation/simulate.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/sqrt_information.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"

namespace tether {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxPoses = 100000000;
constexpr int kMaxLandmarks = 10000000;
/// Manhattan world: probability that a step turns (left and right equally likely).
constexpr double kManhattanTurnProbability = 0.3;

template <typename T>
std::string Str(const T& v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

/// Mixes a 64-bit value (SplitMix64's finaliser), to derive independent stream seeds.
std::uint64_t Mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Random numbers that are the same on every platform: std::mt19937_64's sequence is fixed by
/// the standard, and every conversion from its raw 64-bit draws is written here.
class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream) : engine_(Mix(seed ^ Mix(stream))) {}

  /// Uniform in [0, 1), 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// Uniform in (0, 1].
  double UniformPositive() { return (static_cast<double>(engine_() >> 11) + 1.0) * 0x1.0p-53; }
  /// Uniform integer in [0, n), n > 0, without modulo bias.
  std::uint64_t Below(std::uint64_t n) {
    const std::uint64_t threshold = (std::uint64_t{0} - n) % n;  // 2^64 mod n
    for (;;) {
      const std::uint64_t x = engine_();
      if (x >= threshold) return x % n;
    }
  }
  /// True with probability p.
  bool Chance(double p) { return Uniform() < p; }
  /// Standard normal by the Box-Muller transform (pairs, the second kept for the next call).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double r = std::sqrt(-2.0 * std::log(UniformPositive()));
    const double a = 2.0 * kPi * Uniform();
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// Everything the world simulations share: options, random streams, noise models, output.
class Simulation {
 public:
  explicit Simulation(const SimulateOptions& o) : o_(o), world_(o.seed, 1), noise_(o.seed, 2) {
    // (1 / sigma)^2 rather than 1 / sigma^2: for the default sigmas it is 400 and 10000 exactly,
    // so the files say 400 where 1 / sigma^2 would write 399.99999999999994.
    const double rt = 1.0 / o.translation_sigma, rr = 1.0 / o.rotation_sigma;
    const double it = rt * rt, ir = rr * rr;
    se2_info_ = SqrtInformation::FromInformation(Eigen::Vector3d(it, it, ir).asDiagonal().toDenseMatrix());
    Eigen::Matrix<double, 6, 1> d;
    d << it, it, it, 4.0 * ir, 4.0 * ir, 4.0 * ir;  // quaternion vector part ~ rotation vector / 2
    se3_info_ = SqrtInformation::FromInformation(d.asDiagonal().toDenseMatrix());
    point2_info_ = SqrtInformation::FromInformation(Eigen::Vector2d(it, it).asDiagonal().toDenseMatrix());
  }

  SimulatedGraph Run() {
    switch (o_.world) {
      case SimWorld::kManhattan:
        Manhattan();
        break;
      case SimWorld::kSphere:
        Sphere();
        break;
      case SimWorld::kLandmarks:
        Landmarks();
        break;
    }
    return std::move(out_);
  }

 private:
  // ---- noisy measurements (each draw its own statement: argument order is unspecified) ----
  SE2d NoisyBetween(const SE2d& a, const SE2d& b) {
    const double nx = o_.translation_sigma * noise_.Normal();
    const double ny = o_.translation_sigma * noise_.Normal();
    const double nt = o_.rotation_sigma * noise_.Normal();
    return (a.Inverse() * b) * SE2d(nx, ny, nt);
  }
  SE3d NoisyBetween(const SE3d& a, const SE3d& b) {
    Eigen::Vector3d t, w;
    for (int i = 0; i < 3; ++i) t[i] = o_.translation_sigma * noise_.Normal();
    for (int i = 0; i < 3; ++i) w[i] = o_.rotation_sigma * noise_.Normal();
    return (a.Inverse() * b) * SE3d(SO3d::Exp(w), t);
  }
  Eigen::Vector2d NoisyObservation(const SE2d& pose, const Eigen::Vector2d& landmark) {
    const Eigen::Vector2d truth = pose.rotation().Inverse() * (landmark - pose.translation());
    const double nx = o_.translation_sigma * noise_.Normal();
    const double ny = o_.translation_sigma * noise_.Normal();
    return truth + Eigen::Vector2d(nx, ny);
  }

  // ---- factors ----
  /// Odometry i-1 -> i; also gives pose i its initial value.
  template <typename Pose>
  void AddOdometry(const std::vector<Pose>& truth, int i, std::vector<Pose>* initial) {
    const Pose z = NoisyBetween(truth[i - 1], truth[i]);
    AddBetween(i - 1, i, z);
    (*initial)[i] = (*initial)[i - 1] * z;
    ++out_.odometry_factors;
  }
  template <typename Pose>
  void AddLoopClosure(const std::vector<Pose>& truth, int j, int i) {
    AddBetween(j, i, NoisyBetween(truth[j], truth[i]));
    ++out_.loop_closures;
  }
  void AddBetween(int i, int j, const SE2d& z) {
    out_.graph.Add(std::make_unique<BetweenSE2>(Key(i), Key(j), z, se2_info_));
  }
  void AddBetween(int i, int j, const SE3d& z) {
    out_.graph.Add(std::make_unique<BetweenSE3>(Key(i), Key(j), z, se3_info_));
  }

  template <typename Pose>
  void InsertPoses(const std::vector<Pose>& truth, const std::vector<Pose>& initial) {
    for (std::size_t i = 0; i < truth.size(); ++i) out_.ground_truth.Insert(Key(i), truth[i]);
    for (std::size_t i = 0; i < initial.size(); ++i) out_.initial.Insert(Key(i), initial[i]);
  }

  static std::int64_t CellId(std::int64_t cx, std::int64_t cy) { return cx * 4294967311LL + cy; }

  // ---- worlds ----
  void Manhattan() {
    const int n = o_.poses;
    const int half = std::max(1, static_cast<int>(std::ceil(0.5 * std::sqrt(static_cast<double>(n)))));
    static constexpr int kDx[4] = {1, 0, -1, 0};
    static constexpr int kDy[4] = {0, 1, 0, -1};
    std::vector<int> xs(n), ys(n);
    std::vector<SE2d> truth(n);
    int x = 0, y = 0, h = 0;
    for (int i = 0; i < n; ++i) {
      if (i > 0) {
        auto inside = [&](int heading) {
          return std::abs(x + kDx[heading]) <= half && std::abs(y + kDy[heading]) <= half;
        };
        const double u = world_.Uniform();
        int turn = u < 0.5 * kManhattanTurnProbability ? 1 : (u < kManhattanTurnProbability ? 3 : 0);
        if (!inside((h + turn) % 4)) {
          // Blocked by the edge of the square: straight on, a random side, the other, back.
          const int side = world_.Below(2) == 0 ? 1 : 3;
          for (int t : {0, side, 4 - side, 2}) {
            turn = t;
            if (inside((h + t) % 4)) break;
          }
        }
        h = (h + turn) % 4;
        x += kDx[h];
        y += kDy[h];
      }
      xs[i] = x;
      ys[i] = y;
      truth[i] = SE2d(x, y, h * 0.5 * kPi);
    }

    std::vector<SE2d> initial(n);
    initial[0] = truth[0];
    std::unordered_map<std::int64_t, std::vector<int>> cells;  // grid cell -> poses in it
    std::vector<int> candidates;
    for (int i = 0; i < n; ++i) {
      if (i > 0) AddOdometry(truth, i, &initial);
      // Earlier poses within one metre: this cell and its four neighbours.
      candidates.clear();
      static constexpr int kNx[5] = {0, 1, -1, 0, 0};
      static constexpr int kNy[5] = {0, 0, 0, 1, -1};
      for (int c = 0; c < 5; ++c) {
        auto it = cells.find(CellId(xs[i] + kNx[c], ys[i] + kNy[c]));
        if (it == cells.end()) continue;
        for (int j : it->second)
          if (j < i - 1) candidates.push_back(j);
      }
      std::sort(candidates.begin(), candidates.end());
      for (int j : candidates)
        if (world_.Chance(o_.loop_closure_probability)) AddLoopClosure(truth, j, i);
      cells[CellId(xs[i], ys[i])].push_back(i);
    }
    InsertPoses(truth, initial);
  }

  void Sphere() {
    const int n = o_.poses;
    const int per_ring = std::max(3, static_cast<int>(std::lround(std::sqrt(static_cast<double>(n)))));
    const double radius = per_ring / (2.0 * kPi);  // one metre steps along the equator
    const double lat0 = -0.45 * kPi, lat1 = 0.45 * kPi;
    const double dlat = n > 1 ? (lat1 - lat0) / (n - 1) : 0.0;
    const double dlon = 2.0 * kPi / per_ring;
    std::vector<SE3d> truth(n);
    for (int i = 0; i < n; ++i) {
      const double lat = lat0 + dlat * i, lon = dlon * (i % per_ring);
      const double cla = std::cos(lat), sla = std::sin(lat), clo = std::cos(lon), slo = std::sin(lon);
      const Eigen::Vector3d up(cla * clo, cla * slo, sla);
      const Eigen::Vector3d east(-slo, clo, 0.0);
      const Eigen::Vector3d north(-sla * clo, -sla * slo, cla);
      const Eigen::Vector3d forward = ((radius * cla * dlon) * east + (radius * dlat) * north).normalized();
      Eigen::Matrix3d r;
      r.col(0) = forward;
      r.col(1) = up.cross(forward);
      r.col(2) = up;
      truth[i] = SE3d(Eigen::Quaterniond(r), radius * up);
    }

    std::vector<SE3d> initial(n);
    initial[0] = truth[0];
    for (int i = 0; i < n; ++i) {
      if (i > 0) AddOdometry(truth, i, &initial);
      // The poses of the previous ring nearest in longitude.
      for (int d = -1; d <= 1; ++d) {
        const int j = i - per_ring + d;
        if (j >= 0 && j < i - 1 && world_.Chance(o_.loop_closure_probability)) AddLoopClosure(truth, j, i);
      }
    }
    InsertPoses(truth, initial);
  }

  void Landmarks() {
    const int n = o_.poses;
    const int k = std::clamp(n / 18, 1, 15);
    const int w = 2 * k, h = k, perimeter = 2 * (w + h);
    std::vector<SE2d> truth(n);
    for (int i = 0; i < n; ++i) {
      const int s = i % perimeter;
      if (s < w) {
        truth[i] = SE2d(s, 0, 0.0);
      } else if (s < w + h) {
        truth[i] = SE2d(w, s - w, 0.5 * kPi);
      } else if (s < 2 * w + h) {
        truth[i] = SE2d(w - (s - w - h), h, kPi);
      } else {
        truth[i] = SE2d(0, h - (s - 2 * w - h), -0.5 * kPi);
      }
    }

    // Landmarks within 0.9 * range of a random pose, so that each is seen at least once.
    const int m = o_.landmarks;
    const double range = o_.landmark_range, r = 0.9 * range;
    std::vector<Eigen::Vector2d> points(m);
    std::unordered_map<std::int64_t, std::vector<int>> cells;  // range-sized cells -> landmarks
    auto cell_of = [range](double v) { return static_cast<std::int64_t>(std::floor(v / range)); };
    for (int l = 0; l < m; ++l) {
      const SE2d& anchor = truth[world_.Below(static_cast<std::uint64_t>(n))];
      double dx, dy;
      do {
        dx = (2.0 * world_.Uniform() - 1.0) * r;
        dy = (2.0 * world_.Uniform() - 1.0) * r;
      } while (dx * dx + dy * dy > r * r);
      points[l] = anchor.translation() + Eigen::Vector2d(dx, dy);
      cells[CellId(cell_of(points[l].x()), cell_of(points[l].y()))].push_back(l);
    }

    std::vector<SE2d> initial(n);
    initial[0] = truth[0];
    std::vector<Eigen::Vector2d> landmark_initial(m);
    std::vector<bool> seen(m, false);
    std::vector<int> visible;
    for (int i = 0; i < n; ++i) {
      if (i > 0) AddOdometry(truth, i, &initial);
      visible.clear();
      const Eigen::Vector2d p = truth[i].translation();
      const std::int64_t cx = cell_of(p.x()), cy = cell_of(p.y());
      for (std::int64_t ix = cx - 1; ix <= cx + 1; ++ix) {
        for (std::int64_t iy = cy - 1; iy <= cy + 1; ++iy) {
          auto it = cells.find(CellId(ix, iy));
          if (it == cells.end()) continue;
          for (int l : it->second)
            if ((points[l] - p).squaredNorm() <= range * range) visible.push_back(l);
        }
      }
      std::sort(visible.begin(), visible.end());
      for (int l : visible) {
        const Eigen::Vector2d z = NoisyObservation(truth[i], points[l]);
        out_.graph.Add(std::make_unique<PosePoint2>(Key(i), Key(n) + Key(l), z, point2_info_));
        ++out_.observations;
        if (!seen[l]) {
          landmark_initial[l] = initial[i] * z;
          seen[l] = true;
        }
      }
    }
    InsertPoses(truth, initial);
    for (int l = 0; l < m; ++l) {
      out_.ground_truth.Insert(Key(n) + Key(l), points[l]);
      // Every landmark is placed within range of a pose, so `seen` always holds; the fallback
      // only keeps the output complete should that ever change.
      out_.initial.Insert(Key(n) + Key(l), seen[l] ? landmark_initial[l] : points[l]);
    }
  }

  const SimulateOptions& o_;
  Rng world_;  // trajectory, landmark positions, loop-closure choices
  Rng noise_;  // measurement noise
  SqrtInformation se2_info_, se3_info_, point2_info_;
  SimulatedGraph out_;
};

}  // namespace

bool SimulateOptions::IsValid(std::string* why) const {
  if (poses < 1 || poses > kMaxPoses)
    return Fail(why, "SimulateOptions.poses must be between 1 and " + Str(kMaxPoses) + " (got " + Str(poses) + ")");
  if (!(translation_sigma >= 1e-9 && translation_sigma <= 1e6))
    return Fail(why,
                "SimulateOptions.translation_sigma must be in [1e-9, 1e6] metres (got " + Str(translation_sigma) + ")");
  if (!(rotation_sigma >= 1e-9 && rotation_sigma <= 0.5))
    return Fail(why, "SimulateOptions.rotation_sigma must be in [1e-9, 0.5] radians (got " + Str(rotation_sigma) +
                         "): larger noise makes angle errors far from Gaussian");
  if (!(loop_closure_probability >= 0.0 && loop_closure_probability <= 1.0))
    return Fail(
        why, "SimulateOptions.loop_closure_probability must be in [0, 1] (got " + Str(loop_closure_probability) + ")");
  if (world == SimWorld::kLandmarks) {
    if (landmarks < 1 || landmarks > kMaxLandmarks)
      return Fail(why, "SimulateOptions.landmarks must be between 1 and " + Str(kMaxLandmarks) +
                           " for the landmarks world (got " + Str(landmarks) + ")");
    if (!(landmark_range >= 1e-3 && landmark_range <= 1e6))
      return Fail(why,
                  "SimulateOptions.landmark_range must be in [1e-3, 1e6] metres (got " + Str(landmark_range) + ")");
  }
  if (why != nullptr) why->clear();
  return true;
}

SimulatedGraph Simulate(const SimulateOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("Simulate: " + why);
  return Simulation(options).Run();
}

}  // namespace tether
