#pragma once
// Seeded random numbers that are the same on every platform, for simulated sensors and
// degraded logs: std::mt19937_64 (whose sequence the C++ standard fixes) with every conversion
// from its raw 64-bit draws written here (the standard distributions differ between library
// implementations). One seed gives many independent streams, told apart by a stream number.
//
//   tether::RandomStream noise(seed, /*stream=*/7);
//   const double e = sigma * noise.Normal();
#include <cmath>
#include <cstdint>
#include <random>

namespace tether {

class RandomStream {
 public:
  RandomStream(std::uint64_t seed, std::uint64_t stream) : engine_(Mix(seed ^ Mix(stream))) {}

  /// Uniform in [0, 1), 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// True with probability p.
  bool Chance(double p) { return Uniform() < p; }
  /// Standard normal by the Box-Muller transform (pairs, the second kept for the next call).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u = (static_cast<double>(engine_() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
    const double r = std::sqrt(-2.0 * std::log(u));
    const double a = 2.0 * 3.14159265358979323846 * Uniform();
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

  /// SplitMix64's finaliser: mixes a 64-bit value, to derive independent stream seeds.
  static std::uint64_t Mix(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace tether
