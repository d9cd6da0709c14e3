#include "gauge.h"

namespace tether {
namespace internal {

std::set<Key> ChooseFixed(const FactorGraph& graph, const Values& values, SolverSummary* s) {
  std::set<Key> fixed = graph.fixed();
  if (!fixed.empty()) return fixed;
  for (const auto& f : graph.factors()) {
    if (f->anchors()) return fixed;
  }
  bool found = false;
  Key best = 0;
  for (const auto& f : graph.factors()) {
    for (Key k : f->keys()) {
      if (values.Has(k) && IsPose(values.TypeOf(k)) && (!found || k < best)) {
        best = k;
        found = true;
      }
    }
  }
  if (found) {
    fixed.insert(best);
    s->gauge_fixed_automatically = true;
    s->gauge_key = best;
  }
  return fixed;
}

}  // namespace internal
}  // namespace tether
