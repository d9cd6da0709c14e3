#include "tether/frontends/ekf/landmark_simulator.h"

#include <cmath>
#include <random>

#include "tether/core/error.h"

namespace tether {
namespace ekf {

namespace {

// Uniform in [0, 1) from 53 random bits, and standard normals by Box-Muller: the same numbers
// with every standard library.
class Noise {
 public:
  explicit Noise(std::uint64_t seed) : engine_(seed) {}
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = Uniform();
    while (u1 <= 0) u1 = Uniform();
    const double u2 = Uniform();
    const double r = std::sqrt(-2 * std::log(u1)), a = 2 * 3.14159265358979323846 * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0;
};

bool NonNegativeFinite(const Eigen::Vector2d& v) { return v.allFinite() && (v.array() >= 0).all(); }

}  // namespace

bool LandmarkWorldOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (steps < 1) return fail("steps must be at least 1");
  if (!(std::isfinite(dt) && dt > 0)) return fail("dt must be positive and finite");
  if (!std::isfinite(command.v) || !std::isfinite(command.w)) return fail("the command must be finite");
  if (landmarks < 0) return fail("landmarks must not be negative");
  if (!(std::isfinite(map_size) && map_size > 0)) return fail("map_size must be positive and finite");
  if (!(std::isfinite(max_range) && max_range > 0)) return fail("max_range must be positive and finite");
  if (!NonNegativeFinite(control_sigma)) return fail("control_sigma must be finite and not negative");
  if (!NonNegativeFinite(measurement_sigma)) return fail("measurement_sigma must be finite and not negative");
  return true;
}

LandmarkWorld SimulateLandmarkWorld(const LandmarkWorldOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("landmark world: " + why);
  Noise noise(o.seed);
  LandmarkWorld w;
  w.dt = o.dt;
  // The circle's centre: to the left of the start, at the turning radius (straight ahead where
  // the command does not turn).
  const Eigen::Vector2d centre = o.command.w != 0 ? Eigen::Vector2d(0, o.command.v / o.command.w)
                                                  : Eigen::Vector2d(o.command.v * o.dt * o.steps / 2, 0);
  for (int i = 0; i < o.landmarks; ++i) {
    const double x = (noise.Uniform() - 0.5) * o.map_size, y = (noise.Uniform() - 0.5) * o.map_size;
    w.landmarks.push_back(centre + Eigen::Vector2d(x, y));
  }
  w.truth.push_back(SE2d());
  for (int k = 0; k < o.steps; ++k) {
    w.truth.push_back(odometry::Move(w.truth.back(), o.command, o.dt));
    const double ev = o.control_sigma.x() * noise.Normal(), ew = o.control_sigma.y() * noise.Normal();
    w.odometry.push_back(odometry::Control{o.command.v + ev, o.command.w + ew});
    std::vector<Observation> seen;
    for (std::size_t j = 0; j < w.landmarks.size(); ++j) {
      const Eigen::Vector2d d = w.landmarks[j] - w.truth.back().translation();
      if (d.norm() > o.max_range || d.norm() == 0) continue;
      const Eigen::Vector2d z = Observe(w.truth.back(), w.landmarks[j]);
      Observation ob;
      ob.range = std::max(0.1, z.x() + o.measurement_sigma.x() * noise.Normal());
      ob.bearing = WrapAngle(z.y() + o.measurement_sigma.y() * noise.Normal());
      ob.id = static_cast<int>(j);
      seen.push_back(ob);
    }
    w.observations.push_back(std::move(seen));
  }
  return w;
}

std::vector<SE2d> DeadReckoning(const LandmarkWorld& world) {
  std::vector<SE2d> out{world.truth.empty() ? SE2d() : world.truth.front()};
  for (const odometry::Control& u : world.odometry) out.push_back(odometry::Move(out.back(), u, world.dt));
  return out;
}

}  // namespace ekf
}  // namespace tether
