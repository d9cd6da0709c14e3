// The factorisation behind covariances with "qr": SuiteSparseQR's R of J, so that
// H^-1 = E R^-1 R^-T E^T for the column permutation E.
#include <SuiteSparseQR.hpp>
#include <cstring>
#include <string>

#include "backend_functions.h"
#include "cholmod_views.h"
#include "covariance_factor.h"
#include "minimizer.h"
#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace internal {
namespace {

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
}  // namespace internal

std::unique_ptr<internal::CovarianceFactor> backends::MakeQrCovariance(const internal::Csc& j,
                                                                       const internal::ColumnNamer&) {
  return std::make_unique<internal::QrCovariance>(j);
}

}  // namespace tether
