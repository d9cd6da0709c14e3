#pragma once
// FactorGraph: the factors of a problem, and the set of variables held fixed.
//
// Adding a factor returns its handle (FactorId); Remove(handle) takes it out again and keeps
// the order of the others. Handles are never reused within a graph, and a copy of the graph
// keeps them.
#include <cstdint>
#include <memory>
#include <set>
#include <utility>
#include <vector>

#include "tether/core/factor.h"

namespace tether {

class Values;

/// The handle of a factor in its graph.
using FactorId = std::uint64_t;

class FactorGraph {
 public:
  FactorGraph() = default;
  FactorGraph(const FactorGraph& other);
  FactorGraph& operator=(const FactorGraph& other);
  FactorGraph(FactorGraph&&) = default;
  FactorGraph& operator=(FactorGraph&&) = default;

  /// Adds a factor; returns its handle. Throws InvalidArgument for a null pointer.
  FactorId Add(std::unique_ptr<Factor> f) {
    if (f == nullptr) ThrowNullFactor();
    factors_.push_back(std::move(f));
    ids_.push_back(next_id_);
    return next_id_++;
  }
  /// Builds a factor in place: graph.Add<BetweenSE2>(1, 2, SE2d(1, 0, 0), noise). Returns it
  /// (its handle is id(size() - 1)).
  template <class F, class... Args>
  F& Add(Args&&... args) {
    auto f = std::make_unique<F>(std::forward<Args>(args)...);
    F& ref = *f;
    Add(std::move(f));
    return ref;
  }
  /// Removes the factor with that handle (the others keep their order and handles); false
  /// where the graph has none. Linear in the number of factors.
  bool Remove(FactorId id);
  /// The handle of the i-th factor.
  FactorId id(std::size_t i) const { return ids_[i]; }
  /// The position of the factor with that handle; false where there is none.
  bool IndexOf(FactorId id, std::size_t* index) const;
  std::size_t size() const { return factors_.size(); }
  bool empty() const { return factors_.empty(); }
  const Factor& at(std::size_t i) const { return *factors_[i]; }
  Factor& at(std::size_t i) { return *factors_[i]; }
  const std::vector<std::unique_ptr<Factor>>& factors() const { return factors_; }

  /// Variables held constant by the solver (g2o FIX lines).
  void Fix(Key k) { fixed_.insert(k); }
  void Unfix(Key k) { fixed_.erase(k); }
  bool IsFixed(Key k) const { return fixed_.count(k) != 0; }
  const std::set<Key>& fixed() const { return fixed_; }

  /// Sum of chi2 over all factors (without their robust losses).
  double Chi2(const Values& values) const;
  /// Sum of each factor's Cost: the objective the solvers minimise (Chi2 where no factor
  /// carries a robust loss).
  double Cost(const Values& values) const;
  /// Whether some factor carries a robust loss.
  bool HasLoss() const;

 private:
  [[noreturn]] static void ThrowNullFactor();
  std::vector<std::unique_ptr<Factor>> factors_;
  std::vector<FactorId> ids_;  // increasing: factors keep the order they were added in
  FactorId next_id_ = 0;
  std::set<Key> fixed_;
};

}  // namespace tether
