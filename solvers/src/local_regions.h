#pragma once
// Internal: the local mode of IncrementalSmoother (SmootherMode::kLocal). Solves a change of
// the graph over a region of variables around the ones it touched, everything else held,
// growing the region until no variable at its edge would lower chi2 by more than a tolerance
// if it moved alone. docs/smoother.md, "Local mode".
#include <set>
#include <unordered_map>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {
namespace internal {

struct LocalRegionOptions {
  double tolerance = 1e-3;  ///< chi2 an edge variable may still gain alone
  int hops = 2;             ///< the first region: the seeds and their neighbours this far
  int max_region = 2000;    ///< stop growing beyond this many variables (Result::capped)
};

class LocalRegions {
 public:
  struct Result {
    int region = 0;       ///< variables solved
    int growths = 0;      ///< times the region grew after its first solve
    int iterations = 0;   ///< Gauss-Newton steps, over every solve
    bool capped = false;  ///< grew to max_region with edge variables still beyond the tolerance
    /// The gains (Gain) of the edge variables after the last solve, summed: about what the
    /// region's edge leaves of the optimum's chi2.
    double edge_gain = 0;
    /// chi2 over the factors of the first region before its solve, and what the solves lowered
    /// it by, summed over the growths.
    double gained = 0;
    bool ok = true;  ///< false where a factor could not be evaluated or a step was not finite
  };

  /// The factors each variable takes part in (ids in the graph, for a deterministic order).
  void Add(FactorId id, const Factor* f);
  void Remove(FactorId id, const Factor* f);

  /// Solves over a region grown from `seeds` (keys with values; the held ones are skipped),
  /// moving only the region's variables in *estimate. The keys in `held` never move.
  Result Solve(const std::vector<Key>& seeds, const std::set<Key>& held, const LocalRegionOptions& options,
               Values* estimate);

 private:
  struct Use {
    FactorId id;
    const Factor* factor;
  };
  // The Gauss-Newton solve over `region` (sorted), until a step gains less than a tenth of
  // `tolerance`; false where it failed.
  bool SolveRegion(const std::vector<Key>& region, double tolerance, Values* estimate, int* iterations, double* gained);
  // Variables outside the region (and not held) that share a factor with it, sorted.
  std::vector<Key> Edge(const std::vector<Key>& region, const std::set<Key>& held) const;
  // chi2 that `key` alone could still gain: g^T H^-1 g over its factors (infinity where H is
  // singular).
  double Gain(Key key, const Values& estimate);
  // The factors of the region's variables, each once, by id.
  std::vector<const Factor*> FactorsOf(const std::vector<Key>& region) const;

  std::unordered_map<Key, std::vector<Use>> uses_;
  std::vector<double> e_, jac_;
};

}  // namespace internal
}  // namespace tether
