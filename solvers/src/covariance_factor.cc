// Covariances by solves against columns of the identity (the default of CovarianceFactor),
// and the factorisation behind "ldlt" (Eigen's SimplicialLDLT of H). "cholmod" and "qr" are
// in the back-end module (solvers/backends).
#include "covariance_factor.h"

#include <Eigen/SparseCholesky>

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

}  // namespace

std::unique_ptr<CovarianceFactor> MakeLdltCovariance(const Csc& h, const ColumnNamer& name) {
  return std::make_unique<LdltCovariance>(h, name);
}

}  // namespace internal
}  // namespace tether
