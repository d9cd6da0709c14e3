// CHOLMOD supernodal Cholesky (and SuiteSparseQR) wrappers.
#include <cholmod.h>

#include <SuiteSparseQR.hpp>
#include <cstring>
#include <utility>
#include <vector>

#include "backend_functions.h"
#include "builtin_linear_solvers.h"
#include "cholmod_views.h"
#include "serial_openmp.h"
#include "tether/core/error.h"

namespace tether {
namespace internal {

namespace {

class Cholmod : public LinearSolver {
 public:
  explicit Cholmod(std::vector<int> ordering) : ordering_(std::move(ordering)) {
    cholmod_start(&cc_);
    // CHOLMOD picks supernodal (dense BLAS blocks) or simplicial from the analysis (flops per
    // non-zero of L): simplicial factorises the sparse 2D graphs 2.5-3.5 times faster (intel
    // 2.5 -> 0.95 ms, ais2klinik 17 -> 5 ms), supernodal stays on for the denser ones
    // (sphere2500, a 10k-pose manhattan); benchmarks/RESULTS.md has the measurements.
    cc_.supernodal = CHOLMOD_AUTO;
    cc_.print = 0;
    cc_.error_handler = nullptr;
    cc_.quick_return_if_not_posdef = 1;
  }
  ~Cholmod() override {
    if (L_) cholmod_free_factor(&L_, &cc_);
    if (X_) cholmod_free_dense(&X_, &cc_);
    if (Y_) cholmod_free_dense(&Y_, &cc_);
    if (E_) cholmod_free_dense(&E_, &cc_);
    cholmod_finish(&cc_);
  }
  void Analyze(const SparseMatrixView& h, const std::vector<int>&) override {
    SerialOpenMp serial;
    cholmod_sparse a = CholmodView(h, 1);
    if (L_) cholmod_free_factor(&L_, &cc_);
    if (ordering_.size() == static_cast<std::size_t>(h.cols)) {
      // An ordering found already (by the block analysis, on the variables' blocks): CHOLMOD
      // takes it instead of ordering the scalar graph again.
      cc_.nmethods = 1;
      cc_.method[0].ordering = CHOLMOD_GIVEN;
      L_ = cholmod_analyze_p(&a, ordering_.data(), nullptr, 0, &cc_);
    } else {
      L_ = cholmod_analyze(&a, &cc_);
    }
    if (L_ == nullptr || cc_.status < CHOLMOD_OK) {
      throw Error("CHOLMOD could not analyse the normal equations (status " + std::to_string(cc_.status) +
                  "); try --linear ldlt");
    }
    n_ = h.cols;
  }
  // No operation counts (factorize_flops, solve_flops): CHOLMOD keeps the reuse of an earlier
  // factorisation at the given maximum. Its conjugate gradients also refine the steps of badly
  // conditioned systems: on Victoria Park read as covariances (landmarks and poses, CHOLMOD),
  // LM with every step factorised stalls 1.7e-6 above the optimum and Gauss-Newton cannot move
  // from there, where with the reuse both reach it.
  LinearSolverStatus Factorize(const SparseMatrixView& h) override {
    cholmod_sparse a = CholmodView(h, 1);
    {
      SerialOpenMp serial;
      cholmod_factorize(&a, L_, &cc_);
    }
    if (cc_.status == CHOLMOD_NOT_POSDEF || L_->minor < L_->n) return LinearSolverStatus::kNotPositiveDefinite;
    if (cc_.status < CHOLMOD_OK) return LinearSolverStatus::kFailed;
    if (!L_->is_super && !L_->is_ll) {
      // A simplicial LDL^T succeeds on indefinite matrices too; the solvers need positive
      // definite ones. D sits on the diagonal, the first entry of each column.
      const double* x = static_cast<const double*>(L_->x);
      const int* p = static_cast<const int*>(L_->p);
      for (std::size_t j = 0; j < L_->n; ++j) {
        if (!(x[p[j]] > 0)) return LinearSolverStatus::kNotPositiveDefinite;
      }
    }
    return LinearSolverStatus::kOk;
  }
  LinearSolverStatus Solve(const double* b, double* x) override {
    SerialOpenMp serial;
    cholmod_dense bd = DenseView(const_cast<double*>(b), n_);
    if (!cholmod_solve2(CHOLMOD_A, L_, &bd, nullptr, &X_, nullptr, &Y_, &E_, &cc_) || X_ == nullptr) {
      throw Error("CHOLMOD could not solve (status " + std::to_string(cc_.status) + "); try --linear ldlt");
    }
    std::memcpy(x, X_->x, sizeof(double) * n_);
    return LinearSolverStatus::kOk;
  }
  std::string Description() const override {
    return L_ != nullptr && !L_->is_super ? "CHOLMOD simplicial" : "CHOLMOD supernodal";
  }

 private:
  cholmod_common cc_;
  cholmod_factor* L_ = nullptr;
  cholmod_dense *X_ = nullptr, *Y_ = nullptr, *E_ = nullptr;
  int n_ = 0;
  std::vector<int> ordering_;  // a fill-reducing ordering of the columns given at construction
};

// SuiteSparseQR's C++ interface works on 64-bit indices (cholmod_l_*): the pattern is
// copied to long once at Analyze, the values are borrowed every time.
class Spqr : public LinearSolver {
 public:
  Spqr() {
    cholmod_l_start(&cc_);
    cc_.print = 0;
    cc_.error_handler = nullptr;
  }
  ~Spqr() override {
    if (qr_) SuiteSparseQR_free<double>(&qr_, &cc_);
    cholmod_l_finish(&cc_);
  }
  void Analyze(const SparseMatrixView& j, const std::vector<int>&) override {
    colptr_.assign(j.colptr, j.colptr + j.cols + 1);
    rowind_.assign(j.rowind, j.rowind + j.colptr[j.cols]);
    cholmod_sparse a = View(j);
    // allow_tol = 1: columns below SPQR's default tolerance count as dependent, so rank
    // deficiency is detected instead of turning into enormous steps.
    qr_ = SuiteSparseQR_symbolic<double>(SPQR_ORDERING_DEFAULT, 1, &a, &cc_);
    if (qr_ == nullptr) {
      throw Error("SuiteSparseQR could not analyse the Jacobian (status " + std::to_string(cc_.status) +
                  "); try --linear cholmod");
    }
    rows_ = j.rows;
    cols_ = j.cols;
  }
  LinearSolverStatus Factorize(const SparseMatrixView& j) override {
    cholmod_sparse a = View(j);
    if (!SuiteSparseQR_numeric<double>(SPQR_DEFAULT_TOL, &a, qr_, &cc_)) return LinearSolverStatus::kFailed;
    if (qr_->rank < cols_) return LinearSolverStatus::kRankDeficient;
    return LinearSolverStatus::kOk;
  }
  LinearSolverStatus Solve(const double* b, double* x) override {
    cholmod_dense bd = DenseView(const_cast<double*>(b), rows_);
    cholmod_dense* y = SuiteSparseQR_qmult<double>(SPQR_QTX, qr_, &bd, &cc_);
    cholmod_dense* sol = y ? SuiteSparseQR_solve<double>(SPQR_RETX_EQUALS_B, qr_, y, &cc_) : nullptr;
    if (sol == nullptr) {
      if (y) cholmod_l_free_dense(&y, &cc_);
      throw Error("SuiteSparseQR could not solve (status " + std::to_string(cc_.status) + "); try --linear cholmod");
    }
    std::memcpy(x, sol->x, sizeof(double) * cols_);
    cholmod_l_free_dense(&y, &cc_);
    cholmod_l_free_dense(&sol, &cc_);
    return LinearSolverStatus::kOk;
  }
  std::string Description() const override { return "SuiteSparseQR"; }

 private:
  cholmod_sparse View(const SparseMatrixView& j) {
    cholmod_sparse a = CholmodView(j, 0);
    a.p = colptr_.data();
    a.i = rowind_.data();
    a.itype = CHOLMOD_LONG;
    return a;
  }
  cholmod_common cc_;
  SuiteSparseQR_factorization<double>* qr_ = nullptr;
  std::vector<SuiteSparse_long> colptr_, rowind_;
  int rows_ = 0, cols_ = 0;
};

}  // namespace
}  // namespace internal

namespace backends {

std::unique_ptr<LinearSolver> MakeCholmod(std::vector<int> ordering) {
  return std::make_unique<internal::Cholmod>(std::move(ordering));
}
std::unique_ptr<LinearSolver> MakeSpqr() { return std::make_unique<internal::Spqr>(); }

}  // namespace backends
}  // namespace tether
