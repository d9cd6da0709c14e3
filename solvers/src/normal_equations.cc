#include "tether/solvers/normal_equations.h"

#include <string>

#include "builtin_linear_solvers.h"
#include "problem.h"
#include "tether/core/error.h"

namespace tether {

namespace {

std::set<Key> Held(const FactorGraph& graph, const std::set<Key>& held) {
  std::set<Key> all = graph.fixed();
  all.insert(held.begin(), held.end());
  return all;
}

int CheckedThreads(int num_threads) {
  if (num_threads < 1) {
    throw InvalidArgument("NormalEquations: num_threads is " + std::to_string(num_threads) + "; use 1 or more");
  }
  return num_threads;
}

}  // namespace

// The values first: the Problem keeps pointers into them.
struct NormalEquations::Impl {
  Impl(const FactorGraph& graph, const Values& v, const std::set<Key>& held, int num_threads)
      : values(v), problem(graph, &values, Held(graph, held), CheckedThreads(num_threads)) {
    problem.BuildNormalStructure(&h, &diagonal);
    g.assign(static_cast<std::size_t>(problem.tangent_dim()), 0.0);
  }
  Values values;
  internal::Problem problem;
  internal::Csc h;
  std::vector<int> diagonal;  // where each diagonal entry sits in h (the solvers damp there)
  std::vector<double> g;
};

NormalEquations::NormalEquations(const FactorGraph& graph, const Values& values, const std::set<Key>& held,
                                 int num_threads)
    : impl_(std::make_unique<Impl>(graph, values, held, num_threads)) {}

NormalEquations::~NormalEquations() = default;

const Values& NormalEquations::values() const { return impl_->values; }

std::vector<Key> NormalEquations::FreeKeys() const {
  std::vector<Key> keys;
  keys.reserve(static_cast<std::size_t>(impl_->problem.num_free()));
  for (int i = 0; i < impl_->problem.num_free(); ++i) keys.push_back(impl_->problem.free_key(i));
  return keys;
}

std::vector<int> NormalEquations::BlockSizes() const { return impl_->problem.BlockSizes(); }

int NormalEquations::size() const { return impl_->problem.tangent_dim(); }

double NormalEquations::Linearize() { return impl_->problem.Linearize(); }

double NormalEquations::Chi2() const { return impl_->problem.Chi2(); }

void NormalEquations::Assemble() { impl_->problem.AssembleNormal(&impl_->h, impl_->g.data()); }

SparseMatrixView NormalEquations::H() const { return internal::View(impl_->h); }

const std::vector<double>& NormalEquations::g() const { return impl_->g; }

}  // namespace tether
