#pragma once
// A simulated Manhattan world with wrong loop closures appended (random pose pairs, random
// relative poses, as precise as the true closures), for the tests of the robust solves, and
// position differences between two estimates in the same gauge.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "testing/simulated.h"
#include "tether/factors/between_se2.h"

namespace tether {
namespace testing {

struct Corrupted {
  FactorGraph clean;            // the simulated world, loop closures marked
  FactorGraph graph;            // with the wrong closures appended
  std::set<std::size_t> wrong;  // their indices in graph
  Values initial;
};

inline Corrupted Corrupt(int poses, double fraction, std::uint64_t seed) {
  const SimulatedGraph sim = SimulateWorld(SimWorld::kManhattan, poses, seed);
  Corrupted c;
  c.initial = sim.initial;
  c.clean = sim.graph;
  const SqrtInformation* closure_noise = nullptr;
  int true_closures = 0;
  for (std::size_t i = 0; i < c.clean.size(); ++i) {
    Factor& f = c.clean.at(i);
    const Key a = f.keys()[0], b = f.keys().back();
    if (f.keys().size() == 2 && (a > b ? a - b : b - a) != 1) {
      f.set_loop_closure(true);
      closure_noise = &f.noise();
      ++true_closures;
    }
  }
  EXPECT_GT(true_closures, 5);
  c.graph = c.clean;
  std::mt19937_64 rng(seed * 7 + 1);
  std::uniform_int_distribution<int> pose(0, poses - 1);
  std::uniform_real_distribution<double> xy(-10, 10), angle(-M_PI, M_PI);
  const int wrong = static_cast<int>(std::lround(fraction * true_closures));
  for (int k = 0; k < wrong; ++k) {
    int a = pose(rng), b = pose(rng);
    while (std::abs(a - b) <= 1) b = pose(rng);
    c.graph.Add<BetweenSE2>(Key(a), Key(b), SE2d(xy(rng), xy(rng), angle(rng)), *closure_noise);
    c.graph.at(c.graph.size() - 1).set_loop_closure(true);
    c.wrong.insert(c.graph.size() - 1);
  }
  return c;
}

inline double MaxPositionDifference(const Values& a, const Values& b) {
  double d = 0;
  for (Key k : a.keys()) d = std::max(d, (a.At<SE2d>(k).translation() - b.At<SE2d>(k).translation()).norm());
  return d;
}

// Root mean square of the position differences (the same gauge: no alignment needed).
inline double RmsPositionDifference(const Values& a, const Values& b) {
  double d = 0;
  for (Key k : a.keys()) d += (a.At<SE2d>(k).translation() - b.At<SE2d>(k).translation()).squaredNorm();
  return std::sqrt(d / static_cast<double>(a.size()));
}

// Root mean square of the position differences with every pose taken relative to pose 0 of
// its own estimate: free of the gauge, which solves from different starts can leave apart.
inline double RmsFromFirstPose(const Values& a, const Values& b) {
  const SE2d a0 = a.At<SE2d>(0), b0 = b.At<SE2d>(0);
  double d = 0;
  for (Key k : a.keys()) {
    const Eigen::Vector2d pa = (a0.Inverse() * a.At<SE2d>(k)).translation();
    const Eigen::Vector2d pb = (b0.Inverse() * b.At<SE2d>(k)).translation();
    d += (pa - pb).squaredNorm();
  }
  return std::sqrt(d / static_cast<double>(a.size()));
}

}  // namespace testing
}  // namespace tether
