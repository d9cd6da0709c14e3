#include "local_regions.h"

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "one_variable.h"
#include "tether/core/robust_kernels.h"

namespace tether {
namespace internal {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr int kMaxIterations = 10;
constexpr int kMaxDampings = 6;

}  // namespace

void LocalRegions::Add(FactorId id, const Factor* f) {
  for (std::size_t i = 0; i < f->keys().size(); ++i) {
    const Key k = f->keys()[i];
    if (std::find(f->keys().begin(), f->keys().begin() + static_cast<std::ptrdiff_t>(i), k) !=
        f->keys().begin() + static_cast<std::ptrdiff_t>(i)) {
      continue;  // a key listed twice in one factor is used once
    }
    uses_[k].push_back({id, f});
  }
}

void LocalRegions::Remove(FactorId id, const Factor* f) {
  for (Key k : f->keys()) {
    auto it = uses_.find(k);
    if (it == uses_.end()) continue;
    std::vector<Use>& list = it->second;
    list.erase(std::remove_if(list.begin(), list.end(), [id](const Use& u) { return u.id == id; }), list.end());
    if (list.empty()) uses_.erase(it);
  }
}

std::vector<const Factor*> LocalRegions::FactorsOf(const std::vector<Key>& region) const {
  std::vector<Use> all;
  for (Key k : region) {
    const auto it = uses_.find(k);
    if (it != uses_.end()) all.insert(all.end(), it->second.begin(), it->second.end());
  }
  std::sort(all.begin(), all.end(), [](const Use& a, const Use& b) { return a.id < b.id; });
  std::vector<const Factor*> out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i == 0 || all[i].id != all[i - 1].id) out.push_back(all[i].factor);
  }
  return out;
}

std::vector<Key> LocalRegions::Edge(const std::vector<Key>& region, const std::set<Key>& held) const {
  std::vector<Key> edge;
  for (Key k : region) {
    const auto it = uses_.find(k);
    if (it == uses_.end()) continue;
    for (const Use& u : it->second) {
      for (Key q : u.factor->keys()) {
        if (!held.count(q) && !std::binary_search(region.begin(), region.end(), q)) edge.push_back(q);
      }
    }
  }
  std::sort(edge.begin(), edge.end());
  edge.erase(std::unique(edge.begin(), edge.end()), edge.end());
  return edge;
}

double LocalRegions::Gain(Key key, const Values& estimate) {
  const auto it = uses_.find(key);
  if (it == uses_.end()) return 0;
  std::vector<const Factor*> factors;
  for (const Use& u : it->second) {
    if (std::count(u.factor->keys().begin(), u.factor->keys().end(), key) == 1) factors.push_back(u.factor);
  }
  const int d = TangentDim(estimate.TypeOf(key));
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(d, d);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(d);
  if (!std::isfinite(OneVariableCost(factors, key, estimate.Params(key), estimate, &H, &g))) return kInfinity;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  const Eigen::VectorXd dd = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(dd.minCoeff() > 1e-12 * std::max(dd.maxCoeff(), 1e-300))) return kInfinity;
  const double gain = g.dot(ldlt.solve(g));
  return std::isfinite(gain) ? gain : kInfinity;
}

bool LocalRegions::SolveRegion(const std::vector<Key>& region, double tolerance, Values* estimate, int* iterations,
                               double* gained) {
  // The elimination order: minimum degree on the variables' graph (one node per variable,
  // much smaller than H's scalar pattern), H laid out in that order.
  const std::vector<const Factor*> factors = FactorsOf(region);
  const int nv = static_cast<int>(region.size());
  std::vector<Eigen::Triplet<double>> pattern;
  std::vector<int> in;
  for (int v = 0; v < nv; ++v) pattern.emplace_back(v, v, 1.0);
  for (const Factor* f : factors) {
    in.clear();
    for (Key k : f->keys()) {
      const auto it = std::lower_bound(region.begin(), region.end(), k);
      if (it != region.end() && *it == k) in.push_back(static_cast<int>(it - region.begin()));
    }
    for (int a : in) {
      for (int b : in) {
        if (a != b) pattern.emplace_back(a, b, 1.0);
      }
    }
  }
  Eigen::SparseMatrix<double> graph(nv, nv);
  graph.setFromTriplets(pattern.begin(), pattern.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;
  Eigen::AMDOrdering<int>()(graph, order);  // order.indices()[position] = variable
  // Per region variable (in `region`'s order): its offset in H, parameters, type.
  std::vector<int> offset(region.size());
  std::vector<double*> value(region.size());
  std::vector<VarType> type(region.size());
  int n = 0;
  for (int pos = 0; pos < nv; ++pos) {
    const std::size_t v = static_cast<std::size_t>(order.indices()[pos]);
    offset[v] = n;
    value[v] = estimate->Params(region[v]);
    type[v] = estimate->TypeOf(region[v]);
    n += TangentDim(type[v]);
  }
  auto offset_of = [&](Key k) {
    const auto it = std::lower_bound(region.begin(), region.end(), k);
    return it != region.end() && *it == k ? offset[static_cast<std::size_t>(it - region.begin())] : -1;
  };
  // Per factor, once: its keys' parameters, and per key the offset in the region (-1: held)
  // and the tangent size; every key's entries in `slots`, a factor's from `first[f]`.
  struct Slot {
    const double* params;
    double* jacobian;  // into jac_, or null for a held key
    int at, dim;
  };
  std::vector<Slot> slots;
  std::vector<std::size_t> first;
  std::size_t jac_size = 0, max_dim = 0;
  for (const Factor* f : factors) {
    first.push_back(slots.size());
    const std::size_t m = static_cast<std::size_t>(f->dim());
    max_dim = std::max(max_dim, m);
    for (Key k : f->keys()) {
      const int at = offset_of(k);
      const int dim = TangentDim(estimate->TypeOf(k));
      slots.push_back({estimate->Params(k), nullptr, at, dim});
      if (at >= 0) jac_size += m * static_cast<std::size_t>(dim);
    }
  }
  first.push_back(slots.size());
  jac_.assign(jac_size, 0.0);
  e_.assign(max_dim, 0.0);
  for (std::size_t f = 0, used = 0; f < factors.size(); ++f) {
    for (std::size_t i = first[f]; i < first[f + 1]; ++i) {
      if (slots[i].at < 0) continue;
      slots[i].jacobian = jac_.data() + used;
      used += static_cast<std::size_t>(factors[f]->dim()) * slots[i].dim;
    }
  }
  std::vector<const double*> params;
  std::vector<double*> jp;
  Eigen::VectorXd g(n);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  int max_tangent = 1;
  for (const Slot& sl : slots) max_tangent = std::max(max_tangent, sl.dim);
  std::vector<double> scratch(static_cast<std::size_t>(max_tangent) * max_tangent);
  // H's lower triangle: its pattern once, then where each entry the loop below adds to lands
  // in H's values, in the order it visits them.
  Eigen::SparseMatrix<double> H(n, n), A(n, n);
  std::vector<int> where;
  {
    std::vector<Eigen::Triplet<double>> pattern;
    for (std::size_t f = 0; f < factors.size(); ++f) {
      for (std::size_t a = first[f]; a < first[f + 1]; ++a) {
        for (std::size_t b = first[f]; b < first[f + 1]; ++b) {
          const Slot &sa = slots[a], &sb = slots[b];
          if (sa.at < 0 || sb.at < 0 || sb.at > sa.at) continue;
          for (int i = 0; i < sa.dim; ++i) {
            for (int j = 0; j < sb.dim; ++j) {
              if (sa.at + i >= sb.at + j) pattern.emplace_back(sa.at + i, sb.at + j, 0.0);
            }
          }
        }
      }
    }
    for (int i = 0; i < n; ++i) pattern.emplace_back(i, i, 0.0);  // a region variable no factor sees
    H.setFromTriplets(pattern.begin(), pattern.end());
    H.makeCompressed();
    where.reserve(pattern.size());
    for (std::size_t t = 0; t + static_cast<std::size_t>(n) < pattern.size(); ++t) {
      const int col = pattern[t].col(), row = pattern[t].row();
      const int* begin = H.innerIndexPtr() + H.outerIndexPtr()[col];
      const int* end = H.innerIndexPtr() + H.outerIndexPtr()[col + 1];
      where.push_back(static_cast<int>(std::lower_bound(begin, end, row) - H.innerIndexPtr()));
    }
  }
  // The cost over the region's factors; with `build`, also H and g.
  auto evaluate = [&](bool build) {
    double cost = 0;
    std::size_t next = 0;  // into `where`
    if (build) {
      std::fill(H.valuePtr(), H.valuePtr() + H.nonZeros(), 0.0);
      g.setZero();
    }
    for (std::size_t f = 0; f < factors.size(); ++f) {
      const int m = factors[f]->dim();
      params.clear();
      jp.clear();
      for (std::size_t i = first[f]; i < first[f + 1]; ++i) {
        params.push_back(slots[i].params);
        jp.push_back(build ? slots[i].jacobian : nullptr);
      }
      if (!factors[f]->Linearize(params.data(), e_.data(), jp.data())) return kInfinity;
      double sq = 0, rho = 0;
      for (int i = 0; i < m; ++i) sq += e_[i] * e_[i];
      const double w2 = std::pow(RobustWeight(factors[f]->loss(), sq, &rho), 2);
      cost += rho;
      if (!build) continue;
      const Eigen::Map<const Eigen::VectorXd> r(e_.data(), m);
      for (std::size_t a = first[f]; a < first[f + 1]; ++a) {
        const Slot& sa = slots[a];
        if (sa.at < 0) continue;
        const Eigen::Map<const RowMajor> Ja(sa.jacobian, m, sa.dim);
        g.segment(sa.at, sa.dim).noalias() += w2 * Ja.transpose() * r;
        for (std::size_t b = first[f]; b < first[f + 1]; ++b) {
          const Slot& sb = slots[b];
          if (sb.at < 0 || sb.at > sa.at) continue;
          const Eigen::Map<const RowMajor> Jb(sb.jacobian, m, sb.dim);
          Eigen::Map<Eigen::MatrixXd> block(scratch.data(), sa.dim, sb.dim);  // rows of a, columns of b
          block.noalias() = w2 * Ja.transpose() * Jb;
          for (int i = 0; i < sa.dim; ++i) {
            for (int j = 0; j < sb.dim; ++j) {
              if (sa.at + i >= sb.at + j) H.valuePtr()[where[next++]] += block(i, j);
            }
          }
        }
      }
    }
    return std::isfinite(cost) ? cost : kInfinity;
  };

  std::vector<double> saved;
  auto save = [&] {
    saved.clear();
    for (std::size_t v = 0; v < region.size(); ++v) saved.insert(saved.end(), value[v], value[v] + AmbientDim(type[v]));
  };
  auto restore = [&] {
    std::size_t i = 0;
    for (std::size_t v = 0; v < region.size(); ++v) {
      const std::size_t a = static_cast<std::size_t>(AmbientDim(type[v]));
      std::copy(saved.begin() + static_cast<std::ptrdiff_t>(i), saved.begin() + static_cast<std::ptrdiff_t>(i + a),
                value[v]);
      i += a;
    }
  };

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
  bool analysed = false;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double cost = evaluate(true);
    if (!std::isfinite(cost)) return false;
    if (!analysed) {
      ldlt.analyzePattern(H);
      analysed = true;
    }
    save();
    double lambda = 0;
    bool accepted = false;
    double next = cost;
    Eigen::VectorXd delta;
    for (int damp = 0; damp < kMaxDampings && !accepted; ++damp) {
      if (lambda == 0) {
        ldlt.factorize(H);
      } else {
        A = H;
        for (int i = 0; i < n; ++i) A.coeffRef(i, i) += lambda * std::max(H.coeff(i, i), 1e-12);
        ldlt.factorize(A);
      }
      if (ldlt.info() == Eigen::Success) {
        delta = -ldlt.solve(g);
        if (!delta.allFinite()) return false;
        for (std::size_t v = 0; v < region.size(); ++v) {
          RetractParams(type[v], value[v], delta.data() + offset[v], value[v]);
        }
        next = evaluate(false);
        if (next <= cost) {
          accepted = true;
          break;
        }
        restore();
      }
      lambda = lambda == 0 ? 1e-4 : lambda * 10;
    }
    if (!accepted) return true;  // no step lowers the cost: the region is at its minimum
    ++*iterations;
    *gained += cost - next;
    // Converged where a step gains less than a tenth of what an edge variable may still gain,
    // or where an undamped step gained what the linear model promised (-g^T delta) to within
    // that: the model holds there, so the step landed at the region's minimum.
    const double enough = std::max(1e-10 * cost, 0.1 * tolerance);
    if (cost - next <= enough) return true;
    if (lambda == 0 && std::abs((cost - next) - (-g.dot(delta))) <= enough) return true;
  }
  return true;
}

LocalRegions::Result LocalRegions::Solve(const std::vector<Key>& seeds, const std::set<Key>& held,
                                         const LocalRegionOptions& options, Values* estimate) {
  Result r;
  std::set<Key> region;
  std::vector<Key> frontier;
  for (Key k : seeds) {
    if (held.count(k) || !estimate->Has(k) || !uses_.count(k)) continue;
    if (region.insert(k).second) frontier.push_back(k);
  }
  // Takes the variables sharing a factor with `from` into the region; returns the new ones.
  auto neighbours = [&](const std::vector<Key>& from) {
    std::vector<Key> added;
    for (Key k : from) {
      const auto it = uses_.find(k);
      if (it == uses_.end()) continue;
      for (const Use& u : it->second) {
        for (Key q : u.factor->keys()) {
          if (!held.count(q) && region.insert(q).second) added.push_back(q);
        }
      }
    }
    return added;
  };
  for (int h = 0; h < options.hops && !frontier.empty(); ++h) frontier = neighbours(frontier);
  while (!region.empty()) {
    const std::vector<Key> sorted(region.begin(), region.end());
    if (static_cast<int>(sorted.size()) > options.max_region) {
      r.capped = true;
      return r;
    }
    if (!SolveRegion(sorted, options.tolerance, estimate, &r.iterations, &r.gained)) {
      r.ok = false;
      return r;
    }
    r.region = static_cast<int>(sorted.size());
    std::vector<Key> grow;
    r.edge_gain = 0;
    for (Key k : Edge(sorted, held)) {
      const double gain = Gain(k, *estimate);
      if (gain > options.tolerance) {
        grow.push_back(k);
      } else {
        r.edge_gain += gain;
      }
    }
    if (grow.empty()) return r;
    ++r.growths;
    for (Key k : grow) region.insert(k);
    neighbours(grow);
  }
  return r;
}

}  // namespace internal
}  // namespace tether
