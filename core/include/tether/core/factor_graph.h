#pragma once
// FactorGraph: the factors of a problem, and the set of variables held fixed.
#include <memory>
#include <set>
#include <utility>
#include <vector>

#include "tether/core/factor.h"

namespace tether {

class Values;

class FactorGraph {
 public:
  FactorGraph() = default;
  FactorGraph(const FactorGraph& other);
  FactorGraph& operator=(const FactorGraph& other);
  FactorGraph(FactorGraph&&) = default;
  FactorGraph& operator=(FactorGraph&&) = default;

  void Add(std::unique_ptr<Factor> f) { factors_.push_back(std::move(f)); }
  /// Builds a factor in place: graph.Add<BetweenSE2>(1, 2, SE2d(1, 0, 0), noise). Returns it.
  template <class F, class... Args>
  F& Add(Args&&... args) {
    auto f = std::make_unique<F>(std::forward<Args>(args)...);
    F& ref = *f;
    factors_.push_back(std::move(f));
    return ref;
  }
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

  /// Sum of chi2 over all factors.
  double Chi2(const Values& values) const;

 private:
  std::vector<std::unique_ptr<Factor>> factors_;
  std::set<Key> fixed_;
};

}  // namespace tether
