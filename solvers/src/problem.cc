#include "problem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "thread_pool.h"

namespace tether {
namespace internal {

namespace {

// blk += Jr^T Jc with the sizes known at compile time: the built-in factors' shapes.
template <int M, int R, int C>
void FixedBlock(const double* jr, const double* jc, double* blk, int ld, int, int, int) {
  for (int c = 0; c < C; ++c) {
    for (int r = 0; r < R; ++r) {
      double s = 0;
      for (int i = 0; i < M; ++i) s += jr[i * R + r] * jc[i * C + c];
      blk[c * ld + r] += s;
    }
  }
}

void AnyBlock(const double* jr, const double* jc, double* blk, int ld, int m, int rd, int cd) {
  for (int c = 0; c < cd; ++c) {
    for (int r = 0; r < rd; ++r) {
      double s = 0;
      for (int i = 0; i < m; ++i) s += jr[i * rd + r] * jc[i * cd + c];
      blk[c * ld + r] += s;
    }
  }
}

using Kernel = void (*)(const double*, const double*, double*, int, int, int, int);

Kernel ChooseKernel(int m, int rd, int cd) {
  struct Shape {
    int m, rd, cd;
    Kernel k;
  };
  // BetweenSE2, PriorSE2 (3: 3 x 3); BetweenSE3, PriorSE3 (6: 6 x 6); PosePoint2 (2: 3, 2);
  // PosePoint3 (3: 6, 3).
  static const Shape kShapes[] = {
      {3, 3, 3, FixedBlock<3, 3, 3>}, {6, 6, 6, FixedBlock<6, 6, 6>}, {2, 3, 3, FixedBlock<2, 3, 3>},
      {2, 3, 2, FixedBlock<2, 3, 2>}, {2, 2, 3, FixedBlock<2, 2, 3>}, {2, 2, 2, FixedBlock<2, 2, 2>},
      {3, 6, 6, FixedBlock<3, 6, 6>}, {3, 6, 3, FixedBlock<3, 6, 3>}, {3, 3, 6, FixedBlock<3, 3, 6>},
  };
  for (const Shape& s : kShapes) {
    if (s.m == m && s.rd == rd && s.cd == cd) return s.k;
  }
  return AnyBlock;
}

// g += J^T r for one row-major m x d Jacobian block, sizes known at compile time.
template <int M, int D>
void FixedGradient(const double* j, const double* r, double* g, int, int) {
  for (int c = 0; c < D; ++c) {
    double s = 0;
    for (int i = 0; i < M; ++i) s += j[i * D + c] * r[i];
    g[c] += s;
  }
}

void AnyGradient(const double* j, const double* r, double* g, int m, int d) {
  for (int c = 0; c < d; ++c) {
    double s = 0;
    for (int i = 0; i < m; ++i) s += j[i * d + c] * r[i];
    g[c] += s;
  }
}

using GradientKernel = void (*)(const double*, const double*, double*, int, int);

GradientKernel ChooseGradientKernel(int m, int d) {
  if (m == 3 && d == 3) return FixedGradient<3, 3>;
  if (m == 6 && d == 6) return FixedGradient<6, 6>;
  if (m == 2 && d == 3) return FixedGradient<2, 3>;
  if (m == 2 && d == 2) return FixedGradient<2, 2>;
  if (m == 3 && d == 6) return FixedGradient<3, 6>;
  return AnyGradient;
}

// Splits [0, cost.size()) into `parts` contiguous ranges of about equal total cost;
// returns parts + 1 boundaries.
std::vector<int> Partition(const std::vector<double>& cost, int parts) {
  double total = 0;
  for (double c : cost) total += c;
  std::vector<int> bounds(parts + 1, static_cast<int>(cost.size()));
  bounds[0] = 0;
  double acc = 0;
  int k = 1;
  for (std::size_t i = 0; i < cost.size() && k < parts; ++i) {
    acc += cost[i];
    while (k < parts && acc >= total * k / parts) bounds[k++] = static_cast<int>(i + 1);
  }
  return bounds;
}

}  // namespace

std::string Problem::DescribeNonFinite() const {
  std::vector<double> r(static_cast<std::size_t>(max_m_));
  std::vector<double> jac;
  std::vector<double*> jp;
  for (std::size_t fi = 0; fi < factors_.size(); ++fi) {
    const FactorRef& f = factors_[fi];
    jac.assign(static_cast<std::size_t>(factor_jac_[fi + 1] - factor_jac_[fi]) + 1, 0.0);
    jp.assign(static_cast<std::size_t>(f.count), nullptr);
    std::vector<int> size(static_cast<std::size_t>(f.count), 0);
    int off = 0;
    for (int a = 0; a < f.count; ++a) {
      const Entry& e = entries_[f.first + a];
      if (e.var < 0) continue;
      jp[a] = jac.data() + off;
      size[a] = f.m * e.dim;
      off += size[a];
    }
    const std::string where = "factor " + std::to_string(f.index) + " (" + f.factor->Describe() + ")";
    if (!f.factor->Linearize(params_.data() + f.first, r.data(), jp.data())) return where + " fails to evaluate";
    for (int i = 0; i < f.m; ++i) {
      if (!std::isfinite(r[i])) return where + " has a non-finite error";
    }
    for (int a = 0; a < f.count; ++a) {
      for (int i = 0; i < size[a]; ++i) {
        if (!std::isfinite(jp[a][i])) {
          return where + " has a non-finite Jacobian with respect to " + KeyToString(f.factor->keys()[a]);
        }
      }
    }
  }
  return "";
}

namespace {

// Free variables in insertion order; their columns follow that order (CHOLMOD and SPQR permute
// for fill-in themselves). Variables no factor uses stay as they are (they would only make H
// singular). Calls add(key) for each, in order.
template <typename Add>
void ForEachFreeVariable(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed, Add add) {
  std::unordered_set<Key> used;
  for (const auto& f : graph.factors()) used.insert(f->keys().begin(), f->keys().end());
  for (Key k : values.keys()) {
    if (!fixed.count(k) && used.count(k)) add(k);
  }
}

}  // namespace

VariableGraph Problem::Variables(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed) {
  VariableGraph g;
  std::unordered_map<Key, int> index;
  ForEachFreeVariable(graph, values, fixed, [&](Key k) {
    index.emplace(k, static_cast<int>(g.block_sizes.size()));
    g.block_sizes.push_back(TangentDim(values.TypeOf(k)));
  });
  const int nv = static_cast<int>(g.block_sizes.size());
  std::vector<std::vector<int>> adj(nv);
  g.first_free.assign(graph.size(), -1);
  std::vector<int> vars;
  for (std::size_t fi = 0; fi < graph.size(); ++fi) {
    vars.clear();
    for (Key k : graph.at(fi).keys()) {
      const auto it = index.find(k);
      if (it != index.end()) vars.push_back(it->second);
    }
    if (!vars.empty()) g.first_free[fi] = vars.front();
    for (std::size_t a = 0; a < vars.size(); ++a) {
      for (std::size_t b = a + 1; b < vars.size(); ++b) {
        if (vars[a] == vars[b]) continue;
        adj[vars[a]].push_back(vars[b]);
        adj[vars[b]].push_back(vars[a]);
      }
    }
  }
  ToCompressedRows(&adj, &g.xadj, &g.adjacency);
  return g;
}

void ToCompressedRows(std::vector<std::vector<int>>* lists, std::vector<int>* xadj, std::vector<int>* adjacency) {
  xadj->assign(1, 0);
  adjacency->clear();
  for (std::vector<int>& l : *lists) {
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
    adjacency->insert(adjacency->end(), l.begin(), l.end());
    xadj->push_back(static_cast<int>(adjacency->size()));
    std::vector<int>().swap(l);
  }
}

Problem::Problem(const FactorGraph& graph, Values* values, const std::set<Key>& fixed, int num_threads,
                 const std::vector<char>* factor_mask) {
  std::unordered_map<Key, int> var_index;
  var_index.reserve(values->size());
  ForEachFreeVariable(graph, *values, fixed, [&](Key k) {
    const VarType t = values->TypeOf(k);
    var_index.emplace(k, static_cast<int>(vars_.size()));
    vars_.push_back(Var{k, t, n_, TangentDim(t), values->Params(k)});
    n_ += TangentDim(t);
  });
  factors_.reserve(graph.size());
  factor_jac_.reserve(graph.size() + 1);
  int jac_size = 0;
  for (std::size_t fi = 0; fi < graph.size(); ++fi) {
    if (factor_mask != nullptr && !(*factor_mask)[fi]) continue;
    const Factor& f = graph.at(fi);
    const std::vector<VarType> types = f.variable_types();
    try {
      f.CheckShape();  // keys against types, noise against error dimension
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("factor " + std::to_string(fi) + ": " + e.what());
    }
    const std::vector<const double*> p = f.GatherParams(*values);  // throws for missing/mistyped keys
    const int first = static_cast<int>(entries_.size());
    factor_jac_.push_back(jac_size);
    for (std::size_t k = 0; k < f.keys().size(); ++k) {
      const auto it = var_index.find(f.keys()[k]);
      const int d = TangentDim(types[k]);
      Entry e{it == var_index.end() ? -1 : it->second, d, -1};
      if (e.var >= 0) {
        e.jac = jac_size;
        jac_size += f.dim() * d;
      }
      entries_.push_back(e);
      params_.push_back(p[k]);
    }
    factors_.push_back(FactorRef{&f, static_cast<int>(fi), f.dim(), m_, first, static_cast<int>(f.keys().size())});
    m_ += f.dim();
  }
  factor_jac_.push_back(jac_size);
  jac_.assign(jac_size, 0.0);
  res_.assign(m_, 0.0);
  jac_ptrs_.resize(entries_.size());
  for (std::size_t e = 0; e < entries_.size(); ++e) {
    jac_ptrs_[e] = entries_[e].var >= 0 ? jac_.data() + entries_[e].jac : nullptr;
  }
  std::size_t ambient = 0;
  for (const Var& v : vars_) ambient += AmbientDim(v.type);
  saved_.assign(ambient, 0.0);

  // Each variable's uses, grouped by variable in factor order (for g and the column split).
  const int nv = num_free();
  var_entry_start_.assign(nv + 1, 0);
  for (const Entry& e : entries_) {
    if (e.var >= 0) ++var_entry_start_[e.var + 1];
  }
  for (int v = 0; v < nv; ++v) var_entry_start_[v + 1] += var_entry_start_[v];
  var_entries_.resize(var_entry_start_[nv]);
  {
    std::vector<int> next(var_entry_start_.begin(), var_entry_start_.end() - 1);
    for (const FactorRef& f : factors_) {
      for (int a = 0; a < f.count; ++a) {
        const int v = entries_[f.first + a].var;
        if (v >= 0) {
          var_entries_[next[v]++] = VarEntry{f.first + a, f.row, f.m, ChooseGradientKernel(f.m, vars_[v].dim)};
        }
      }
    }
  }

  // The work split: factors by the size of their Jacobians, block columns by the products
  // and gradient terms that land in them.
  const int parts = std::max(1, num_threads);
  std::vector<double> factor_cost(factors_.size()), column_cost(nv, 0.0);
  for (std::size_t fi = 0; fi < factors_.size(); ++fi) {
    const FactorRef& f = factors_[fi];
    factor_cost[fi] = 8.0 + f.m + (factor_jac_[fi + 1] - factor_jac_[fi]);  // evaluation, whitening
    for (int a = 0; a < f.count; ++a) {
      const Entry& ea = entries_[f.first + a];
      if (ea.var < 0) continue;
      column_cost[ea.var] += f.m * ea.dim;  // gradient
      for (int b = a; b < f.count; ++b) {
        const Entry& eb = entries_[f.first + b];
        if (eb.var >= 0) column_cost[std::max(ea.var, eb.var)] += f.m * ea.dim * eb.dim;
      }
    }
  }
  for (int v = 0; v < nv; ++v) column_cost[v] += vars_[v].dim * vars_[v].dim;  // zeroing
  factor_parts_ = Partition(factor_cost, parts);
  var_parts_ = Partition(column_cost, parts);
  factor_cost_.assign(factors_.size(), 0.0);
  part_status_.assign(parts, 0);
  for (const FactorRef& f : factors_) max_m_ = std::max(max_m_, f.m);
  scratch_.assign(static_cast<std::size_t>(parts) * max_m_, 0.0);
  pool_ = std::make_unique<ThreadPool>(parts);
}

Problem::~Problem() = default;

int Problem::num_threads() const { return pool_->num_threads(); }

std::vector<int> Problem::BlockSizes() const {
  std::vector<int> sizes;
  sizes.reserve(vars_.size());
  for (const Var& v : vars_) sizes.push_back(v.dim);
  return sizes;
}

template <typename F>
void Problem::Parallel(F& f) const {
  pool_->Run(f);
}

int Problem::LinearizeRange(int part, double* res) const {
  const int f0 = factor_parts_[part], f1 = factor_parts_[part + 1];
  const bool jacobians = res != nullptr;
  double* scratch = scratch_.data() + static_cast<std::size_t>(part) * max_m_;
  for (int fi = f0; fi < f1; ++fi) {
    const FactorRef& f = factors_[fi];
    double* r = jacobians ? res + f.row : scratch;
    double* const* jp = jacobians ? jac_ptrs_.data() + f.first : nullptr;
    // Factor::Linearize without its per-call variable_types(): the entries know the dims.
    if (!f.factor->Evaluate(params_.data() + f.first, r, jp)) return 1;
    const SqrtInformation& noise = f.factor->noise();
    noise.WhitenVector(r);
    double s = 0;
    for (int i = 0; i < f.m; ++i) s += r[i] * r[i];
    // A robust loss: the cost is rho(s), and the residual and Jacobians are weighted by
    // sqrt(rho'(s)) (iteratively reweighted least squares, docs/solvers.md "Robust losses").
    const double weight = RobustWeight(f.factor->loss(), s, &factor_cost_[fi]);
    if (jacobians) {
      for (int a = 0; a < f.count; ++a) {
        if (jp[a] == nullptr) continue;
        const int d = entries_[f.first + a].dim;
        noise.WhitenRowMajor(jp[a], d);
        if (weight != 1) {
          for (int i = 0; i < f.m * d; ++i) jp[a][i] *= weight;
        }
      }
      if (weight != 1) {
        for (int i = 0; i < f.m; ++i) r[i] *= weight;
      }
    }
  }
  if (jacobians) {
    const double* j = jac_.data();
    for (int i = factor_jac_[f0]; i < factor_jac_[f1]; ++i) {
      if (!std::isfinite(j[i])) return 2;
    }
  }
  return 0;
}

double Problem::SumChi2() const {
  double chi2 = 0;
  for (double c : factor_cost_) chi2 += c;
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}

double Problem::Chi2() const {
  auto part = [this](int k) { part_status_[k] = LinearizeRange(k, nullptr); };
  Parallel(part);
  double chi2 = SumChi2();
  for (int st : part_status_) {
    if (st == 1) chi2 = std::numeric_limits<double>::infinity();
  }
  Total(&chi2, 1);
  return chi2;
}

void Problem::Total(double* v, int n) const {
  if (group_ == nullptr) return;
  if (split_) group_->Sum(v, n);
  group_->Broadcast(v, n);
}

double Problem::Linearize() {
  jacobian_finite_ = false;
  double* res = res_.data();
  auto part = [this, res](int k) { part_status_[k] = LinearizeRange(k, res); };
  Parallel(part);
  bool finite = true;
  bool failed = false;
  for (int st : part_status_) {
    failed = failed || st == 1;
    if (st == 2) finite = false;
  }
  // chi2 and how many Jacobians are not finite, over every process where the solve spans them.
  double totals[2] = {failed ? std::numeric_limits<double>::infinity() : SumChi2(), finite ? 0.0 : 1.0};
  Total(totals, 2);
  if (!std::isfinite(totals[0])) return totals[0];
  jacobian_finite_ = totals[1] == 0;
  return totals[0];
}

void Problem::BuildNormalStructure(Csc* h, std::vector<int>* diagonal_positions) {
  const int nv = num_free();
  // Block rows present in each block column (upper triangle: row <= column).
  std::vector<std::vector<int>> rows(nv);
  for (int v = 0; v < nv; ++v) rows[v].push_back(v);
  for (const FactorRef& f : factors_) {
    for (int a = 0; a < f.count; ++a) {
      const int va = entries_[f.first + a].var;
      if (va < 0) continue;
      for (int b = a + 1; b < f.count; ++b) {
        const int vb = entries_[f.first + b].var;
        if (vb < 0) continue;
        rows[std::max(va, vb)].push_back(std::min(va, vb));
      }
    }
  }
  std::vector<long> base(nv + 1);
  std::vector<int> height(nv);
  long nnz = 0;
  for (int v = 0; v < nv; ++v) {
    std::sort(rows[v].begin(), rows[v].end());
    rows[v].erase(std::unique(rows[v].begin(), rows[v].end()), rows[v].end());
    int hgt = 0;
    for (int r : rows[v]) hgt += vars_[r].dim;
    height[v] = hgt;
    base[v] = nnz;
    nnz += static_cast<long>(hgt) * vars_[v].dim;
  }
  base[nv] = nnz;
  if (nnz > std::numeric_limits<int>::max()) {
    throw InvalidArgument("the normal equations have more than 2^31 non-zeros; use a smaller graph");
  }
  h->rows = h->cols = n_;
  h->colptr.assign(n_ + 1, 0);
  h->rowind.assign(nnz, 0);
  h->values.assign(nnz, 0.0);
  diagonal_positions->assign(n_, 0);
  for (int v = 0; v < nv; ++v) {
    for (int c = 0; c < vars_[v].dim; ++c) {
      const int col = vars_[v].offset + c;
      const long start = base[v] + static_cast<long>(c) * height[v];
      h->colptr[col] = static_cast<int>(start);
      long p = start;
      for (int r : rows[v]) {
        for (int i = 0; i < vars_[r].dim; ++i) h->rowind[p++] = vars_[r].offset + i;
      }
      // The diagonal block is the last one in its column.
      (*diagonal_positions)[col] = static_cast<int>(start + height[v] - vars_[v].dim + c);
    }
  }
  h->colptr[n_] = static_cast<int>(nnz);
  // Where each factor's blocks land, grouped by block column (factor order within one, so
  // that every entry of H is summed in factor order).
  auto offset_in_column = [&](int row_var, int col_var) {
    const auto it = std::lower_bound(rows[col_var].begin(), rows[col_var].end(), row_var);
    int off = 0;
    for (auto r = rows[col_var].begin(); r != it; ++r) off += vars_[*r].dim;
    return off;
  };
  column_pairs_.assign(nv + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<int> next;
    if (pass == 1) {
      for (int v = 0; v < nv; ++v) column_pairs_[v + 1] += column_pairs_[v];
      pairs_.resize(column_pairs_[nv]);
      next.assign(column_pairs_.begin(), column_pairs_.end() - 1);
    }
    for (const FactorRef& f : factors_) {
      for (int a = 0; a < f.count; ++a) {
        const int ea = f.first + a;
        if (entries_[ea].var < 0) continue;
        for (int b = a; b < f.count; ++b) {
          const int eb = f.first + b;
          if (entries_[eb].var < 0) continue;
          const int va = entries_[ea].var, vb = entries_[eb].var;
          const int re = va <= vb ? ea : eb;
          const int ce = va <= vb ? eb : ea;
          const int rv = entries_[re].var, cv = entries_[ce].var;
          if (pass == 0) {
            ++column_pairs_[cv + 1];
            continue;
          }
          const int rd = entries_[re].dim, cd = entries_[ce].dim;
          // The same variable twice in one factor needs both orders of the cross terms.
          const Kernel k = re != ce && rv == cv ? AnyBlock : ChooseKernel(f.m, rd, cd);
          pairs_[next[cv]++] = Pair{re, ce, static_cast<int>(base[cv] + offset_in_column(rv, cv)), height[cv], f.m, k};
        }
      }
    }
  }
  column_base_ = std::move(base);
}

void Problem::GradientRange(int v0, int v1, double* g, double* diag) const {
  for (int v = v0; v < v1; ++v) {
    double* gv = g + vars_[v].offset;
    double* dv = diag != nullptr ? diag + vars_[v].offset : nullptr;
    const int dim = vars_[v].dim;
    for (int c = 0; c < dim; ++c) gv[c] = 0.0;
    if (dv != nullptr) {
      for (int c = 0; c < dim; ++c) dv[c] = 0.0;
    }
    for (int k = var_entry_start_[v]; k < var_entry_start_[v + 1]; ++k) {
      const VarEntry& ve = var_entries_[k];
      const double* J = jac_.data() + entries_[ve.entry].jac;
      const double* r = res_.data() + ve.row;
      for (int c = 0; c < dim; ++c) {
        double s = 0, d = 0;
        for (int i = 0; i < ve.m; ++i) {
          s += J[i * dim + c] * r[i];
          d += J[i * dim + c] * J[i * dim + c];
        }
        gv[c] += s;
        if (dv != nullptr) dv[c] += d;
      }
    }
  }
}

void Problem::AssembleColumns(int v0, int v1, double* hx, double* g) const {
  std::fill(hx + column_base_[v0], hx + column_base_[v1], 0.0);
  const double* jac = jac_.data();
  for (int v = v0; v < v1; ++v) {
    double* gv = g + vars_[v].offset;
    std::fill(gv, gv + vars_[v].dim, 0.0);
    for (int k = var_entry_start_[v]; k < var_entry_start_[v + 1]; ++k) {
      const VarEntry& ve = var_entries_[k];
      ve.kernel(jac + entries_[ve.entry].jac, res_.data() + ve.row, gv, ve.m, vars_[v].dim);
    }
  }
  for (int k = column_pairs_[v0]; k < column_pairs_[v1]; ++k) {
    const Pair& p = pairs_[k];
    const Entry& er = entries_[p.row_entry];
    const Entry& ec = entries_[p.col_entry];
    double* blk = hx + p.pos;
    p.kernel(jac + er.jac, jac + ec.jac, blk, p.ld, p.m, er.dim, ec.dim);
    if (p.row_entry != p.col_entry && er.var == ec.var) {
      // The same variable twice in one factor: its cross terms land on the diagonal block
      // once per order.
      AnyBlock(jac + ec.jac, jac + er.jac, blk, p.ld, p.m, ec.dim, er.dim);
    }
  }
}

void Problem::AssembleNormal(Csc* h, double* g) const {
  double* hx = h->values.data();
  auto part = [&](int k) { AssembleColumns(var_parts_[k], var_parts_[k + 1], hx, g); };
  Parallel(part);
}

void Problem::Gradient(double* g, double* diag) const {
  auto part = [&](int k) { GradientRange(var_parts_[k], var_parts_[k + 1], g, diag); };
  Parallel(part);
}

void Problem::BuildJacobianStructure(Csc* j, std::vector<int>* damping_positions) {
  const int nv = num_free();
  std::vector<int> column_length(nv, 0);  // residual rows touching each variable
  for (const FactorRef& f : factors_) {
    for (int a = 0; a < f.count; ++a) {
      Entry& e = entries_[f.first + a];
      if (e.var < 0) continue;
      for (int b = 0; b < a; ++b) {
        if (entries_[f.first + b].var == e.var) {
          throw InvalidArgument(f.factor->type_name() + " factor uses variable " + KeyToString(vars_[e.var].key) +
                                " twice, which the qr solver does not support; use --linear cholmod or ldlt");
        }
      }
      e.qr_offset = column_length[e.var];
      column_length[e.var] += f.m;
    }
  }
  long nnz = 0;
  for (int v = 0; v < nv; ++v) nnz += static_cast<long>(column_length[v] + 1) * vars_[v].dim;
  if (nnz > std::numeric_limits<int>::max()) {
    throw InvalidArgument("the Jacobian has more than 2^31 non-zeros; use the Cholesky solvers");
  }
  j->rows = m_ + n_;
  j->cols = n_;
  j->colptr.assign(n_ + 1, 0);
  j->rowind.assign(nnz, 0);
  j->values.assign(nnz, 0.0);
  damping_positions->assign(n_, 0);
  long p = 0;
  for (int v = 0; v < nv; ++v) {
    for (int c = 0; c < vars_[v].dim; ++c) {
      j->colptr[vars_[v].offset + c] = static_cast<int>(p);
      p += column_length[v] + 1;
    }
  }
  j->colptr[n_] = static_cast<int>(nnz);
  for (const FactorRef& f : factors_) {
    for (int a = 0; a < f.count; ++a) {
      const Entry& e = entries_[f.first + a];
      if (e.var < 0) continue;
      for (int c = 0; c < e.dim; ++c) {
        const int start = j->colptr[vars_[e.var].offset + c] + e.qr_offset;
        for (int i = 0; i < f.m; ++i) j->rowind[start + i] = f.row + i;
      }
    }
  }
  for (int col = 0; col < n_; ++col) {
    const int last = j->colptr[col + 1] - 1;
    j->rowind[last] = m_ + col;
    (*damping_positions)[col] = last;
  }
}

void Problem::AssembleJacobian(Csc* j, double* rhs) const {
  // Every factor writes its own rows: the factor split needs no ordering.
  auto part = [&](int k) {
    for (int fi = factor_parts_[k]; fi < factor_parts_[k + 1]; ++fi) {
      const FactorRef& f = factors_[fi];
      for (int a = 0; a < f.count; ++a) {
        const Entry& e = entries_[f.first + a];
        if (e.var < 0) continue;
        const double* J = jac_.data() + e.jac;
        for (int c = 0; c < e.dim; ++c) {
          double* col = j->values.data() + j->colptr[vars_[e.var].offset + c] + e.qr_offset;
          for (int i = 0; i < f.m; ++i) col[i] = J[i * e.dim + c];
        }
      }
      for (int i = 0; i < f.m; ++i) rhs[f.row + i] = -res_[f.row + i];
    }
  };
  Parallel(part);
  for (int i = 0; i < n_; ++i) rhs[m_ + i] = 0.0;
}

void Problem::Retract(const double* delta) {
  for (const Var& v : vars_) RetractParams<double>(v.type, v.params, delta + v.offset, v.params);
}

double Problem::ParameterNorm() const {
  double s = 0;
  for (const Var& v : vars_)
    for (int i = 0; i < AmbientDim(v.type); ++i) s += v.params[i] * v.params[i];
  s = std::sqrt(s);
  if (group_ != nullptr) group_->Broadcast(&s, 1);  // every process holds every variable
  return s;
}

void Problem::Save() {
  has_saved_ = true;
  double* out = saved_.data();
  for (const Var& v : vars_) out = std::copy(v.params, v.params + AmbientDim(v.type), out);
}

void Problem::Restore() {
  if (!has_saved_) return;  // nothing saved yet: the values were never changed
  const double* in = saved_.data();
  for (const Var& v : vars_) {
    std::copy(in, in + AmbientDim(v.type), v.params);
    in += AmbientDim(v.type);
  }
}

}  // namespace internal
}  // namespace tether
