// Covariances from CHOLMOD's Cholesky factor: column solves for joint blocks, and the
// sparse inverse subset (Takahashi's recursion, one supernode at a time) for the diagonal
// blocks of many variables.
//
// With L L^T = P H P^T and Z = (P H P^T)^-1, Z L = L^-T is upper triangular. For one
// supernode S (columns S, rows R below them; L's columns S are [L1; L2]) the rows R of
// Z L's columns S are zero and rows S are L1^-T, so with W = L2 L1^-1:
//   Z_RS = -Z_RR W,      Z_SS = L1^-T L1^-1 - W^T Z_RS.
// Every pair of R is in L's pattern (R is a clique of the filled graph), so going from the
// last supernode to the first, Z on L's pattern is computed from itself: the same dense
// shapes (and about the same flops) as the factorisation.
#include <cholmod.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstring>

#include "backend_functions.h"
#include "blas.h"
#include "builtin_linear_solvers.h"
#include "cholmod_views.h"
#include "covariance_factor.h"
#include "minimizer.h"
#include "serial_openmp.h"
#include "tether/core/timing.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace internal {

namespace {

// Below this many multiply-adds in Z_RR W, Eigen's kernels beat the call into BLAS.
constexpr long kBlasFlops = 32 * 32 * 32;

using Block = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using ConstBlock = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

class CholmodCovariance : public CovarianceFactor {
 public:
  CholmodCovariance(const Csc& h, const ColumnNamer& name) {
    cholmod_start(&cc_);
    cc_.supernodal = CHOLMOD_AUTO;  // as the solver's factorisation (cholmod_solver.cc)
    cc_.print = 0;
    cc_.error_handler = nullptr;
    cc_.quick_return_if_not_posdef = 1;
    n_ = h.cols;
    try {
      Factorize(h, name);
    } catch (...) {
      Release();  // a constructor that throws runs no destructor
      throw;
    }
  }
  ~CholmodCovariance() override { Release(); }

  void Release() {
    if (L_) cholmod_free_factor(&L_, &cc_);
    cholmod_finish(&cc_);
  }

  void Factorize(const Csc& h, const ColumnNamer& name) {
    cholmod_sparse a = CholmodView(View(h), 1);
    SerialOpenMp serial;
    L_ = cholmod_analyze(&a, &cc_);
    if (L_ == nullptr) throw Error("CHOLMOD could not analyse H (status " + std::to_string(cc_.status) + ")");
    const Clock::time_point t0 = Clock::now();
    cholmod_factorize(&a, L_, &cc_);
    factorize_seconds_ = SecondsSince(t0);
    CheckPositive(name);
    if (!L_->is_super) {
      // Simplicial LDL^T -> L L^T, packed, so that each column is a supernode of one.
      cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, L_, &cc_);
    }
    BuildSupernodes();
  }

  Eigen::MatrixXd Solve(const Eigen::MatrixXd& b) override {
    cholmod_dense bd = DenseView(const_cast<double*>(b.data()), b.rows(), b.cols());
    SerialOpenMp serial;
    cholmod_dense* x = cholmod_solve(CHOLMOD_A, L_, &bd, &cc_);
    if (x == nullptr) throw Error("CHOLMOD could not solve (status " + std::to_string(cc_.status) + ")");
    Eigen::MatrixXd out = Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), b.rows(), b.cols());
    cholmod_free_dense(&x, &cc_);
    return out;
  }

  std::vector<Eigen::MatrixXd> DiagonalBlocks(const std::vector<int>& offsets, const std::vector<int>& dims) override {
    if (!z_) SparseInverse();
    std::vector<Eigen::MatrixXd> out(offsets.size());
    for (std::size_t v = 0; v < offsets.size(); ++v) {
      Eigen::MatrixXd& c = out[v];
      c.resize(dims[v], dims[v]);
      bool found = true;
      for (int j = 0; j < dims[v] && found; ++j) {
        for (int i = j; i < dims[v] && found; ++i) {
          found = Lookup(offsets[v] + i, offsets[v] + j, &c(i, j));
          c(j, i) = c(i, j);
        }
      }
      if (!found) c = CovarianceFactor::DiagonalBlocks({offsets[v]}, {dims[v]})[0];
    }
    return out;
  }

  std::string Description() const override {
    return std::string(is_super_ ? "CHOLMOD supernodal" : "CHOLMOD simplicial") + ", sparse inverse subset";
  }

 private:
  void CheckPositive(const ColumnNamer& name) {
    const int* perm = static_cast<const int*>(L_->Perm);
    int bad = -1;
    if (cc_.status == CHOLMOD_NOT_POSDEF || L_->minor < L_->n) {
      bad = static_cast<int>(L_->minor);
    } else if (cc_.status < CHOLMOD_OK) {
      throw Error("CHOLMOD could not factorise H (status " + std::to_string(cc_.status) + "); try linear solver ldlt");
    } else if (!L_->is_super && !L_->is_ll) {
      const double* x = static_cast<const double*>(L_->x);
      const int* p = static_cast<const int*>(L_->p);
      for (int j = 0; j < n_ && bad < 0; ++j) {
        if (!(x[p[j]] > 0)) bad = j;
      }
    }
    if (bad < 0) return;
    const int column = bad < n_ && perm != nullptr ? perm[bad] : -1;
    throw RankDeficientError(
        "H is singular: the Cholesky factorisation broke down at " +
        (column >= 0 ? name(column) : std::string("an unknown column")) +
        ", a direction no factor determines (there, or in a part of the graph it depends on); hold a variable "
        "fixed or add a prior there");
  }

  // The supernodes of L: for a simplicial factor, one per column.
  void BuildSupernodes() {
    is_super_ = L_->is_super != 0;
    if (is_super_) {
      nsuper_ = static_cast<int>(L_->nsuper);
      super_ = static_cast<const int*>(L_->super);
      rowptr_ = static_cast<const int*>(L_->pi);
      rows_ = static_cast<const int*>(L_->s);
      valptr_ = static_cast<const int*>(L_->px);
    } else {
      nsuper_ = n_;
      own_super_.resize(n_ + 1);
      for (int j = 0; j <= n_; ++j) own_super_[j] = j;
      super_ = own_super_.data();
      rowptr_ = valptr_ = static_cast<const int*>(L_->p);
      rows_ = static_cast<const int*>(L_->i);
    }
    lx_ = static_cast<const double*>(L_->x);
    // The recursion and the look-up walk each supernode's rows in increasing order.
    for (int s = 0; s < nsuper_; ++s) {
      if (!std::is_sorted(rows_ + rowptr_[s], rows_ + rowptr_[s + 1])) SortColumns();
    }
    col_super_.resize(n_);
    for (int s = 0; s < nsuper_; ++s) {
      for (int c = super_[s]; c < super_[s + 1]; ++c) col_super_[c] = s;
    }
    pinv_.resize(n_);
    const int* perm = static_cast<const int*>(L_->Perm);
    for (int k = 0; k < n_; ++k) pinv_[perm ? perm[k] : k] = k;
  }

  // A simplicial factor whose columns are not sorted: a sorted copy (never for a supernodal one).
  void SortColumns() {
    if (is_super_) throw Error("CHOLMOD's supernodal factor has unsorted rows; use linear solver ldlt");
    own_rows_.assign(rows_, rows_ + rowptr_[n_]);
    own_x_.assign(lx_, lx_ + rowptr_[n_]);
    std::vector<std::pair<int, double>> col;
    for (int j = 0; j < n_; ++j) {
      col.clear();
      for (int p = rowptr_[j]; p < rowptr_[j + 1]; ++p) col.emplace_back(own_rows_[p], own_x_[p]);
      std::sort(col.begin(), col.end());
      for (std::size_t q = 0; q < col.size(); ++q) {
        own_rows_[rowptr_[j] + q] = col[q].first;
        own_x_[rowptr_[j] + q] = col[q].second;
      }
    }
    rows_ = own_rows_.data();
    lx_ = own_x_.data();
  }

  // Z on L's pattern, from the last supernode to the first.
  void SparseInverse() {
    // Every entry Lookup and GatherZrr read is written below: no need to clear it first.
    z_.reset(new double[static_cast<std::size_t>(valptr_[nsuper_])]);
    int max_ns = 1, max_m = 1;
    for (int s = 0; s < nsuper_; ++s) {
      const int ns = super_[s + 1] - super_[s];
      max_ns = std::max(max_ns, ns);
      max_m = std::max(max_m, rowptr_[s + 1] - rowptr_[s] - ns);
    }
    std::vector<double> zrr(static_cast<std::size_t>(max_m) * max_m), w(static_cast<std::size_t>(max_m) * max_ns);
    std::vector<double> linv(static_cast<std::size_t>(max_ns) * max_ns);
    std::vector<int> pos(static_cast<std::size_t>(max_m));
    for (int s = nsuper_ - 1; s >= 0; --s) {
      const int ns = super_[s + 1] - super_[s];
      const int nr = rowptr_[s + 1] - rowptr_[s];
      const int m = nr - ns;
      const double* ls = lx_ + valptr_[s];
      double* zs = z_.get() + valptr_[s];
      if (m > 0) GatherZrr(rows_ + rowptr_[s] + ns, m, pos.data(), zrr.data());
      if (ns == 1) {
        SingleColumn(ls, m, zrr.data(), w.data(), zs);
      } else {
        Supernode(ls, ns, m, zrr.data(), w.data(), linv.data(), zs);
      }
    }
  }

  // One column (a simplicial factor's): w = l_R / l_jj, Z_Rj = -Z_RR w, Z_jj = 1/l_jj^2 + w.Z_RR w.
  static void SingleColumn(const double* ls, int m, const double* zrr, double* w, double* zs) {
    const double il = 1.0 / ls[0];
    double* y = zs + 1;
    for (int u = 0; u < m; ++u) {
      w[u] = ls[1 + u] * il;
      y[u] = 0;
    }
    for (int t = 0; t < m; ++t) {  // y = Z_RR w from Z_RR's lower triangle
      const double* zc = zrr + static_cast<long>(t) * m;
      const double wt = w[t];
      double acc = zc[t] * wt;
      for (int u = t + 1; u < m; ++u) {
        y[u] += zc[u] * wt;
        acc += zc[u] * w[u];
      }
      y[t] += acc;
    }
    double d = il * il;
    for (int u = 0; u < m; ++u) {
      d += w[u] * y[u];
      y[u] = -y[u];
    }
    zs[0] = d;
  }

  // One supernode of ns columns and m rows below them; the small ones with Eigen, the large
  // ones with BLAS and LAPACK (Z_SS's lower triangle only: nothing reads its upper one).
  static void Supernode(const double* ls, int ns, int m, const double* zrr, double* w, double* linv, double* zs) {
    const int nr = ns + m;
    Block zss(zs, ns, ns, Eigen::OuterStride<>(nr));
    if (static_cast<long>(ns) * ns * ns + static_cast<long>(m) * m * ns < kBlasFlops) {
      Eigen::Map<Eigen::MatrixXd> li(linv, ns, ns);
      li.setIdentity();
      ConstBlock(ls, ns, ns, Eigen::OuterStride<>(nr)).triangularView<Eigen::Lower>().solveInPlace(li);
      zss.noalias() = li.transpose() * li.triangularView<Eigen::Lower>();
      if (m == 0) return;
      Eigen::Map<Eigen::MatrixXd> wm(w, m, ns);
      wm.noalias() = ConstBlock(ls + ns, m, ns, Eigen::OuterStride<>(nr)) * li.triangularView<Eigen::Lower>();
      Eigen::Map<const Eigen::MatrixXd> zr(zrr, m, m);
      Block zrs(zs + ns, m, ns, Eigen::OuterStride<>(nr));
      zrs.noalias() = -(zr.selfadjointView<Eigen::Lower>() * wm);
      zss.noalias() -= wm.transpose() * zrs;
      return;
    }
    zss.triangularView<Eigen::Lower>() = ConstBlock(ls, ns, ns, Eigen::OuterStride<>(nr));
    int info = 0;
    dpotri_("L", &ns, zs, &nr, &info);  // (L1 L1^T)^-1 from L1
    if (info != 0)
      throw Error("LAPACK could not invert a supernode's diagonal block (info " + std::to_string(info) + ")");
    if (m == 0) return;
    Eigen::Map<Eigen::MatrixXd>(w, m, ns) = ConstBlock(ls + ns, m, ns, Eigen::OuterStride<>(nr));
    const double minus_one = -1, zero = 0, one = 1;
    dtrsm_("R", "L", "N", "N", &m, &ns, &one, ls, &nr, w, &m);                       // W = L2 L1^-1
    dsymm_("L", "L", &m, &ns, &minus_one, zrr, &m, w, &m, &zero, zs + ns, &nr);      // Z_RS = -Z_RR W
    dgemm_("T", "N", &ns, &ns, &m, &minus_one, w, &m, zs + ns, &nr, &one, zs, &nr);  // Z_SS -= W^T Z_RS
  }

  // The lower triangle of Z_RR (m x m, column-major) for the sorted rows r of a supernode,
  // gathered from the supernodes that own r's columns (computed already: they come later).
  void GatherZrr(const int* r, int m, int* pos, double* out) const {
    int t = 0;
    while (t < m) {
      const int T = col_super_[r[t]];
      const int c0 = super_[T], c1 = super_[T + 1];
      const int t0 = rowptr_[T], nrt = rowptr_[T + 1] - t0;
      int t1 = t;
      while (t1 < m && r[t1] < c1) {
        pos[t1] = r[t1] - c0;
        ++t1;
      }
      int p = t0 + (c1 - c0);
      for (int u = t1; u < m; ++u) {
        while (rows_[p] != r[u]) ++p;  // r[u] is in T's rows: the clique property
        pos[u] = p - t0;
      }
      for (int c = t; c < t1; ++c) {
        const double* zt = z_.get() + valptr_[T] + static_cast<long>(r[c] - c0) * nrt;
        double* oc = out + static_cast<long>(c) * m;
        for (int u = c; u < m; ++u) oc[u] = zt[pos[u]];
      }
      t = t1;
    }
  }

  // H^-1(a, b) for original columns a, b from Z; false where the pair is not in L's pattern.
  bool Lookup(int a, int b, double* v) const {
    const int qa = pinv_[a], qb = pinv_[b];
    const int c = std::min(qa, qb), row = std::max(qa, qb);
    const int T = col_super_[c];
    const int nrt = rowptr_[T + 1] - rowptr_[T];
    int p = row - super_[T];
    if (row >= super_[T + 1]) {
      const int* first = rows_ + rowptr_[T] + (super_[T + 1] - super_[T]);
      const int* last = rows_ + rowptr_[T + 1];
      const int* it = std::lower_bound(first, last, row);
      if (it == last || *it != row) return false;
      p = static_cast<int>(it - (rows_ + rowptr_[T]));
    }
    *v = z_[static_cast<std::size_t>(valptr_[T]) + static_cast<std::size_t>(c - super_[T]) * nrt + p];
    return true;
  }

  cholmod_common cc_;
  cholmod_factor* L_ = nullptr;
  bool is_super_ = false;
  int nsuper_ = 0;
  const int *super_ = nullptr, *rowptr_ = nullptr, *rows_ = nullptr, *valptr_ = nullptr;
  const double* lx_ = nullptr;
  std::vector<int> own_super_, own_rows_, col_super_, pinv_;
  std::vector<double> own_x_;
  std::unique_ptr<double[]> z_;
};

}  // namespace
}  // namespace internal

std::unique_ptr<internal::CovarianceFactor> backends::MakeCholmodCovariance(const internal::Csc& h,
                                                                            const internal::ColumnNamer& name) {
  return std::make_unique<internal::CholmodCovariance>(h, name);
}

}  // namespace tether
