#pragma once
// A solve that grows the graph in time order: the poses in increasing key order (the order of
// the public files and of a front-end's ids) are cut into chunks; at each chunk the poses so
// far, with every factor whose variables are all present, are solved from the previous
// chunk's estimate, the new poses placed by composing their odometry (a factor that is not a
// loop closure) onto it. Each solve thus starts near its answer, which a robust loss needs:
// a loop closure is judged against a map made of the closures accepted before it, not
// against an odometry start that has drifted for the whole run (benchmarks/RESULTS.md,
// "Outlier benchmark": DCS from the odometry start of input_M3500_g2o fails at 30-50% false
// closures, and holds from the optimum without them). A chunk's solve moves only the poses
// of the newest chunks (the window, ChunkedSolveOptions::free_chunks, default the newest
// one): the older map is held, as the closures accepted so far left it; one solve of the
// whole graph ends it.
//
// The graph's own losses are used as they are (for example DCS on the loop closures).
// Variables other than poses enter with the first chunk in which a factor ties them to a pose
// present, at their given values. A graph without SE2 or SE3 poses is solved whole, once.
#include <functional>
#include <string>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

struct ChunkedSolveOptions {
  /// How many chunks the poses are cut into (fewer where chunks would hold fewer than
  /// min_chunk_poses). Default 10 (20 gave the same decisions on the outlier benchmark and on
  /// simulated worlds of 1000-2000 poses, at 1.4x the time; benchmarks/RESULTS.md, "GNC: ten
  /// chunks").
  int chunks = 10;
  int min_chunk_poses = 50;
  /// Each chunk's solve. Default: Levenberg-Marquardt, at most 30 iterations.
  SolverOptions solver;
  /// The solves before the last stop once the cost falls by less than this fraction per
  /// iteration (the larger of this and solver.function_tolerance); the last solve, of the
  /// whole graph, keeps solver's. A chunk's map only has to be good enough to judge the next
  /// chunk's closures against. 0: solver's own everywhere. Default 1e-5.
  double interim_function_tolerance = 1e-5;
  /// The window: each chunk's solve moves the poses of the newest free_chunks chunks only,
  /// the older ones held where the earlier solves left them (factors among held poses alone
  /// are left out of it); after the last chunk one more solve moves every pose. On a pose
  /// graph a chunk's solve then costs about one chunk's worth, not the whole graph so far
  /// (landmarks are never held: their factors stay in every solve). 0: no window, each
  /// solve moves every pose so far (the last chunk's is the whole graph's). Default 1: GNC
  /// from this start makes the same decisions as with 0 on the outlier benchmark and on
  /// simulated worlds, in 0.2-0.45x the time; DCS alone in chunks is less accurate with it on
  /// intel, a new closure being judged against an older map that does not bend toward it
  /// (benchmarks/RESULTS.md, "GNC: a window").
  int free_chunks = 1;
  /// Called before each solve (chunk from 0; with a window, also before the whole graph's
  /// solve that follows the last chunk, with chunk one more than the last chunk's) with the
  /// graph so far (the factors of earlier chunks first, in the order they joined: the first
  /// `solved` of them were in the graph at the last solve; a window leaves those among held
  /// poses out of the solve itself) and the estimate it starts from; it may change that graph's losses (a scale
  /// learned from the residuals so far) or remove factors from it for the chunks to come
  /// (FactorGraph::Remove; `solved` at the next call counts what is left). Its factors are
  /// copies: the caller's graph is not touched.
  std::function<void(int chunk, std::size_t solved, FactorGraph* sub, const Values& estimate)> before_solve;

  ChunkedSolveOptions();
  bool IsValid(std::string* why) const;
};

struct ChunkedSolveSummary {
  int chunks = 0;      ///< solves run
  int iterations = 0;  ///< over all solves
  SolverSummary last;  ///< the last solve's (the whole graph's)
  double seconds = 0;
  bool usable = false;
  std::string message;  ///< empty when usable; else why not
};

/// Solves `graph` chunk by chunk from *values (its poses' values are replaced as the chunks
/// go; only the first pose's and other variables' values are used as given). Throws
/// InvalidArgument for invalid options; a variable without a value, or a failed solve, gives
/// a summary that is not usable and says why (and *values unchanged).
ChunkedSolveSummary SolveInChunks(const FactorGraph& graph, Values* values,
                                  const ChunkedSolveOptions& options = ChunkedSolveOptions());

}  // namespace tether
