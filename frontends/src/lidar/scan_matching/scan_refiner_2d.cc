#include "tether/frontends/lidar/scan_matching/scan_refiner_2d.h"

#include "tether/core/error.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace lidar {

bool ScanRefinerOptions::IsValid(std::string* why) const {
  if (max_iterations < 1) {
    if (why != nullptr) *why = "max_iterations is " + std::to_string(max_iterations) + "; it must be at least 1";
    return false;
  }
  return weights.IsValid(why);
}

ScanRefinement RefineScanPose(const std::shared_ptr<const ProbabilityGrid>& grid, const SE2d& initial,
                              const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                              const ScanRefinerOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("ScanRefinerOptions: " + why);
  constexpr Key kPose = 0;
  FactorGraph graph;
  graph.Add<ScanMatchSE2>(kPose, grid, points, guess, options.weights);
  Values values;
  values.Insert(kPose, initial);
  SolverOptions solver;
  solver.algorithm = Algorithm::kLevenbergMarquardt;
  solver.linear_solver = LinearSolverType::kEigenLDLT;
  solver.max_iterations = options.max_iterations;
  solver.function_tolerance = 1e-6;
  const SolverSummary summary = Optimize(graph, &values, solver);
  ScanRefinement result;
  result.pose = values.At<SE2d>(kPose);
  result.status = summary.status;
  result.iterations = summary.iterations;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  return result;
}

}  // namespace lidar
}  // namespace tether
