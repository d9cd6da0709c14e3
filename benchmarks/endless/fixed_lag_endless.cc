// An endless run for the fixed-lag smoother: a robot on a street grid (1 m steps, turns at the
// crossings, mostly to the left, so that it often drives round a block), simulated step by step with known truth, its
// odometry and the loop closures to places it passed within the last `span` poses, fed one pose per update into a
// FixedLagSmoother. Nothing of the run is kept beyond the window: the world is made as it
// goes, and the poses that leave the window are scored and dropped. Every `block` poses it
// prints the mean and largest update time of the block, the resident memory now and at its
// peak, the window's size, and the error of the estimate over 10-pose segments (translation
// of est(i-10)^-1 est(i) against the truth) for the poses that left the window, against the
// same for dead reckoning.
//
//   tether_fixed_lag_endless [--poses N] [--lag L] [--span S] [--block B] [--seed K]
//
// benchmarks/RESULTS.md, "Fixed lag", has the runs and the commands.
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/between_se2.h"
#include "tether/solvers/fixed_lag_smoother.h"

namespace {

using tether::Key;
using tether::SE2d;

double ResidentMib() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

double PeakMib() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// A noisy copy of the relative pose z.
SE2d Noisy(const SE2d& z, const Eigen::Vector3d& sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, 1);
  return z * SE2d(sigma[0] * n(rng), sigma[1] * n(rng), sigma[2] * n(rng));
}

double SegmentError(const SE2d& a, const SE2d& b, const SE2d& ta, const SE2d& tb) {
  return ((a.Inverse() * b).translation() - (ta.Inverse() * tb).translation()).norm();
}

}  // namespace

int main(int argc, char** argv) {
  long poses = 1000000, block = 100000;
  double lag = 100;
  int span = 50;
  std::uint64_t seed = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--poses")
      poses = std::atol(argv[i + 1]);
    else if (a == "--lag")
      lag = std::atof(argv[i + 1]);
    else if (a == "--span")
      span = std::atoi(argv[i + 1]);
    else if (a == "--block")
      block = std::atol(argv[i + 1]);
    else if (a == "--seed")
      seed = std::strtoull(argv[i + 1], nullptr, 10);
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (poses < 2 || block < 1 || !(lag >= 1) || span < 2 || span >= lag) {
    std::fprintf(stderr, "need --poses >= 2, --block >= 1, --lag >= 1 and 2 <= --span < --lag\n");
    return 2;
  }
  const Eigen::Vector3d odo_sigma(0.05, 0.05, 0.01), closure_sigma(0.05, 0.05, 0.01);
  const auto odo_noise = tether::SqrtInformation::FromSigmas(odo_sigma);
  const auto closure_noise = tether::SqrtInformation::FromSigmas(closure_sigma);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);

  tether::FixedLagOptions options;
  options.lag = lag;
  tether::FixedLagSmoother smoother(options);

  // The truth and dead reckoning of the last poses (enough for the closures and the scoring).
  std::unordered_map<Key, SE2d> truth, dead;
  std::deque<std::pair<Key, SE2d>> recent_estimates;  // of poses that left the window, for the segments
  SE2d heading(0, 0, 0);
  double block_seconds = 0, block_max = 0, err2 = 0, dead2 = 0;
  long scored = 0, closures = 0;
  std::printf(
      "# poses  mean_step_ms  max_step_ms  rss_mib  peak_mib  window  closures  segment_rms_m  dead_reckoning_rms_m\n");
  for (long i = 0; i < poses; ++i) {
    const Key k = static_cast<Key>(i);
    tether::FactorGraph f;
    tether::Values v;
    if (i == 0) {
      truth[k] = dead[k] = SE2d(0, 0, 0);
      v.Insert(k, SE2d(0, 0, 0));
    } else {
      // A 1 m step along the street; at a crossing (every 5 m) a left turn with probability
      // 0.5, a right one with 0.15: the robot often drives round a block (20 poses) and back
      // over its own track.
      double turn = 0;
      if (i % 5 == 0) {
        const double r = u(rng);
        turn = r < 0.5 ? M_PI / 2 : r < 0.65 ? -M_PI / 2 : 0.0;
      }
      const SE2d step(1, 0, turn);
      truth[k] = truth[k - 1] * step;
      const SE2d z = Noisy(step, odo_sigma, rng);
      dead[k] = dead[k - 1] * z;
      f.Add<tether::BetweenSE2>(k - 1, k, z, odo_noise);
      v.Insert(k, smoother.Estimate().At<SE2d>(k - 1) * z);
      // A closure to a pose passed within the last `span` (not the last 5) closer than 1.5 m.
      for (long j = i - span; j < i - 5; ++j) {
        if (j < 0) continue;
        const SE2d& tj = truth[static_cast<Key>(j)];
        if ((tj.translation() - truth[k].translation()).norm() < 1.5 && u(rng) < 0.5) {
          f.Add<tether::BetweenSE2>(static_cast<Key>(j), k, Noisy(tj.Inverse() * truth[k], closure_sigma, rng),
                                    closure_noise);
          ++closures;
          break;
        }
      }
    }
    const auto t0 = std::chrono::steady_clock::now();
    smoother.Update(std::move(f), std::move(v));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    block_seconds += s;
    block_max = std::max(block_max, s);
    // Score what left the window, then forget it.
    const tether::Values out = smoother.TakeMarginalized();
    for (Key m : out.keys()) {
      const SE2d e = out.At<SE2d>(m);
      recent_estimates.emplace_back(m, e);
      if (recent_estimates.size() > 11) recent_estimates.pop_front();
      if (recent_estimates.size() == 11 && recent_estimates.front().first + 10 == m) {
        const Key a = recent_estimates.front().first;
        err2 += std::pow(SegmentError(recent_estimates.front().second, e, truth[a], truth[m]), 2);
        dead2 += std::pow(SegmentError(dead[a], dead[m], truth[a], truth[m]), 2);
        ++scored;
      }
    }
    // Truth older than the window and the closures' reach is no longer needed.
    const long drop = i - static_cast<long>(2 * lag) - span - 20;
    if (drop >= 0) {
      truth.erase(static_cast<Key>(drop));
      dead.erase(static_cast<Key>(drop));
    }
    if ((i + 1) % block == 0) {
      std::printf("%ld  %.4f  %.3f  %.1f  %.1f  %zu  %ld  %.4f  %.4f\n", i + 1, 1e3 * block_seconds / block,
                  1e3 * block_max, ResidentMib(), PeakMib(), smoother.Estimate().size(), closures,
                  scored ? std::sqrt(err2 / scored) : 0.0, scored ? std::sqrt(dead2 / scored) : 0.0);
      std::fflush(stdout);
      block_seconds = block_max = err2 = dead2 = 0;
      scored = 0;
      closures = 0;
    }
  }
  return 0;
}
