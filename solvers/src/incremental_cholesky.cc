#include "incremental_cholesky.h"

#include <camd.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <queue>
#include <utility>

#include "backends.h"
#include "tether/core/error.h"

namespace tether {
namespace internal {

namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A front whose Cholesky and update (W columns, B rows below them) take at least this many
// flops runs on the BLAS's kernels, smaller ones on Eigen's: a BLAS call costs about a
// microsecond, and below this Eigen's kernels (compiled for the baseline x86-64, without
// AVX) are as quick. Measured on sphere2500 and parking-garage (benchmarks/RESULTS.md,
// "BLAS fronts"): 1e4 beat 3e3, 1e5 and 1e6.
constexpr double kBlasFlops = 1e4;
// The BLAS, from the back-end module (loaded at the first large front), or null where it
// cannot be loaded: Eigen's kernels then do every front.
const BackendTable* Blas() {
  static const BackendTable* const blas = []() -> const BackendTable* {
    try {
      return &Backends();
    } catch (const Error&) {
      return nullptr;
    }
  }();
  return blas;
}

bool UseBlas(int W, int B) {
  const double w = W, b = B;
  return w * w * w / 3 + w * w * b + w * b * b >= kBlasFlops && Blas() != nullptr;
}

void EraseValue(std::vector<int>* v, int x) {
  auto it = std::find(v->begin(), v->end(), x);
  if (it != v->end()) v->erase(it);
}

// out (n x dj, column-major, leading dimension ldo) -= A (n x dk, leading dimension lda) *
// B^T (B: dj x dk, leading dimension lda). Fixed-size kernels for the common block widths
// (vectorised along n; Eigen's GEMM packs its operands, which costs more than the product for
// blocks this narrow), the dynamic product for the rest.
template <int Dk, int Dj>
void SubtractProductFixed(double* out, int ldo, const double* A, const double* B, int lda, int n) {
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Dj>, 0, Stride> O(out, n, Dj, Stride(ldo));
  Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Dk>, 0, Stride> a(A, n, Dk, Stride(lda));
  Eigen::Map<const Eigen::Matrix<double, Dj, Dk>, 0, Stride> b(B, Dj, Dk, Stride(lda));
  O.noalias() -= a.lazyProduct(b.transpose());
}

void SubtractProduct(double* out, int ldo, const double* A, const double* B, int lda, int n, int dk, int dj) {
  if (dk == 3 && dj == 3) return SubtractProductFixed<3, 3>(out, ldo, A, B, lda, n);
  if (dk == 6 && dj == 6 && n < 24) return SubtractProductFixed<6, 6>(out, ldo, A, B, lda, n);
  if (dk == 3 && dj == 6) return SubtractProductFixed<3, 6>(out, ldo, A, B, lda, n);
  if (dk == 6 && dj == 3) return SubtractProductFixed<6, 3>(out, ldo, A, B, lda, n);
  if (dk == 2 && dj == 3) return SubtractProductFixed<2, 3>(out, ldo, A, B, lda, n);
  if (dk == 3 && dj == 2) return SubtractProductFixed<3, 2>(out, ldo, A, B, lda, n);
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<Eigen::MatrixXd, 0, Stride> O(out, n, dj, Stride(ldo));
  Eigen::Map<const Eigen::MatrixXd, 0, Stride> a(A, n, dk, Stride(lda));
  Eigen::Map<const Eigen::MatrixXd, 0, Stride> b(B, dj, dk, Stride(lda));
  O.noalias() -= a * b.transpose();
}

// out (da x db, column-major, leading dimension ldo) += A^T B for the factor's row-major
// Jacobian blocks A (rows x da) and B (rows x db): one block of H. Fixed sizes for the
// built-in shapes (SE2 and SE3 between factors), the dynamic product for the rest.
template <int R, int Da, int Db>
void AddJtJFixed(double* out, int ldo, const double* A, const double* B) {
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<Eigen::Matrix<double, Da, Db>, 0, Stride> O(out, Da, Db, Stride(ldo));
  Eigen::Map<const Eigen::Matrix<double, R, Da, Eigen::RowMajor>> a(A);
  Eigen::Map<const Eigen::Matrix<double, R, Db, Eigen::RowMajor>> b(B);
  O.noalias() += a.transpose() * b;
}

void AddJtJ(double* out, int ldo, const double* A, const double* B, int rows, int da, int db) {
  if (rows == 3 && da == 3 && db == 3) return AddJtJFixed<3, 3, 3>(out, ldo, A, B);
  if (rows == 6 && da == 6 && db == 6) return AddJtJFixed<6, 6, 6>(out, ldo, A, B);
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<Eigen::MatrixXd, 0, Stride> O(out, da, db, Stride(ldo));
  Eigen::Map<const RowMajor> a(A, rows, da);
  Eigen::Map<const RowMajor> b(B, rows, db);
  O.noalias() += a.transpose() * b;
}

// x (dj) -= B^T d for a block B (dr x dj, column-major, leading dimension ld) of a column
// of L and the step d (dr) of its row variable.
template <int Dr, int Dj>
void SubtractTransposedProductFixed(double* x, const double* B, int ld, const double* d) {
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const Eigen::Matrix<double, Dr, Dj>, 0, Stride> b(B, Dr, Dj, Stride(ld));
  Eigen::Map<Eigen::Matrix<double, Dj, 1>>(x).noalias() -=
      b.transpose() * Eigen::Map<const Eigen::Matrix<double, Dr, 1>>(d);
}

void SubtractTransposedProduct(double* x, const double* B, int ld, const double* d, int dr, int dj) {
  if (dr == 3 && dj == 3) return SubtractTransposedProductFixed<3, 3>(x, B, ld, d);
  if (dr == 6 && dj == 6) return SubtractTransposedProductFixed<6, 6>(x, B, ld, d);
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const Eigen::MatrixXd, 0, Stride> b(B, dr, dj, Stride(ld));
  Eigen::Map<Eigen::VectorXd>(x, dj).noalias() -= b.transpose() * Eigen::Map<const Eigen::VectorXd>(d, dr);
}

// x (dj) = L^-T x for the lower triangular diagonal block L (dj x dj, column-major, leading
// dimension ld): fixed sizes for the built-in widths.
template <int D>
void SolveTransposedDiagonalFixed(const double* L, int ld, double* x) {
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const Eigen::Matrix<double, D, D>, 0, Stride> l(L, D, D, Stride(ld));
  Eigen::Map<Eigen::Matrix<double, D, 1>> v(x);
  l.transpose().template triangularView<Eigen::Upper>().solveInPlace(v);
}

void SolveTransposedDiagonal(const double* L, int ld, double* x, int dj) {
  if (dj == 3) return SolveTransposedDiagonalFixed<3>(L, ld, x);
  if (dj == 6) return SolveTransposedDiagonalFixed<6>(L, ld, x);
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const Eigen::MatrixXd, 0, Stride> l(L, dj, dj, Stride(ld));
  Eigen::Map<Eigen::VectorXd> v(x, dj);
  l.transpose().triangularView<Eigen::Upper>().solveInPlace(v);
}

}  // namespace

int IncrementalCholesky::AddVariable(int dim) {
  Var v;
  v.dim = dim;
  v.alive = true;
  v.y = Eigen::VectorXd::Zero(dim);
  v.delta = Eigen::VectorXd::Zero(dim);
  vars_.push_back(std::move(v));
  stamp_.push_back(0);
  pos_.push_back(-1);
  seen_.push_back(0);
  scratch_.push_back(0);
  marked_.push_back(0);
  return static_cast<int>(vars_.size()) - 1;
}

void IncrementalCholesky::RemoveVariable(int v) {
  // Its column (if any) stays until the next Solve, which walks the tree through it; the
  // removal of its factors touched it.
  vars_[v].alive = false;
  touched_.push_back(v);
}

void IncrementalCholesky::SetConstant(int v, bool constant) {
  if (vars_[v].constant == constant) return;
  vars_[v].constant = constant;
  full_ = true;
}

int IncrementalCholesky::AddFactor(const std::vector<int>& vars, int rows) {
  FactorSlot f;
  f.alive = true;
  f.rows = rows;
  f.vars = vars;
  int total = 0;
  for (int v : vars) {
    f.offsets.push_back(total);
    total += rows * vars_[v].dim;
  }
  f.J.assign(static_cast<std::size_t>(total), 0.0);
  f.r = Eigen::VectorXd::Zero(rows);
  factors_.push_back(std::move(f));
  const int id = static_cast<int>(factors_.size()) - 1;
  for (int v : vars) vars_[v].factors.push_back(id);
  Touch(id);
  return id;
}

void IncrementalCholesky::RemoveFactor(int id) {
  FactorSlot& f = factors_[id];
  Touch(id);
  for (int v : f.vars) EraseValue(&vars_[v].factors, id);
  f.alive = false;
  f.J.clear();
  f.J.shrink_to_fit();
  f.r.resize(0);
}

void IncrementalCholesky::Touch(int f) {
  for (int v : factors_[f].vars) touched_.push_back(v);
}

bool IncrementalCholesky::PathMarginal(int v, int max_columns, Eigen::MatrixXd* cov) const {
  if (v < 0 || v >= static_cast<int>(vars_.size()) || full_ || !touched_.empty()) return false;
  // v and its ancestors: every row of their columns is one of them, so their block of H^-1 is
  // (L_PP L_PP^T)^-1 with L_PP the rows and columns of the path alone.
  std::vector<int> path, offset;
  int total = 0;
  for (int j = v; j >= 0; j = Parent(j)) {
    const Var& c = vars_[j];
    if (!InSystem(c) || c.L.cols() != c.dim || static_cast<int>(path.size()) == max_columns) return false;
    path.push_back(j);
    offset.push_back(total);
    total += c.dim;
  }
  auto at = [&](int var) {
    const auto it = std::find(path.begin(), path.end(), var);
    return it == path.end() ? -1 : offset[static_cast<std::size_t>(it - path.begin())];
  };
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(total, total);
  for (std::size_t p = 0; p < path.size(); ++p) {
    const Var& c = vars_[path[p]];
    L.block(offset[p], offset[p], c.dim, c.dim) = c.L.topRows(c.dim);
    for (std::size_t i = 0; i < c.rows.size(); ++i) {
      const int row = at(c.rows[i]);
      if (row < 0) return false;  // not an ancestor: the factor is not what this assumes
      L.block(row, offset[p], vars_[c.rows[i]].dim, c.dim) = c.L.block(c.offsets[i], 0, vars_[c.rows[i]].dim, c.dim);
    }
  }
  // H^-1 = L^-T L^-1; v's block is X^T X with X the first dim(v) columns of L^-1.
  const int d = vars_[v].dim;
  const Eigen::MatrixXd X = L.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(total, d));
  *cov = X.transpose() * X;
  return cov->allFinite();
}

std::int64_t IncrementalCholesky::FactorEntries() const {
  std::int64_t n = 0;
  for (const Var& v : vars_) n += v.L.size();
  return n;
}

int IncrementalCholesky::Parent(int v) const {
  const Var& c = vars_[v];
  return pos_[v] < 0 || c.rows.empty() ? -1 : c.rows.front();
}

int IncrementalCholesky::RowIndex(const std::vector<int>& rows, std::int64_t pos) const {
  auto it = std::lower_bound(rows.begin(), rows.end(), pos, [&](int r, std::int64_t p) { return pos_[r] < p; });
  return static_cast<int>(it - rows.begin());
}

int IncrementalCholesky::Height(const Var& c) const {
  return c.rows.empty() ? c.dim : c.offsets.back() + vars_[c.rows.back()].dim;
}

// Puts the rows of column k back in position order (its rows among the affected columns got
// new positions), moving their blocks of L with them.
void IncrementalCholesky::SortRows(int k) {
  Var& c = vars_[k];
  auto by_pos = [&](int a, int b) { return pos_[a] < pos_[b]; };
  if (std::is_sorted(c.rows.begin(), c.rows.end(), by_pos)) return;
  std::vector<int> order(c.rows.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return by_pos(c.rows[a], c.rows[b]); });
  Eigen::MatrixXd L(c.L.rows(), c.L.cols());
  L.topRows(c.dim) = c.L.topRows(c.dim);
  std::vector<int> rows(c.rows.size()), offsets(c.rows.size());
  int at = c.dim;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const int r = c.rows[order[i]];
    const int dr = vars_[r].dim;
    L.middleRows(at, dr) = c.L.middleRows(c.offsets[order[i]], dr);
    rows[i] = r;
    offsets[i] = at;
    at += dr;
  }
  c.L.swap(L);
  c.rows.swap(rows);
  c.offsets.swap(offsets);
}

// The touched variables and every ancestor of theirs in the elimination tree (all variables
// for a full refactor), marked with stamp_now_. Their columns are cleared.
void IncrementalCholesky::Affected(std::vector<int>* affected) {
  ++stamp_now_;
  const std::uint32_t mark = stamp_now_;
  if (full_) {
    for (std::size_t v = 0; v < vars_.size(); ++v) {
      if (vars_[v].alive || pos_[v] >= 0) {
        stamp_[v] = mark;
        affected->push_back(static_cast<int>(v));
      }
    }
  } else {
    auto walk = [&](int t) {
      for (int v = t; v >= 0 && stamp_[v] != mark; v = Parent(v)) {
        stamp_[v] = mark;
        affected->push_back(v);
      }
    };
    for (int t : touched_) {
      walk(t);
      // A variable leaving the system leaves the rows of every column: also those that hold
      // it only as a stored zero (taken from a supernode's last column) and so are not above
      // a touched variable.
      if (!InSystem(vars_[t])) {
        for (int k : vars_[t].dependents) walk(k);
      }
    }
  }
  for (int a : *affected) {
    Var& c = vars_[a];
    // Columns below the affected ones keep their entries; affected columns are rebuilt.
    auto& d = c.dependents;
    d.erase(std::remove_if(d.begin(), d.end(), [&](int k) { return stamp_[k] == mark; }), d.end());
    c.L.resize(0, 0);
    c.rows.clear();
    c.offsets.clear();
    c.update.resize(0, 0);
    c.update_rhs.resize(0);
    c.update_rows.clear();
    c.has_update = false;
    pos_[a] = -1;
  }
}

// Orders the affected columns: CAMD on the graph of their Schur complement (edges of the
// factors among them, and a clique over the affected rows of every unaffected column that
// reaches them), with the recent variables constrained to come last.
void IncrementalCholesky::Order(std::vector<int>* columns) {
  const int n = static_cast<int>(columns->size());
  if (n <= 1) return;
  const std::uint32_t mark = stamp_now_;  // affected
  for (int i = 0; i < n; ++i) scratch_[(*columns)[i]] = i;
  auto in_columns = [&](int u) { return stamp_[u] == mark && InSystem(vars_[u]); };
  // The cliques: an unaffected column whose parent is affected (the root of a subtree the
  // update leaves alone) adds a clique over its affected rows. Every other unaffected column
  // below has its rows among its parent's, so its clique is inside one of those.
  std::vector<std::vector<int>> cliques;
  std::vector<std::vector<int>> cliques_of(static_cast<std::size_t>(n));
  ++seen_now_;
  for (int i = 0; i < n; ++i) {
    for (int k : vars_[(*columns)[i]].dependents) {
      const Var& ck = vars_[k];
      if (pos_[k] < 0 || seen_[k] == seen_now_ || ck.rows.empty() || stamp_[ck.rows.front()] != mark) continue;
      seen_[k] = seen_now_;
      std::vector<int> clique;
      for (int r : ck.rows) {
        if (in_columns(r)) clique.push_back(scratch_[r]);
      }
      if (clique.size() < 2) continue;
      for (int a : clique) cliques_of[a].push_back(static_cast<int>(cliques.size()));
      cliques.push_back(std::move(clique));
    }
  }
  std::vector<int> Ap(static_cast<std::size_t>(n) + 1, 0), Ai;
  std::vector<int> last(static_cast<std::size_t>(n), -1);
  for (int i = 0; i < n; ++i) {
    last[i] = i;
    auto add = [&](int b) {
      if (last[b] != i) {
        last[b] = i;
        Ai.push_back(b);
      }
    };
    for (int f : vars_[(*columns)[i]].factors) {
      for (int u : factors_[f].vars) {
        if (in_columns(u)) add(scratch_[u]);
      }
    }
    for (int c : cliques_of[i]) {
      for (int b : cliques[c]) add(b);
    }
    Ap[i + 1] = static_cast<int>(Ai.size());
  }
  std::vector<int> C(static_cast<std::size_t>(n), 0);
  int recent = 0;
  for (int v : recent_) {
    if (stamp_[v] == mark && InSystem(vars_[v]) && C[scratch_[v]] == 0) {
      C[scratch_[v]] = 1;
      ++recent;
    }
  }
  if (recent == 0 || recent == n) {
    // No constraint among these columns (a first batch, or a full refactor after Finish()):
    // the newest variable still goes last, since the next update most likely touches it.
    // Newest: marked recent before the latest Solve that marked any of them (marks count
    // Solves, not calls), and of those, or where none was ever marked, the one added last.
    auto newer = [&](int a, int b) { return std::make_pair(marked_[a], a) < std::make_pair(marked_[b], b); };
    const auto last = std::max_element(columns->begin(), columns->end(), newer);
    std::fill(C.begin(), C.end(), 0);
    C[last - columns->begin()] = 1;
  }
  std::vector<int> P(static_cast<std::size_t>(n));
  double control[CAMD_CONTROL], info[CAMD_INFO];
  camd_defaults(control);
  const int status = camd_order(n, Ap.data(), Ai.empty() ? nullptr : Ai.data(), P.data(), control, info, C.data());
  if (status != CAMD_OK && status != CAMD_OK_BUT_JUMBLED) return;  // keep the order given
  std::vector<int> ordered(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) ordered[i] = (*columns)[P[i]];
  columns->swap(ordered);
}

// The rows of column j: the later variables j shares a factor with, and the rows after j of
// each child of j (a column whose parent j is). j becomes a dependent of each of its rows.
void IncrementalCholesky::Symbolic(int j) {
  Var& c = vars_[j];
  const std::int64_t pj = pos_[j];
  ++stamp_now_;
  const std::uint32_t mark = stamp_now_;
  stamp_[j] = mark;
  std::vector<std::pair<std::int64_t, int>>& rows = row_scratch_;
  rows.clear();
  auto add_row = [&](int r) {
    if (stamp_[r] != mark) {
      stamp_[r] = mark;
      rows.emplace_back(pos_[r], r);
    }
  };
  for (int f : c.factors) {
    for (int u : factors_[f].vars) {
      if (u != j && InSystem(vars_[u]) && pos_[u] > pj) add_row(u);
    }
  }
  for (int k : c.dependents) {
    const Var& ck = vars_[k];
    if (ck.rows.front() != j) continue;
    for (std::size_t i = 1; i < ck.rows.size(); ++i) add_row(ck.rows[i]);
  }
  std::sort(rows.begin(), rows.end());
  c.rows.resize(rows.size());
  c.offsets.resize(rows.size());
  int total = c.dim;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    c.rows[i] = rows[i].second;
    c.offsets[i] = total;
    total += vars_[rows[i].second].dim;
  }
  for (int r : c.rows) vars_[r].dependents.push_back(j);
}

// Adds the update of column k (its subtree's contribution to its rows, update_rows order) to
// the lower triangle of F (leading dimension ld) and to b, each row variable r at scratch_[r]
// (none where scratch_[r] < 0); the columns from `split` on go to U (leading dimension ldu) at
// both coordinates less split: a supernode's own update matrix, kept apart from its front.
// Variables consecutive in both form runs, added block by block.
void IncrementalCholesky::ExtendAdd(int k, double* F, int ld, double* b, int split, double* U, int ldu) {
  const Var& ck = vars_[k];
  const std::vector<int>& rows = ck.update_rows;
  // Runs: offset in the update, destination, length; none crosses `split`.
  std::vector<Run>& runs = run_scratch_;
  runs.clear();
  int src = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const int r = rows[i];
    const int d = vars_[r].dim;
    const int dst = scratch_[r];
    if (dst >= 0) {
      if (!runs.empty() && runs.back().src + runs.back().len == src && runs.back().dst + runs.back().len == dst &&
          (dst < split) == (runs.back().dst < split)) {
        runs.back().len += d;
      } else {
        runs.push_back(Run{src, dst, d});
      }
    }
    src += d;
  }
  using Stride = Eigen::OuterStride<>;
  // The block at destination rows r0.. and columns c0.. (r0 >= c0): in F, or in U from `split` on.
  auto target = [&](int r0, int c0, int n_rows, int n_cols) {
    if (c0 < split) {
      return Eigen::Map<Eigen::MatrixXd, 0, Stride>(F + static_cast<std::ptrdiff_t>(c0) * ld + r0, n_rows, n_cols,
                                                    Stride(ld));
    }
    return Eigen::Map<Eigen::MatrixXd, 0, Stride>(U + static_cast<std::ptrdiff_t>(c0 - split) * ldu + (r0 - split),
                                                  n_rows, n_cols, Stride(ldu));
  };
  for (std::size_t q = 0; q < runs.size(); ++q) {
    const Run& Q = runs[q];
    Eigen::Map<Eigen::VectorXd>(b + Q.dst, Q.len) += ck.update_rhs.segment(Q.src, Q.len);
    for (std::size_t p = q; p < runs.size(); ++p) {
      const Run& P = runs[p];
      const auto block = ck.update.block(P.src, Q.src, P.len, Q.len);
      if (P.dst >= Q.dst) {
        target(P.dst, Q.dst, P.len, Q.len) += block;
      } else {
        target(Q.dst, P.dst, Q.len, P.len) += block.transpose();
      }
    }
  }
}

// The update of an unchanged column k that was factorised inside a supernode and so holds
// none: its children's updates extended to its rows, minus its own column's outer product.
void IncrementalCholesky::ComputeUpdate(int k) {
  std::vector<int> children;
  for (int d : vars_[k].dependents) {
    if (vars_[d].rows.front() == k) {
      children.push_back(d);
      if (!vars_[d].has_update) ComputeUpdate(d);
    }
  }
  Var& c = vars_[k];
  const int B = Height(c) - c.dim;
  for (std::size_t i = 0; i < c.rows.size(); ++i) scratch_[c.rows[i]] = c.offsets[i] - c.dim;
  scratch_[k] = -1;
  c.update.setZero(B, B);
  c.update_rhs.setZero(B);
  for (int d : children) ExtendAdd(d, c.update.data(), B, c.update_rhs.data());
  const auto below = c.L.bottomRows(B);
  if (UseBlas(c.dim, B)) {
    ++stats_.blas_fronts;
    const double one = 1, minus_one = -1;
    const int ld = static_cast<int>(c.L.rows());
    Blas()->dsyrk("L", "N", &B, &c.dim, &minus_one, c.L.data() + c.dim, &ld, &one, c.update.data(), &B);
  } else {
    c.update.selfadjointView<Eigen::Lower>().rankUpdate(below, -1.0);
  }
  c.update_rhs.noalias() -= below * c.y;
  c.update_rows = c.rows;
  c.has_update = true;
}

// Whether the parent j of the supernode's last column joins it. Its columns then take every
// row of j (those they lack are stored as zeros). Always where none is lacking (a fundamental
// supernode); otherwise while the front is narrow and mostly not zeros. Measured on the
// replays (benchmarks/RESULTS.md): wider relaxed fronts cost more in zeros than they save.
bool IncrementalCholesky::Merge(Supernode& s, int j) const {
  constexpr int kMaxWidth = 1024;        // scalar columns of a front
  constexpr int kRelaxedWidth = 12;      // fronts up to this wide may store zeros...
  constexpr double kRelaxedZeros = 0.8;  // ...up to this fraction of their entries
  const Var& last = vars_[s.last];
  const Var& c = vars_[j];
  const int W = s.width + c.dim;
  if (W > kMaxWidth) return false;
  const int extra = Height(c) - (Height(last) - last.dim);  // rows each column of s gains
  if (extra == 0) return true;
  const std::int64_t zeros = s.zeros + static_cast<std::int64_t>(s.width) * extra;
  const double entries = 0.5 * W * (W + 1.0) + static_cast<double>(W) * (Height(c) - c.dim);
  if (W > kRelaxedWidth || static_cast<double>(zeros) >= kRelaxedZeros * entries) return false;
  s.zeros = zeros;
  return true;
}

// Refactors the supernode s (multifrontal): its frontal matrix holds its columns' rows of H
// (from their factors) and the updates of its children outside it; a dense Cholesky of its
// columns gives their part of L and, in the rows below, the supernode's own update for its
// parent. The right-hand side rides along as one more column: the forward solution.
bool IncrementalCholesky::FactorSupernode(const Supernode& s, std::string* why) {
  const Var& last = vars_[s.last];
  const int W = s.width;
  const int B = Height(last) - last.dim;
  const int R = W + B;
  const std::int64_t first_pos = pos_[s.first];
  if (s.zeros > 0) {
    // Columns short of rows of the front take them (as zeros, and as their dependents).
    for (int j = s.first; j != s.last; j = vars_[j].rows.front()) {
      Var& c = vars_[j];
      ++seen_now_;
      for (int r : c.rows) seen_[r] = seen_now_;
      const int parent = c.rows.front();
      c.rows.clear();
      c.offsets.clear();
      int at = c.dim;
      auto add = [&](int r) {
        c.rows.push_back(r);
        c.offsets.push_back(at);
        at += vars_[r].dim;
        if (seen_[r] != seen_now_) vars_[r].dependents.push_back(j);
      };
      for (int k = parent;; k = vars_[k].rows.front()) {
        add(k);
        if (k == s.last) break;
      }
      for (int r : last.rows) add(r);
    }
  }
  std::vector<int>& children = children_scratch_;
  children.clear();
  for (int j = s.first;; j = vars_[j].rows.front()) {
    for (int k : vars_[j].dependents) {
      if (pos_[k] < first_pos && vars_[k].rows.front() == j) children.push_back(k);
    }
    if (j == s.last) break;
  }
  for (int k : children) {
    if (!vars_[k].has_update) ComputeUpdate(k);
  }
  ++stamp_now_;
  const std::uint32_t mark = stamp_now_;
  int at = 0;
  for (int k = s.first;; k = vars_[k].rows.front()) {
    stamp_[k] = mark;
    scratch_[k] = at;
    at += vars_[k].dim;
    if (k == s.last) break;
  }
  for (std::size_t i = 0; i < last.rows.size(); ++i) {
    stamp_[last.rows[i]] = mark;
    scratch_[last.rows[i]] = W - last.dim + last.offsets[i];
  }
  // The front's columns (R x W, lower triangle only: what is above the diagonal is never
  // read); its lower right B x B block is the supernode's update matrix, kept apart below.
  const std::size_t size = static_cast<std::size_t>(R) * static_cast<std::size_t>(W);
  if (front_scratch_.size() < size) front_scratch_.resize(size);
  Eigen::Map<Eigen::MatrixXd> P(front_scratch_.data(), R, W);
  for (int col = 0; col < W; ++col) P.col(col).tail(R - col).setZero();
  Eigen::VectorXd& b = front_rhs_scratch_;
  b.setZero(R);
  double* F = P.data();
  // H's columns, and the gradient.
  for (int j = s.first;; j = vars_[j].rows.front()) {
    Var& c = vars_[j];
    const int dj = c.dim;
    const int oj = scratch_[j];
    double* Fj = F + static_cast<std::ptrdiff_t>(oj) * R;
    for (int fi : c.factors) {
      const FactorSlot& f = factors_[fi];
      const int kj = static_cast<int>(std::find(f.vars.begin(), f.vars.end(), j) - f.vars.begin());
      const double* Jj = f.J.data() + f.offsets[kj];
      AddJtJ(Fj + oj, R, Jj, Jj, f.rows, dj, dj);
      b.segment(oj, dj).noalias() -= Eigen::Map<const RowMajor>(Jj, f.rows, dj).transpose() * f.r;
      for (std::size_t k = 0; k < f.vars.size(); ++k) {
        const int u = f.vars[k];
        if (u == j || stamp_[u] != mark || scratch_[u] < oj) continue;
        AddJtJ(Fj + scratch_[u], R, f.J.data() + f.offsets[k], Jj, f.rows, vars_[u].dim, dj);
      }
    }
    c.scale = P.block(oj, oj, dj, dj).diagonal().cwiseSqrt();
    if (j == s.last) break;
  }
  // The rows below the supernode's columns: their block is the supernode's own update matrix
  // (its children's updates on those rows, then minus below below^T), built in place.
  Var& l = vars_[s.last];
  if (B > 0) l.update.setZero(B, B);
  for (int k : children) ExtendAdd(k, F, R, b.data(), W, l.update.data(), B);
  // The dense kernels: Eigen's on small fronts, the BLAS's (vectorised for the CPU at run
  // time) on large ones (benchmarks/RESULTS.md, "BLAS fronts").
  const bool blas = UseBlas(W, B);
  if (blas) {
    ++stats_.blas_fronts;
    int info = 0;
    Blas()->dpotrf("L", &W, F, &R, &info);
    if (info != 0) {
      if (why) *why = "not positive definite";
      return false;
    }
  } else {
    Eigen::Ref<Eigen::MatrixXd, 0, Eigen::OuterStride<>> top = P.topLeftCorner(W, W);
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd, 0, Eigen::OuterStride<>>> llt(top);
    if (llt.info() != Eigen::Success) {
      if (why) *why = "not positive definite";
      return false;
    }
  }
  P.topLeftCorner(W, W).triangularView<Eigen::StrictlyUpper>().setZero();
  const auto Ltop = P.topLeftCorner(W, W).triangularView<Eigen::Lower>();
  Ltop.solveInPlace(b.head(W));
  if (B > 0) {
    auto below = P.block(W, 0, B, W);
    if (blas) {
      const double one = 1, minus_one = -1;
      Blas()->dtrsm("R", "L", "T", "N", &B, &W, &one, F, &R, F + W, &R);                  // below = below Ltop^-T
      Blas()->dsyrk("L", "N", &B, &W, &minus_one, F + W, &R, &one, l.update.data(), &B);  // -= below below^T
    } else {
      Ltop.transpose().solveInPlace<Eigen::OnTheRight>(below);
      l.update.selfadjointView<Eigen::Lower>().rankUpdate(below, -1.0);
    }
    l.update_rhs = b.tail(B);
    l.update_rhs.noalias() -= below * b.head(W);
    l.update_rows = l.rows;
    l.has_update = true;
  }
  for (int j = s.first;; j = vars_[j].rows.front()) {
    Var& c = vars_[j];
    const int oj = scratch_[j];
    c.L = P.block(oj, oj, R - oj, c.dim);
    c.y = b.segment(oj, c.dim);
    if (j == s.last) break;
  }
  return true;
}

// Refactors column j left-looking: H's column, minus the contribution of every column before
// it that reaches it (its dependents), then the dense Cholesky of the diagonal block.
bool IncrementalCholesky::FactorColumn(int j, std::string* why) {
  Var& c = vars_[j];
  const int dj = c.dim;
  const std::int64_t pj = pos_[j];
  // The rows (from Symbolic) at their offsets, and j itself.
  ++stamp_now_;
  const std::uint32_t mark = stamp_now_;
  stamp_[j] = mark;
  for (std::size_t i = 0; i < c.rows.size(); ++i) {
    stamp_[c.rows[i]] = mark;
    scratch_[c.rows[i]] = c.offsets[i];
  }
  const int total = Height(c);
  std::vector<int>& at_j = index_scratch_;  // where row j is in each column j depends on
  at_j.resize(c.dependents.size());
  for (std::size_t d = 0; d < c.dependents.size(); ++d) {
    const Var& ck = vars_[c.dependents[d]];
    at_j[d] = RowIndex(ck.rows, pj);
  }
  scratch_[j] = 0;
  c.L.setZero(total, dj);
  double* F = c.L.data();    // column-major, leading dimension `total`
  Eigen::VectorXd& b = c.y;  // the right-hand side, then the forward solution
  b.setZero(dj);

  // H's column j, and the gradient.
  for (int fi : c.factors) {
    const FactorSlot& f = factors_[fi];
    const int kj = static_cast<int>(std::find(f.vars.begin(), f.vars.end(), j) - f.vars.begin());
    const double* Jj = f.J.data() + f.offsets[kj];
    AddJtJ(F, total, Jj, Jj, f.rows, dj, dj);
    b.noalias() -= Eigen::Map<const RowMajor>(Jj, f.rows, dj).transpose() * f.r;
    for (std::size_t k = 0; k < f.vars.size(); ++k) {
      const int u = f.vars[k];
      if (u == j || stamp_[u] != mark) continue;
      AddJtJ(F + scratch_[u], total, f.J.data() + f.offsets[k], Jj, f.rows, vars_[u].dim, dj);
    }
  }
  c.scale = c.L.topRows(dj).diagonal().cwiseSqrt();
  // Minus the contributions of the columns before j that reach row j: for each, the product
  // of its tail from row j on with its block in row j. The tail's row blocks land in the rows
  // of j; blocks that are consecutive in both are one run, subtracted in one product.
  for (std::size_t d = 0; d < c.dependents.size(); ++d) {
    const Var& ck = vars_[c.dependents[d]];
    const int dk = ck.dim;
    const int ij = at_j[d];
    const int start = ck.offsets[ij];
    const auto Lkj = ck.L.block(start, 0, dj, dk);
    b.noalias() -= Lkj * ck.y;
    std::size_t i = static_cast<std::size_t>(ij);
    while (i < ck.rows.size()) {
      const int src = ck.offsets[i];
      const int r0 = ck.rows[i];
      const int dst = r0 == j ? 0 : scratch_[r0];
      int n = vars_[r0].dim;
      for (++i; i < ck.rows.size() && scratch_[ck.rows[i]] == dst + n && ck.rows[i] != j; ++i) {
        n += vars_[ck.rows[i]].dim;
      }
      const int ld = static_cast<int>(ck.L.rows());
      SubtractProduct(F + dst, total, ck.L.data() + src, ck.L.data() + start, ld, n, dk, dj);
    }
  }
  Eigen::Ref<Eigen::MatrixXd> top = c.L.topRows(dj);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(top);
  if (llt.info() != Eigen::Success) {
    if (why) *why = "not positive definite";
    return false;
  }
  c.L.topRows(dj).triangularView<Eigen::StrictlyUpper>().setZero();
  const auto Ljj = c.L.topRows(dj).triangularView<Eigen::Lower>();
  if (total > dj) {
    auto below = c.L.bottomRows(total - dj);
    Ljj.transpose().solveInPlace<Eigen::OnTheRight>(below);
  }
  Ljj.solveInPlace(b);
  return true;
}

void IncrementalCholesky::BackSubstitute(const std::vector<int>& columns, double wildfire, std::vector<int>* changed) {
  ++stamp_now_;
  const std::uint32_t mark = stamp_now_;
  std::priority_queue<std::pair<std::int64_t, int>> queue;
  for (int j : columns) {
    stamp_[j] = mark;
    queue.emplace(pos_[j], j);
  }
  Eigen::VectorXd& x = x_scratch_;
  Eigen::VectorXd& above = above_scratch_;
  while (!queue.empty()) {
    const int j = queue.top().second;
    queue.pop();
    Var& c = vars_[j];
    const int dj = c.dim;
    const int below = static_cast<int>(c.L.rows()) - dj;
    x = c.y;
    if (below > 0 && (dj == 3 || dj == 6)) {
      // Block by block where the widths are the built-in ones (no gathering of the steps).
      const int ld = static_cast<int>(c.L.rows());
      for (std::size_t i = 0; i < c.rows.size(); ++i) {
        const Var& r = vars_[c.rows[i]];
        SubtractTransposedProduct(x.data(), c.L.data() + c.offsets[i], ld, r.delta.data(), r.dim, dj);
      }
    } else if (below > 0) {
      above.resize(below);
      for (std::size_t i = 0; i < c.rows.size(); ++i) {
        const Var& r = vars_[c.rows[i]];
        above.segment(c.offsets[i] - dj, r.dim) = r.delta;
      }
      x.noalias() -= c.L.bottomRows(below).transpose() * above;
    }
    SolveTransposedDiagonal(c.L.data(), static_cast<int>(c.L.rows()), x.data(), dj);
    const double diff = (x - c.delta).lpNorm<Eigen::Infinity>();
    c.delta = x;
    ++stats_.back_substituted;
    if (diff > 0) changed->push_back(j);
    if (!(diff <= wildfire)) {
      for (int k : c.dependents) {
        if (stamp_[k] != mark) {
          stamp_[k] = mark;
          queue.emplace(pos_[k], k);
        }
      }
    }
  }
}

// Groups the columns (in position order) into supernodes, runs of columns each the parent of
// the one before whose rows Merge accepts, and refactors them in that order.
bool IncrementalCholesky::FactorSupernodes(const std::vector<int>& columns, std::string* why) {
  Supernode s;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const int j = columns[i];
    if (i > 0) {
      const Var& prev = vars_[s.last];
      if (!prev.rows.empty() && prev.rows.front() == j && Merge(s, j)) {
        s.last = j;
        s.width += vars_[j].dim;
        continue;
      }
      ++stats_.supernodes;
      if (!FactorSupernode(s, why)) return false;
    }
    s = Supernode{j, j, vars_[j].dim, 0};
  }
  if (columns.empty()) return true;
  ++stats_.supernodes;
  return FactorSupernode(s, why);
}

bool IncrementalCholesky::Solve(double wildfire, std::vector<int>* changed, std::string* why) {
  const auto t0 = std::chrono::steady_clock::now();
  stats_ = Stats{};
  stats_.full = full_;
  std::vector<int> affected;
  Affected(&affected);
  std::vector<int> columns;
  columns.reserve(affected.size());
  for (int a : affected) {
    Var& c = vars_[a];
    if (InSystem(c)) {
      columns.push_back(a);
      continue;
    }
    // Out of the system (removed, constant, or without factors): its step is zero.
    if (c.delta.size() > 0 && c.delta.lpNorm<Eigen::Infinity>() > 0) {
      c.delta.setZero();
      changed->push_back(a);
    }
    c.y.setZero();
    if (!c.alive) c.dependents.clear();
  }
  touched_.clear();
  Order(&columns);
  recent_.clear();
  ++generation_;
  for (int j : columns) pos_[j] = next_pos_++;
  // The columns below the affected ones that reach them: their rows among the affected ones
  // have new positions.
  ++seen_now_;
  for (int j : columns) {
    for (int k : vars_[j].dependents) {
      if (seen_[k] != seen_now_) {
        seen_[k] = seen_now_;
        SortRows(k);
      }
    }
  }
  stats_.affected = static_cast<int>(columns.size());
  for (int j : columns) Symbolic(j);
  if (stats_.full) {
    if (method_ == Method::kAuto) {
      std::int64_t width = 0;
      for (int j : columns) width += vars_[j].dim;
      multifrontal_ = 2 * width >= 9 * static_cast<std::int64_t>(columns.size());  // mean width >= 4.5
    } else {
      multifrontal_ = method_ == Method::kMultifrontal;
    }
  }
  if (!multifrontal_) {
    for (int j : columns) {
      if (!FactorColumn(j, why)) {
        full_ = true;
        return false;
      }
    }
  } else if (!FactorSupernodes(columns, why)) {
    full_ = true;
    return false;
  }
  full_ = false;
  const auto t1 = std::chrono::steady_clock::now();
  BackSubstitute(columns, wildfire, changed);
  stats_.factor_seconds = std::chrono::duration<double>(t1 - t0).count();
  stats_.back_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  return true;
}

}  // namespace internal
}  // namespace tether
