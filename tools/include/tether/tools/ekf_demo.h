#pragma once
// `tether ekf-demo`: the filter experiment of tether/frontends/ekf/experiment.h over the
// experiments, associations and seeds the flags name, printed as tables. For each experiment (1: control noise std
// (0.1 m/s, pi/18 rad/s); 2: doubled), each data association (known, nearest neighbour) and
// each seed, it runs dead reckoning, EKF-SLAM, UKF-SLAM, the invariant EKF and FastSLAM 1.0 and
// 2.0 (at each --fastslam-particles count), builds the pose graph from the same
// odometry and observations, seeds it with each filter's run, feeds it to the incremental
// smoother step by step and solves it; it reports, over the seeds, mean +- std of the robot
// trajectory RMSE and the landmark RMSE of each, the wrong associations, and the time; with
// --nees also each method's consistency (frontends/ekf/consistency.h).
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/frontends/ekf/experiment.h"

namespace tether {

struct EkfDemoCommand {
  int seeds = 20;
  std::uint64_t first_seed = 1;
  std::string experiments = "1,2";
  std::string association = "known,nn";
  std::string fastslam_particles = "100";  ///< a list, or "none"
  std::string fastslam = "1,2";            ///< the FastSLAM versions
  EkfDemoSetup setup;
  std::string output;  ///< also write the table (markdown) here
  std::string plot;    ///< an SVG of the first seed of the first experiment and association
  bool quiet = false;
};

/// Exit codes: 0 done; 2 bad usage; 4 an output could not be written.
int RunEkfDemo(const EkfDemoCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
