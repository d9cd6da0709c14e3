#pragma once
// Internal: a factorisation of H (or of J) that answers blocks of H^-1, for Marginals
// (tether/solvers/covariance.h). One implementation per linear solver name.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "problem.h"

namespace tether {
namespace internal {

class CovarianceFactor {
 public:
  virtual ~CovarianceFactor() = default;
  /// X = H^-1 B for a dense n x k B.
  virtual Eigen::MatrixXd Solve(const Eigen::MatrixXd& b) = 0;
  /// The diagonal blocks H^-1[o, o + d) x [o, o + d) for the given column offsets and sizes.
  /// The default solves against the blocks' columns of the identity, many at once.
  virtual std::vector<Eigen::MatrixXd> DiagonalBlocks(const std::vector<int>& offsets, const std::vector<int>& dims);
  virtual std::string Description() const = 0;
  int n() const { return n_; }
  double factorize_seconds() const { return factorize_seconds_; }

 protected:
  int n_ = 0;
  double factorize_seconds_ = 0;
};

/// Names the variable of a column of H and the coordinate within it, for messages:
/// "variable 12 (SE2), tangent coordinate 2".
using ColumnNamer = std::function<std::string(int column)>;

/// Factorisations of the upper triangle of H (cholmod, ldlt) or of J (qr). Each throws
/// RankDeficientError, naming the column's variable where it can, when H is singular.
std::unique_ptr<CovarianceFactor> MakeCholmodCovariance(const Csc& h, const ColumnNamer& name);
std::unique_ptr<CovarianceFactor> MakeLdltCovariance(const Csc& h, const ColumnNamer& name);
std::unique_ptr<CovarianceFactor> MakeQrCovariance(const Csc& j, const ColumnNamer& name);

}  // namespace internal
}  // namespace tether
