// A downstream program: a square of four poses with a loop closure, solved with tether.
#include <cstdio>

#include "tether/factors/between_se2.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

int main() {
  tether::FactorGraph graph;
  tether::Values values;
  const auto noise = tether::SqrtInformation::Isotropic(3, 0.1);
  const double corners[4][3] = {{0, 0, 0}, {1, 0, 1.57}, {1, 1, 3.14}, {0, 1, -1.57}};
  for (tether::Key k = 0; k < 4; ++k) {
    graph.Add(std::make_unique<tether::BetweenSE2>(k, (k + 1) % 4, tether::SE2d(1, 0, 1.5707963267948966), noise));
    // A start near the true square, off by a few centimetres.
    values.Insert(k, tether::SE2d(corners[k][0] + 0.05 * k, corners[k][1] - 0.03 * k, corners[k][2] + 0.05));
  }
  // The chordal start of exact measurements is already the solution (chi2 ~ 0).
  const tether::InitSummary init = tether::Initialize(graph, &values, tether::InitMethod::kChordal);
  if (init.poses_set != 3 || graph.Chi2(values) > 1e-6) {
    std::printf("unexpected chordal start: %s, chi2 %g\n", init.message.c_str(), graph.Chi2(values));
    return 1;
  }
  const tether::SolverSummary s = tether::Optimize(graph, &values, {});
  std::printf("%s\n", s.BriefReport().c_str());
  const bool ok = s.status == tether::SolverStatus::kConverged && s.final_chi2 < 1e-12;
  return ok ? 0 : 1;
}
