#include "tether/core/factor_graph.h"

#include <algorithm>

#include "tether/core/error.h"
#include "tether/core/values.h"

namespace tether {

FactorGraph::FactorGraph(const FactorGraph& other) : ids_(other.ids_), next_id_(other.next_id_), fixed_(other.fixed_) {
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

void FactorGraph::ThrowNullFactor() {
  throw InvalidArgument("FactorGraph::Add: the factor is a null pointer; pass a factor made with std::make_unique");
}

bool FactorGraph::IndexOf(FactorId id, std::size_t* index) const {
  const auto it = std::lower_bound(ids_.begin(), ids_.end(), id);
  if (it == ids_.end() || *it != id) return false;
  *index = static_cast<std::size_t>(it - ids_.begin());
  return true;
}

bool FactorGraph::Remove(FactorId id) {
  std::size_t i;
  if (!IndexOf(id, &i)) return false;
  factors_.erase(factors_.begin() + static_cast<std::ptrdiff_t>(i));
  ids_.erase(ids_.begin() + static_cast<std::ptrdiff_t>(i));
  return true;
}

double FactorGraph::Chi2(const Values& values) const {
  double s = 0;
  for (const auto& f : factors_) s += f->Chi2(values);
  return s;
}

double FactorGraph::Cost(const Values& values) const {
  double s = 0;
  for (const auto& f : factors_) s += f->Cost(values);
  return s;
}

bool FactorGraph::HasLoss() const {
  for (const auto& f : factors_) {
    if (f->loss() != nullptr) return true;
  }
  return false;
}

}  // namespace tether
