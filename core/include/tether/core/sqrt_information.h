#pragma once
// A Gaussian noise model kept as the square root of its information matrix.
//
// Information Omega = R^T R with R upper triangular (Cholesky). Whitening maps an error e
// to R e, so that chi2 = e^T Omega e = |R e|^2. Dimensions up to 6 are stored inline.
#include <Eigen/Core>
#include <string>

namespace tether {

constexpr int kMaxResidualDim = 6;

class SqrtInformation {
 public:
  SqrtInformation() = default;

  /// From an information matrix. Throws InvalidArgument (with `why` filled when given) if it
  /// is not symmetric positive definite or holds NaN/inf.
  static SqrtInformation FromInformation(const Eigen::MatrixXd& omega);
  /// Returns false (and says why) instead of throwing.
  static bool TryFromInformation(const Eigen::MatrixXd& omega, SqrtInformation* out, std::string* why);
  /// Identity information of the given dimension (unit noise).
  static SqrtInformation Identity(int dim);
  /// Isotropic: Omega = I / sigma^2.
  static SqrtInformation Isotropic(int dim, double sigma);

  int dim() const { return dim_; }
  /// The information matrix R^T R.
  Eigen::MatrixXd Information() const;
  /// The upper-triangular square root R.
  Eigen::MatrixXd R() const;

  /// In-place whitening of a vector of length dim(): v <- R v.
  void WhitenVector(double* v) const;
  /// In-place whitening of a row-major dim() x cols block: J <- R J.
  void WhitenRowMajor(double* j, int cols) const;

 private:
  int dim_ = 0;
  double r_[kMaxResidualDim * kMaxResidualDim] = {};  // row-major, upper triangle used
};

/// How non-positive-definite information matrices in input files are treated.
enum class InformationRepair {
  kNone,       ///< an error naming file:line (default)
  kNearestPD,  ///< eigenvalues clamped up to a small positive floor (nearest PD in Frobenius norm)
  kIsotropic,  ///< replaced by (trace / n) * I, or I where the trace is not positive
};
const char* ToString(InformationRepair r);
bool FromString(const std::string& s, InformationRepair* r);

/// Repairs omega in place according to mode; returns true if it was changed.
bool RepairInformation(InformationRepair mode, Eigen::MatrixXd* omega);

}  // namespace tether
