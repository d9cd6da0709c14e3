#pragma once
// The filter experiment of the thesis's chapters 3 and 4.2 on simulated worlds
// (landmark_simulator.h), the loop behind `tether ekf-demo` and Python's ekf.run_experiment.
// For each experiment (1: control noise std (0.1 m/s, pi/18 rad/s); 2: doubled), a data
// association (known, nearest neighbour) and each seed, it runs dead reckoning, EKF-SLAM,
// UKF-SLAM, the invariant EKF and FastSLAM 1.0 and 2.0, builds the pose graph from the same odometry and
// observations, seeds it with each filter's run, feeds it to the incremental smoother step by
// step and solves it; it reports, over the seeds, mean +- std of the robot trajectory RMSE and
// the landmark RMSE of each, the wrong associations, and the time; with consistency also each
// method's NEES (consistency.h).
#include <cstdint>
#include <string>
#include <vector>

namespace tether {

/// The world: steps and the measurement noise (std of range [m] and bearing [rad]; the thesis's
/// 2 m and pi/18 by default).
struct EkfDemoSetup {
  int steps = 200;
  double range_sigma = 2.0;
  double bearing_sigma = 0.17453292519943295;
  /// Also the consistency of each method's pose estimate at every step (NEES; the graphs: the
  /// smoother's online estimate and marginal after each step). Costs a marginal per step.
  bool consistency = false;
  /// The invariant EKF's min_range [m]: observations nearer are not used. Negative: 1.5 range
  /// sigmas (3 m at the thesis's noise; docs/front_ends.md, "Consistency").
  double invariant_min_range = -1;
  /// The EKF's and UKF's min_range [m] (default 0: every observation).
  double min_range = 0;
  /// The invariant EKF's update_iterations.
  int invariant_iterations = 2;
  /// Also the graphs seeded by the filters (false: the filters alone, much faster).
  bool graphs = true;
  /// FastSLAM 1.0 and 2.0 (fast_slam.h) with each of these particle counts (empty: neither).
  std::vector<int> fastslam_particles = {100};
  /// Which FastSLAM versions run (1.0 and 2.0 by default).
  bool fastslam_one = true;
  bool fastslam_two = true;
};

/// One method's figures over the seeds.
struct EkfDemoRow {
  std::string method;
  std::vector<double> trajectory_rmse;
  std::vector<double> landmark_rmse;
  std::vector<double> wrong_associations;
  std::vector<double> seconds;
  /// With setup.consistency: per step (the start first), the NEES summed over nees_runs runs.
  std::vector<double> step_nees;
  int nees_runs = 0;
  int failures = 0;          ///< runs that threw (a filter whose covariance broke down)
  std::string failure_note;  ///< the first failure's message
};

struct EkfDemoConfig {
  int experiment = 1;
  bool nearest_neighbour = false;
  EkfDemoSetup setup;
  double observations = 0;  ///< per run, the mean over the seeds
  std::vector<EkfDemoRow> rows;
};

/// Runs one experiment and association over the seeds (no output).
EkfDemoConfig RunEkfExperiment(int experiment, bool nearest_neighbour, int seeds, std::uint64_t first_seed,
                               const EkfDemoSetup& setup = {});

/// The markdown table of the configurations.
std::string EkfDemoTable(const std::vector<EkfDemoConfig>& configs);

/// The consistency table (setup.consistency): per method the NEES averaged over the runs at each
/// step from the second, then its mean over those steps, the steps whose average lies in the 95%
/// interval for that many runs, and the average at a few steps.
std::string EkfDemoConsistencyTable(const std::vector<EkfDemoConfig>& configs);

/// An SVG of one seed: the truth, dead reckoning, each filter (with 2-sigma landmark and final
/// pose ellipses) and the graph seeded by the EKF, with each one's trajectory RMSE.
std::string EkfDemoSvg(int experiment, bool nearest_neighbour, std::uint64_t seed, const EkfDemoSetup& setup = {});

}  // namespace tether
