#pragma once
// A Gaussian noise model kept as the square root of its information matrix.
//
// Information Omega = R^T R with R upper triangular (Cholesky). Whitening maps an error e
// to R e, so that chi2 = e^T Omega e = |R e|^2. Any dimension works; up to 6 (every
// built-in factor) R is stored inline, larger ones on the heap.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"

namespace tether {

/// Residual dimensions up to this are stored inline (no allocation per factor).
constexpr int kInlineResidualDim = 6;

class SqrtInformation {
 public:
  SqrtInformation() = default;

  /// From an information matrix. Throws InvalidArgument (with `why` filled when given) if it
  /// is not symmetric positive definite or holds NaN/inf.
  static SqrtInformation FromInformation(const Eigen::Ref<const Eigen::MatrixXd>& omega);
  /// Returns false (and says why) instead of throwing. A matrix of at most 6 x 6 in fixed
  /// storage (Eigen::Matrix<double, Dynamic, Dynamic, 0, 6, 6>) goes through without any
  /// allocation.
  static bool TryFromInformation(const Eigen::Ref<const Eigen::MatrixXd>& omega, SqrtInformation* out,
                                 std::string* why);
  /// Identity information of the given dimension (unit noise).
  static SqrtInformation Identity(int dim);
  /// Isotropic: Omega = I / sigma^2.
  static SqrtInformation Isotropic(int dim, double sigma);
  /// Diagonal, one standard deviation per axis: Omega = diag(1 / sigma_i^2). Throws
  /// InvalidArgument naming the axis where a sigma is not finite and positive.
  static SqrtInformation FromSigmas(const Eigen::VectorXd& sigmas);

  int dim() const { return dim_; }
  /// The information matrix: exactly the one given to FromInformation (so that a file's
  /// numbers are written back bit for bit), else R^T R.
  Eigen::MatrixXd Information() const;
  /// True where the information was given as a matrix (FromInformation) and is kept as given.
  bool has_given_information() const { return given_; }
  /// The upper-triangular square root R.
  Eigen::MatrixXd R() const;

  /// In-place whitening of a vector of length dim(): v <- R v.
  void WhitenVector(double* v) const;
  /// In-place whitening of a row-major dim() x cols block: J <- R J.
  void WhitenRowMajor(double* j, int cols) const;

 private:
  static bool FromLarge(const Eigen::Ref<const Eigen::MatrixXd>& omega, double scale, SqrtInformation* out,
                        std::string* why);
  const double* data() const { return dim_ <= kInlineResidualDim ? r_ : big_.data(); }
  double* data() { return dim_ <= kInlineResidualDim ? r_ : big_.data(); }
  void Resize(int dim, bool diagonal = false);
  // Sets R(i, i) of a fresh (Resize'd) diagonal or dense R.
  void SetDiagonal(int i, double v) { data()[diagonal_ ? i : i * dim_ + i] = v; }

  void KeepGiven(const double* omega_row_major);

  int dim_ = 0;
  // Row-major; R in the upper triangle. Where the information was given, its strict upper
  // triangle is kept (transposed) in R's unused strict lower triangle and its diagonal in
  // given_diag_ (inline) or after the n x n block (big_), so keeping it costs no allocation.
  double r_[kInlineResidualDim * kInlineResidualDim] = {};
  double given_diag_[kInlineResidualDim] = {};
  std::vector<double> big_;  // the same, for dim_ > kInlineResidualDim: n x n, then n diagonal entries
  bool given_ = false;
  // Above kInlineResidualDim, a diagonal R (FromSigmas, Isotropic) keeps only its n diagonal
  // entries in big_, and whitening scales rows: a scan-match factor has hundreds of rows, and a
  // dense R would cost n^2 storage and n^2 work per column.
  bool diagonal_ = false;
};

/// How non-positive-definite information matrices in input files are treated.
enum class InformationRepair {
  kNone,       ///< an error naming file:line (default)
  kNearestPD,  ///< eigenvalues clamped up to a small positive floor (nearest PD in Frobenius norm)
  kIsotropic,  ///< replaced by (trace / n) * I, or I where the trace is not positive
};
inline constexpr EnumName<InformationRepair> kInformationRepairNames[] = {{InformationRepair::kNone, "none"},
                                                                          {InformationRepair::kNearestPD, "nearest-pd"},
                                                                          {InformationRepair::kIsotropic, "isotropic"}};
constexpr const auto& EnumNames(InformationRepair) { return kInformationRepairNames; }

/// Repairs omega in place according to mode; returns true if it was changed.
bool RepairInformation(InformationRepair mode, Eigen::MatrixXd* omega);

}  // namespace tether
