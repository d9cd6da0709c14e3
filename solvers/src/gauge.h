#pragma once
// Internal: which variables a solve holds constant. Shared by the native solvers and the Ceres
// adapter so that both remove the gauge freedom the same way.
#include <set>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {
namespace internal {

/// The graph's own fixed set; or, where it fixes nothing and no factor anchors (a prior, Factor::anchors)
/// the problem, the lowest-key pose that some factor uses (an unused pose anchors nothing).
/// In that last case s->gauge_fixed_automatically and s->gauge_key say so.
std::set<Key> ChooseFixed(const FactorGraph& graph, const Values& values, SolverSummary* s);

}  // namespace internal
}  // namespace tether
