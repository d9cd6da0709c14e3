// Eigen's SimplicialLDLT: the dependency-light Cholesky path.
#include <Eigen/SparseCholesky>

#include "linear_solver.h"

namespace tether {
namespace internal {

namespace {

class EigenLDLT : public SparseCholesky {
 public:
  using Map = Eigen::Map<const Eigen::SparseMatrix<double, Eigen::ColMajor, int>>;

  void Analyze(const Csc& h) override { solver_.analyzePattern(View(h)); }
  FactorResult Factorize(const Csc& h) override {
    solver_.factorize(View(h));
    // Eigen reports a zero pivot (a singular matrix) as NumericalIssue.
    if (solver_.info() == Eigen::NumericalIssue) return FactorResult::kNotPositiveDefinite;
    if (solver_.info() != Eigen::Success) return FactorResult::kFailed;
    // LDL^T succeeds on indefinite matrices; the solvers need positive definite ones.
    if (!(solver_.vectorD().minCoeff() > 0)) return FactorResult::kNotPositiveDefinite;
    return FactorResult::kOk;
  }
  void Solve(const double* b, double* x) override {
    const int n = static_cast<int>(solver_.rows());
    Eigen::Map<Eigen::VectorXd>(x, n) = solver_.solve(Eigen::Map<const Eigen::VectorXd>(b, n));
  }
  std::string Description() const override { return "Eigen SimplicialLDLT"; }

 private:
  static Map View(const Csc& h) {
    return Map(h.rows, h.cols, static_cast<int>(h.values.size()), h.colptr.data(), h.rowind.data(), h.values.data());
  }
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double, Eigen::ColMajor, int>, Eigen::Upper> solver_;
};

}  // namespace

std::unique_ptr<SparseCholesky> MakeEigenLDLT() { return std::make_unique<EigenLDLT>(); }

}  // namespace internal
}  // namespace tether
