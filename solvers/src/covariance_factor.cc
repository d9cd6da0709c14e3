// Covariances by solves against columns of the identity (the default of CovarianceFactor),
// and the factorisations behind "ldlt" (Eigen's SimplicialLDLT of H) and "qr" (SuiteSparseQR's
// R of J: H^-1 = E R^-1 R^-T E^T for the column permutation E).
#include "covariance_factor.h"

#include <Eigen/SparseCholesky>
#include <SuiteSparseQR.hpp>
#include <cstring>

#include "cholmod_views.h"
#include "minimizer.h"
#include "tether/core/timing.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace internal {

std::vector<Eigen::MatrixXd> CovarianceFactor::DiagonalBlocks(const std::vector<int>& offsets,
                                                              const std::vector<int>& dims) {
  // Blocks of variables solved together: up to kColumns right-hand sides at once.
  constexpr int kColumns = 96;
  std::vector<Eigen::MatrixXd> out(offsets.size());
  std::size_t v0 = 0;
  while (v0 < offsets.size()) {
    std::size_t v1 = v0;
    int k = 0;
    while (v1 < offsets.size() && (k == 0 || k + dims[v1] <= kColumns)) k += dims[v1++];
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n_, k);
    for (std::size_t v = v0, c = 0; v < v1; c += dims[v], ++v) {
      for (int i = 0; i < dims[v]; ++i) b(offsets[v] + i, static_cast<Eigen::Index>(c) + i) = 1;
    }
    const Eigen::MatrixXd x = Solve(b);
    for (std::size_t v = v0, c = 0; v < v1; c += dims[v], ++v) {
      out[v] = x.block(offsets[v], static_cast<Eigen::Index>(c), dims[v], dims[v]);
      out[v] = 0.5 * (out[v] + out[v].transpose()).eval();
    }
    v0 = v1;
  }
  return out;
}

namespace {

class LdltCovariance : public CovarianceFactor {
 public:
  using Map = Eigen::Map<const Eigen::SparseMatrix<double, Eigen::ColMajor, int>>;

  LdltCovariance(const Csc& h, const ColumnNamer& name) {
    n_ = h.cols;
    const Map a(h.rows, h.cols, h.colptr[h.cols], h.colptr.data(), h.rowind.data(), h.values.data());
    solver_.analyzePattern(a);
    const Clock::time_point t0 = Clock::now();
    solver_.factorize(a);
    factorize_seconds_ = SecondsSince(t0);
    int bad = -1;
    if (solver_.info() != Eigen::Success) {
      bad = n_ - 1;  // Eigen does not say where; the message stays general
    } else {
      const Eigen::VectorXd& d = solver_.vectorD();
      for (int j = 0; j < n_ && bad < 0; ++j) {
        if (!(d[j] > 0)) bad = j;
      }
    }
    if (bad < 0) return;
    const int column = solver_.permutationPinv().indices()[bad];
    throw RankDeficientError("H is singular: the LDL^T factorisation found no positive pivot at " + name(column) +
                             ", a direction no factor determines (there, or in a part of the graph it depends "
                             "on); hold a variable fixed or add a prior there");
  }
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& b) override { return solver_.solve(b); }
  std::string Description() const override { return "Eigen SimplicialLDLT, column solves"; }

 private:
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Upper> solver_;
};

// SuiteSparseQR works on 64-bit indices: J's pattern is copied to long.
class QrCovariance : public CovarianceFactor {
 public:
  explicit QrCovariance(const Csc& j) {
    cholmod_l_start(&cc_);
    cc_.print = 0;
    cc_.error_handler = nullptr;
    n_ = j.cols;
    colptr_.assign(j.colptr.begin(), j.colptr.end());
    rowind_.assign(j.rowind.begin(), j.rowind.end());
    cholmod_sparse a;
    std::memset(&a, 0, sizeof(a));
    a.nrow = j.rows;
    a.ncol = j.cols;
    a.nzmax = j.colptr[j.cols];
    a.p = colptr_.data();
    a.i = rowind_.data();
    a.x = const_cast<double*>(j.values.data());
    a.itype = CHOLMOD_LONG;
    a.xtype = CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    try {
      Factorize(&a);
    } catch (...) {
      Release();  // a constructor that throws runs no destructor
      throw;
    }
  }

  void Release() {
    if (qr_) SuiteSparseQR_free<double>(&qr_, &cc_);
    cholmod_l_finish(&cc_);
  }

  void Factorize(cholmod_sparse* ap) {
    cholmod_sparse& a = *ap;
    qr_ = SuiteSparseQR_symbolic<double>(SPQR_ORDERING_DEFAULT, 1, &a, &cc_);
    if (qr_ == nullptr) throw Error("SuiteSparseQR could not analyse J (status " + std::to_string(cc_.status) + ")");
    const Clock::time_point t0 = Clock::now();
    const bool ok = SuiteSparseQR_numeric<double>(SPQR_DEFAULT_TOL, &a, qr_, &cc_);
    factorize_seconds_ = SecondsSince(t0);
    if (!ok) throw Error("SuiteSparseQR could not factorise J (status " + std::to_string(cc_.status) + ")");
    if (qr_->rank < n_) {
      throw RankDeficientError("H is singular: the QR factorisation of J has rank " + std::to_string(qr_->rank) +
                               " of " + std::to_string(n_) +
                               ", so some direction is determined by no factor (a free gauge, a landmark seen too "
                               "few times, a part of the graph not connected to a held variable); hold a variable "
                               "fixed or add a prior (linear solver cholmod names the variable)");
    }
  }
  ~QrCovariance() override { Release(); }
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& b) override {
    cholmod_dense bd = DenseView(const_cast<double*>(b.data()), b.rows(), b.cols());
    // R^T y = E^T b, then x = E R^-1 y.
    cholmod_dense* y = SuiteSparseQR_solve<double>(SPQR_RTX_EQUALS_ETB, qr_, &bd, &cc_);
    cholmod_dense* x = y ? SuiteSparseQR_solve<double>(SPQR_RETX_EQUALS_B, qr_, y, &cc_) : nullptr;
    if (y) cholmod_l_free_dense(&y, &cc_);
    if (x == nullptr) throw Error("SuiteSparseQR could not solve (status " + std::to_string(cc_.status) + ")");
    Eigen::MatrixXd out = Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x->x), b.rows(), b.cols());
    cholmod_l_free_dense(&x, &cc_);
    return out;
  }
  std::string Description() const override { return "SuiteSparseQR, solves with R^T and R"; }

 private:
  cholmod_common cc_;
  SuiteSparseQR_factorization<double>* qr_ = nullptr;
  std::vector<SuiteSparse_long> colptr_, rowind_;
};

}  // namespace

std::unique_ptr<CovarianceFactor> MakeLdltCovariance(const Csc& h, const ColumnNamer& name) {
  return std::make_unique<LdltCovariance>(h, name);
}
std::unique_ptr<CovarianceFactor> MakeQrCovariance(const Csc& j, const ColumnNamer&) {
  return std::make_unique<QrCovariance>(j);
}

}  // namespace internal
}  // namespace tether
