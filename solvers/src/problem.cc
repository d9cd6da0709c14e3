#include "problem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "tether/core/error.h"

namespace tether {
namespace internal {

Problem::Problem(const FactorGraph& graph, Values* values, const std::set<Key>& fixed) : values_(values) {
  // Free variables in insertion order; their columns follow that order (CHOLMOD and SPQR
  // permute for fill-in themselves).
  // Variables no factor uses stay as they are (they would only make H singular).
  std::unordered_set<Key> used;
  for (const auto& f : graph.factors()) used.insert(f->keys().begin(), f->keys().end());
  std::unordered_map<Key, int> var_index;
  var_index.reserve(values->size());
  for (Key k : values->keys()) {
    if (fixed.count(k) || !used.count(k)) continue;
    const VarType t = values->TypeOf(k);
    var_index.emplace(k, static_cast<int>(vars_.size()));
    vars_.push_back(Var{k, t, n_, TangentDim(t), values->Params(k)});
    n_ += TangentDim(t);
  }
  factors_.reserve(graph.size());
  int jac_size = 0;
  for (std::size_t fi = 0; fi < graph.size(); ++fi) {
    const Factor& f = graph.at(fi);
    const std::vector<VarType> types = f.variable_types();
    try {
      f.CheckShape();  // keys against types, noise against error dimension
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("factor " + std::to_string(fi) + ": " + e.what());
    }
    const std::vector<const double*> p = f.GatherParams(*values);  // throws for missing/mistyped keys
    const int first = static_cast<int>(entries_.size());
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
    factors_.push_back(FactorRef{&f, f.dim(), m_, first, static_cast<int>(f.keys().size())});
    m_ += f.dim();
  }
  jac_.assign(jac_size, 0.0);
  res_.assign(m_, 0.0);
  jac_ptrs_.resize(entries_.size());
  for (std::size_t e = 0; e < entries_.size(); ++e) {
    jac_ptrs_[e] = entries_[e].var >= 0 ? jac_.data() + entries_[e].jac : nullptr;
  }
  std::size_t ambient = 0;
  for (const Var& v : vars_) ambient += AmbientDim(v.type);
  saved_.assign(ambient, 0.0);
}

double Problem::Chi2() const {
  double chi2 = 0;
  double r[kMaxResidualDim];
  for (const FactorRef& f : factors_) {
    if (!f.factor->Linearize(params_.data() + f.first, r, nullptr)) return std::numeric_limits<double>::infinity();
    for (int i = 0; i < f.m; ++i) chi2 += r[i] * r[i];
  }
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}

double Problem::Linearize() {
  jacobian_finite_ = false;
  double chi2 = 0;
  for (const FactorRef& f : factors_) {
    double* r = res_.data() + f.row;
    if (!f.factor->Linearize(params_.data() + f.first, r, jac_ptrs_.data() + f.first)) {
      return std::numeric_limits<double>::infinity();
    }
    for (int i = 0; i < f.m; ++i) chi2 += r[i] * r[i];
  }
  if (!std::isfinite(chi2)) return std::numeric_limits<double>::infinity();
  jacobian_finite_ = true;
  for (double v : jac_) {
    if (!std::isfinite(v)) {
      jacobian_finite_ = false;
      break;
    }
  }
  return chi2;
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
  std::vector<long> base(nv);
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
  // Where each factor's blocks land.
  auto offset_in_column = [&](int row_var, int col_var) {
    int off = 0;
    for (int r : rows[col_var]) {
      if (r == row_var) return off;
      off += vars_[r].dim;
    }
    return -1;
  };
  pairs_.clear();
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
        pairs_.push_back(Pair{re, ce, static_cast<int>(base[cv] + offset_in_column(rv, cv)), height[cv]});
      }
    }
  }
}

void Problem::AddGradient(const FactorRef& f, double* g, double* diag) const {
  const double* r = res_.data() + f.row;
  for (int a = 0; a < f.count; ++a) {
    const Entry& e = entries_[f.first + a];
    if (e.var < 0) continue;
    const double* J = jac_.data() + e.jac;
    const int off = vars_[e.var].offset;
    for (int c = 0; c < e.dim; ++c) {
      double s = 0, d = 0;
      for (int i = 0; i < f.m; ++i) {
        s += J[i * e.dim + c] * r[i];
        d += J[i * e.dim + c] * J[i * e.dim + c];
      }
      g[off + c] += s;
      if (diag != nullptr) diag[off + c] += d;
    }
  }
}

void Problem::AssembleNormal(Csc* h, double* g) const {
  std::fill(h->values.begin(), h->values.end(), 0.0);
  std::fill(g, g + n_, 0.0);
  double* hx = h->values.data();
  std::size_t pi = 0;
  for (const FactorRef& f : factors_) {
    AddGradient(f, g, nullptr);
    // Pairs were generated in the same factor order.
    for (; pi < pairs_.size() && pairs_[pi].row_entry < f.first + f.count; ++pi) {
      const Pair& p = pairs_[pi];
      const Entry& er = entries_[p.row_entry];
      const Entry& ec = entries_[p.col_entry];
      const double* Jr = jac_.data() + er.jac;
      const double* Jc = jac_.data() + ec.jac;
      double* blk = hx + p.pos;
      for (int c = 0; c < ec.dim; ++c) {
        for (int rr = 0; rr < er.dim; ++rr) {
          double s = 0;
          for (int i = 0; i < f.m; ++i) s += Jr[i * er.dim + rr] * Jc[i * ec.dim + c];
          blk[c * p.ld + rr] += s;
        }
      }
      if (p.row_entry != p.col_entry && er.var == ec.var) {
        // The same variable twice in one factor: its cross terms land on the diagonal block
        // once per order.
        for (int c = 0; c < ec.dim; ++c)
          for (int rr = 0; rr < er.dim; ++rr) {
            double s = 0;
            for (int i = 0; i < f.m; ++i) s += Jc[i * ec.dim + rr] * Jr[i * er.dim + c];
            blk[c * p.ld + rr] += s;
          }
      }
    }
  }
}

void Problem::Gradient(double* g, double* diag) const {
  std::fill(g, g + n_, 0.0);
  std::fill(diag, diag + n_, 0.0);
  for (const FactorRef& f : factors_) AddGradient(f, g, diag);
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
  for (const FactorRef& f : factors_) {
    for (int a = 0; a < f.count; ++a) {
      const Entry& e = entries_[f.first + a];
      if (e.var < 0) continue;
      const double* J = jac_.data() + e.jac;
      for (int c = 0; c < e.dim; ++c) {
        double* col = j->values.data() + j->colptr[vars_[e.var].offset + c] + e.qr_offset;
        for (int i = 0; i < f.m; ++i) col[i] = J[i * e.dim + c];
      }
    }
  }
  for (int i = 0; i < m_; ++i) rhs[i] = -res_[i];
  for (int i = 0; i < n_; ++i) rhs[m_ + i] = 0.0;
}

void Problem::Retract(const double* delta) {
  for (const Var& v : vars_) RetractParams<double>(v.type, v.params, delta + v.offset, v.params);
}

double Problem::ParameterNorm() const {
  double s = 0;
  for (const Var& v : vars_)
    for (int i = 0; i < AmbientDim(v.type); ++i) s += v.params[i] * v.params[i];
  return std::sqrt(s);
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
