#pragma once
// `tether replay`: feeds a graph file into the incremental smoother pose by pose, as a
// front-end would, and times each update.
//
// Poses are added in increasing id order. At step i the variable with the i-th smallest id
// is added, with the initial guess of the current estimate of the variable before it composed
// with the edge between the two (through the factor's Predict; failing that, any edge to a
// variable added before, and failing that the file's value), together with every factor whose
// variables have all been added by then. The smoother is updated every `every`-th step (and
// after the last). After the last step Finish() solves to convergence, and the result is
// compared with the batch optimum of the whole file (Optimize from the chordal start).
#include <iosfwd>
#include <string>

#include "tether/solvers/incremental_smoother.h"

namespace tether {

struct ReplayCommand {
  std::string input;
  int every = 1;       ///< update the smoother every N-th step (at least 1)
  int check = 0;       ///< every K-th update, solve the graph so far in batch (untimed); 0: never
  std::string output;  ///< g2o file with the final estimate (optional)
  bool quiet = false;  ///< only the summary lines
  /// The smoother's per-update solve (SmootherOptions::update): iteration limit and
  /// function tolerance; and whether updates whose new factors have zero error skip the solve.
  int update_iterations = SmootherOptions().rounds_per_update;
  double update_tolerance = SmootherOptions().relinearize_threshold;
  bool no_skip = false;
};

/// Exit codes: 0 done; 1 bad input (unreadable file, plugin); 2 bad usage; 3 a solve failed.
int RunReplay(const ReplayCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
