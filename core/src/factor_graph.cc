#include "tether/core/factor_graph.h"

#include "tether/core/values.h"

namespace tether {

FactorGraph::FactorGraph(const FactorGraph& other) : fixed_(other.fixed_) {
  factors_.reserve(other.factors_.size());
  for (const auto& f : other.factors_) factors_.push_back(f->Clone());
}

FactorGraph& FactorGraph::operator=(const FactorGraph& other) {
  if (this != &other) {
    FactorGraph copy(other);
    *this = std::move(copy);
  }
  return *this;
}

double FactorGraph::Chi2(const Values& values) const {
  double s = 0;
  for (const auto& f : factors_) s += f->Chi2(values);
  return s;
}

}  // namespace tether
