// A downstream program: a square of four poses with a loop closure, solved with tether,
// written as a user meets the library: one umbrella header, factors built in place, noise from
// per-axis sigmas, one naming scheme for values, and poses and values printed with <<.
#include <iostream>
#include <sstream>

#include "tether/tether.h"

int main() {
  tether::FactorGraph graph;
  tether::Values values;
  const auto noise = tether::SqrtInformation::FromSigmas(Eigen::Vector3d(0.1, 0.1, 0.05));
  const double corners[4][3] = {{0, 0, 0}, {1, 0, 1.57}, {1, 1, 3.14}, {0, 1, -1.57}};
  for (tether::Key k = 0; k < 4; ++k) {
    graph.Add<tether::BetweenSE2>(k, (k + 1) % 4, tether::SE2d(1, 0, 1.5707963267948966), noise);
    // A start near the true square, off by a few centimetres.
    values.Insert(k, tether::SE2d(corners[k][0] + 0.05 * k, corners[k][1] - 0.03 * k, corners[k][2] + 0.05));
  }
  // The chordal start of exact measurements is already the solution (chi2 ~ 0).
  const tether::InitSummary init = tether::Initialize(graph, &values, tether::InitMethod::kChordal);
  if (init.poses_set != 3 || graph.Chi2(values) > 1e-6) {
    std::cout << "unexpected chordal start: " << init.message << ", chi2 " << graph.Chi2(values) << "\n";
    return 1;
  }
  const tether::SolverSummary s = tether::Optimize(graph, &values, {});
  std::cout << s.BriefReport() << "\n" << values;
  std::ostringstream pose;
  pose << values.At<tether::SE2d>(2);
  std::cout << "pose 2: " << pose.str() << "\n";
  const bool ok =
      s.status == tether::SolverStatus::kConverged && s.final_chi2 < 1e-12 && pose.str().rfind("SE2(", 0) == 0;
  return ok ? 0 : 1;
}
