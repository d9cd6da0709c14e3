// Eigen's SimplicialLDLT: the dependency-light Cholesky path.
#include <Eigen/SparseCholesky>

#include "builtin_linear_solvers.h"

namespace tether {
namespace internal {

namespace {

class EigenLDLT : public LinearSolver {
 public:
  using Map = Eigen::Map<const Eigen::SparseMatrix<double, Eigen::ColMajor, int>>;

  void Analyze(const SparseMatrixView& h, const std::vector<int>&) override { solver_.analyzePattern(View(h)); }
  LinearSolverStatus Factorize(const SparseMatrixView& h) override {
    solver_.factorize(View(h));
    // Eigen reports a zero pivot (a singular matrix) as NumericalIssue.
    if (solver_.info() == Eigen::NumericalIssue) return LinearSolverStatus::kNotPositiveDefinite;
    if (solver_.info() != Eigen::Success) return LinearSolverStatus::kFailed;
    // LDL^T succeeds on indefinite matrices; the solvers need positive definite ones.
    if (!(solver_.vectorD().minCoeff() > 0)) return LinearSolverStatus::kNotPositiveDefinite;
    return LinearSolverStatus::kOk;
  }
  LinearSolverStatus Solve(const double* b, double* x) override {
    const int n = static_cast<int>(solver_.rows());
    Eigen::Map<Eigen::VectorXd>(x, n) = solver_.solve(Eigen::Map<const Eigen::VectorXd>(b, n));
    return LinearSolverStatus::kOk;
  }
  std::string Description() const override { return "Eigen SimplicialLDLT"; }

 private:
  static Map View(const SparseMatrixView& h) {
    return Map(h.rows, h.cols, h.colptr[h.cols], h.colptr, h.rowind, h.values);
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Upper> solver_;
};

}  // namespace

std::unique_ptr<LinearSolver> MakeEigenLDLT() { return std::make_unique<EigenLDLT>(); }

}  // namespace internal
}  // namespace tether
