#pragma once
// `tether bench --outliers RATES FILES`: how well each way of solving keeps a map right when
// false loop closures are added to a graph file (issue 10's outlier benchmark).
//
// For each file: the loop closures as read (edges between poses whose ids are not
// consecutive), and the optimum without false ones (least squares, chordal start). For each
// rate and seed: rate x (number of true loop closures) false closures are added with the
// information of a true one: "random", between random pose pairs with random relative poses
// (translation uniform in +-10 m per axis, rotation uniform), or "grouped", in mutually
// consistent clusters of 5 (pairs (i + k, j + k), k = 0..4, all agreeing on one wrong
// relative pose of i and j: a front-end's perceptual aliasing). Then each method solves from
// the file's own start (its vertices: odometry in the public files): none (least squares),
// huber (loop=huber:1), dcs (loop=dcs:1), cdcs (DCS with phi = the chi2 0.99 quantile,
// solved in chunks: chunked_solve.h), gnc (GNC, Geman-McClure, from its default start: DCS in
// chunks), gnc-ls (GNC from least squares, the classic start), sc (switchable
// constraints, the switch prior from the chi2 quantile) or sc:SIGMA (switch prior sigma
// SIGMA; Sünderhauf's is sc:1). Reported per method: the absolute trajectory error (positions, after a
// rigid alignment) against the optimum without false closures, chi2 of the true factors
// at the result over their chi2 at that optimum, precision and recall of the rejected set
// (GNC's and switchable constraints'; for the others the closures whose final weight rho' is
// below 0.1), and time over
// the time of the solve without false closures.
#include <ostream>
#include <string>
#include <vector>

namespace tether {

struct OutlierBenchOptions {
  std::vector<std::string> files;
  std::vector<double> rates = {0.1, 0.3, 0.5};
  std::vector<int> seeds = {1, 2, 3, 4, 5};
  bool grouped = false;
  std::vector<std::string> methods = {"none", "huber", "dcs", "gnc"};
};

struct OutlierBenchRow {
  std::string file, mode, method;
  double rate = 0;
  int false_closures = 0, true_closures = 0;
  // Over the seeds: median and largest ATE, median chi2 ratio, smallest precision and
  // recall, median time ratio.
  double ate_median = 0, ate_max = 0, chi2_ratio = 0, precision_min = 1, recall_min = 1, time_ratio = 0;
  int runs = 0;
  std::string status;  ///< "ok", or why a run failed
  /// gnc and gnc-ls: the most stages any seed ran, and the seconds of GNC's start, stages and
  /// final least squares summed over the seeds (0 for the other methods).
  int gnc_stages_max = 0;
  double gnc_start_seconds = 0, gnc_stages_seconds = 0, gnc_final_seconds = 0;
};

/// Runs the benchmark; throws tether::Error for a file that cannot be read or an unknown
/// method.
std::vector<OutlierBenchRow> RunOutlierBench(const OutlierBenchOptions& options, std::ostream& progress);

/// The rows as a Markdown table.
std::string FormatOutlierBenchMarkdown(const std::vector<OutlierBenchRow>& rows);

}  // namespace tether
