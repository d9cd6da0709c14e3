#pragma once
// Shared test helper: a simulated world with the simulator's default noise.
#include <cstdint>

#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace testing {

inline SimulatedGraph SimulateWorld(SimWorld world, int poses, std::uint64_t seed, int landmarks = 100) {
  SimulateOptions o;
  o.world = world;
  o.poses = poses;
  o.seed = seed;
  o.landmarks = landmarks;
  return Simulate(o);
}

}  // namespace testing
}  // namespace tether
