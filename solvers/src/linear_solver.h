#pragma once
// Internal: sparse linear solvers behind one interface. The pattern is analysed once
// (Analyze) and every later Factorize reuses that analysis.
#include <memory>
#include <string>

#include "problem.h"
#include "tether/solvers/solver_options.h"

namespace tether {
namespace internal {

enum class FactorResult { kOk, kNotPositiveDefinite, kRankDeficient, kFailed };

/// Solves H x = b for symmetric positive definite H given by its upper triangle.
class SparseCholesky {
 public:
  virtual ~SparseCholesky() = default;
  virtual void Analyze(const Csc& h) = 0;
  virtual FactorResult Factorize(const Csc& h) = 0;
  /// x = H^-1 b (both of length n).
  virtual void Solve(const double* b, double* x) = 0;
  /// Name of the BLAS or back-end in use, for reports.
  virtual std::string Description() const = 0;
};

std::unique_ptr<SparseCholesky> MakeCholmod();
std::unique_ptr<SparseCholesky> MakeEigenLDLT();

/// Least squares min |J x - b| for a tall sparse J (SuiteSparseQR).
class SparseQR {
 public:
  virtual ~SparseQR() = default;
  virtual void Analyze(const Csc& j) = 0;
  virtual FactorResult Factorize(const Csc& j) = 0;
  virtual void Solve(const double* b, double* x) = 0;
};

std::unique_ptr<SparseQR> MakeSpqr();

}  // namespace internal
}  // namespace tether
