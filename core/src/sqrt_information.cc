#include "tether/core/sqrt_information.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"

namespace tether {

namespace {

// The rule a refused matrix broke, and its numbers. Accepted: finite, symmetric, and every
// pivot of its Cholesky factor above kPivotFloor times the square root of its largest entry
// (a condition number up to about 1 / kPivotFloor^2 = 1e24).
constexpr double kPivotFloor = 1e-12;

std::string NotPositiveDefinite(const Eigen::Ref<const Eigen::MatrixXd>& omega) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (omega + omega.transpose()), Eigen::EigenvaluesOnly);
  const double lo = es.eigenvalues()(0), hi = es.eigenvalues()(es.eigenvalues().size() - 1);
  std::ostringstream s;
  s.precision(3);
  if (!(lo > 0)) {
    s << "information matrix is not positive definite (smallest eigenvalue " << lo << ", largest " << hi << ")";
  } else {
    s << "information matrix is singular to working precision: positive definite on paper (eigenvalues " << lo << " to "
      << hi << ", condition number " << hi / lo << "), but a pivot of its Cholesky factor falls below " << kPivotFloor
      << " times the square root of its largest entry (tether's limit, about condition number 1e24)";
  }
  return s.str();
}

}  // namespace

bool SqrtInformation::TryFromInformation(const Eigen::Ref<const Eigen::MatrixXd>& omega, SqrtInformation* out,
                                         std::string* why) {
  const int n = static_cast<int>(omega.rows());
  if (n < 1 || omega.cols() != n) {
    if (why)
      *why = "information matrix must be square with at least 1 row, got " + std::to_string(omega.rows()) + "x" +
             std::to_string(omega.cols());
    return false;
  }
  if (!omega.allFinite()) {
    if (why) *why = "information matrix holds NaN or inf";
    return false;
  }
  const double scale = omega.cwiseAbs().maxCoeff();
  if ((omega - omega.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(1.0, scale)) {
    if (why) *why = "information matrix is not symmetric";
    return false;
  }
  if (n > kInlineResidualDim) return FromLarge(omega, scale, out, why);
  // At most 6 x 6: matrices of that bounded size live on the stack (this runs for every
  // edge of a file that is read).
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kInlineResidualDim, kInlineResidualDim>;
  Eigen::LLT<Small> llt(omega);
  bool ok = llt.info() == Eigen::Success;
  if (ok) {
    // LLT succeeds on matrices that are only semidefinite up to rounding; insist on a
    // strictly positive pivot relative to the scale.
    const Small L = llt.matrixL();
    for (int i = 0; i < n; ++i) ok = ok && L(i, i) > kPivotFloor * std::sqrt(std::max(scale, 1e-300));
  }
  if (!ok) {
    if (why) *why = NotPositiveDefinite(omega);
    return false;
  }
  SqrtInformation r;
  r.Resize(n);
  const Small U = llt.matrixU();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) r.r_[i * n + j] = j >= i ? U(i, j) : 0.0;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kInlineResidualDim, kInlineResidualDim> rows =
      omega;
  r.KeepGiven(rows.data());
  *out = r;
  return true;
}

bool SqrtInformation::FromLarge(const Eigen::Ref<const Eigen::MatrixXd>& omega, double scale, SqrtInformation* out,
                                std::string* why) {
  const int n = static_cast<int>(omega.rows());
  Eigen::LLT<Eigen::MatrixXd> llt(omega);
  bool ok = llt.info() == Eigen::Success;
  const Eigen::MatrixXd U = llt.matrixU();
  for (int i = 0; ok && i < n; ++i) ok = U(i, i) > kPivotFloor * std::sqrt(std::max(scale, 1e-300));
  if (!ok) {
    if (why) *why = NotPositiveDefinite(omega);
    return false;
  }
  SqrtInformation r;
  r.Resize(n);
  double* d = r.data();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) d[i * n + j] = j >= i ? U(i, j) : 0.0;
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = omega;
  r.KeepGiven(rows.data());
  *out = std::move(r);
  return true;
}

void SqrtInformation::Resize(int dim, bool diagonal) {
  dim_ = dim;
  given_ = false;
  diagonal_ = diagonal && dim > kInlineResidualDim;
  std::fill(r_, r_ + kInlineResidualDim * kInlineResidualDim, 0.0);
  std::fill(given_diag_, given_diag_ + kInlineResidualDim, 0.0);
  const std::size_t n = static_cast<std::size_t>(dim);
  big_.assign(diagonal_ ? n : dim > kInlineResidualDim ? n * (n + 1) : 0, 0.0);
}

void SqrtInformation::KeepGiven(const double* omega) {
  const int n = dim_;
  double* d = data();
  double* diag = n <= kInlineResidualDim ? given_diag_ : big_.data() + static_cast<std::size_t>(n) * n;
  for (int i = 0; i < n; ++i) {
    diag[i] = omega[i * n + i];
    for (int j = i + 1; j < n; ++j) d[j * n + i] = omega[i * n + j];
  }
  given_ = true;
}

SqrtInformation SqrtInformation::FromSigmas(const Eigen::VectorXd& sigmas) {
  const int n = static_cast<int>(sigmas.size());
  if (n < 1) throw InvalidArgument("SqrtInformation::FromSigmas: give at least one sigma");
  SqrtInformation r;
  r.Resize(n, /*diagonal=*/true);
  for (int i = 0; i < n; ++i) {
    if (!(sigmas[i] > 0) || !std::isfinite(sigmas[i])) {
      std::ostringstream s;
      s << "SqrtInformation::FromSigmas: sigma of axis " << i << " is " << sigmas[i]
        << "; every sigma must be finite and positive";
      throw InvalidArgument(s.str());
    }
    r.SetDiagonal(i, 1.0 / sigmas[i]);
  }
  return r;
}

SqrtInformation SqrtInformation::FromInformation(const Eigen::Ref<const Eigen::MatrixXd>& omega) {
  SqrtInformation r;
  std::string why;
  if (!TryFromInformation(omega, &r, &why)) throw InvalidArgument(why);
  return r;
}

SqrtInformation SqrtInformation::Identity(int dim) { return Isotropic(dim, 1.0); }

SqrtInformation SqrtInformation::Isotropic(int dim, double sigma) {
  if (dim < 1 || !(sigma > 0) || !std::isfinite(sigma)) {
    throw InvalidArgument("SqrtInformation::Isotropic: need dim >= 1 and a finite sigma > 0");
  }
  SqrtInformation r;
  r.Resize(dim, /*diagonal=*/true);
  for (int i = 0; i < dim; ++i) r.SetDiagonal(i, 1.0 / sigma);
  return r;
}

Eigen::MatrixXd SqrtInformation::R() const {
  if (diagonal_) return Eigen::Map<const Eigen::VectorXd>(big_.data(), dim_).asDiagonal();
  Eigen::MatrixXd m(dim_, dim_);
  for (int i = 0; i < dim_; ++i)
    for (int j = 0; j < dim_; ++j) m(i, j) = j >= i ? data()[i * dim_ + j] : 0.0;
  return m;
}

Eigen::MatrixXd SqrtInformation::Information() const {
  if (!given_) {
    const Eigen::MatrixXd r = R();
    return r.transpose() * r;
  }
  const int n = dim_;
  const double* d = data();
  const double* diag = n <= kInlineResidualDim ? given_diag_ : big_.data() + static_cast<std::size_t>(n) * n;
  Eigen::MatrixXd omega(n, n);
  for (int i = 0; i < n; ++i) {
    omega(i, i) = diag[i];
    for (int j = i + 1; j < n; ++j) omega(i, j) = omega(j, i) = d[j * n + i];
  }
  return omega;
}

namespace {

// M = R M for a row-major M of `dim` rows and `cols` columns, in place. R is upper
// triangular: row i only reads rows i..dim-1 of M, so top-down works. Where D and C are
// positive they are the sizes, known at compile time (those of the built-in factors), and the
// compiler unrolls the loops; the sums are the same, in the same order, either way.
template <int D, int C>
void Whiten(const double* r, int dim, double* m, int cols) {
  const int rows = D > 0 ? D : dim, n = C > 0 ? C : cols;
  for (int i = 0; i < rows; ++i) {
    for (int c = 0; c < n; ++c) {
      double s = 0;
      for (int j = i; j < rows; ++j) s += r[i * rows + j] * m[j * n + c];
      m[i * n + c] = s;
    }
  }
}

using WhitenFn = void (*)(const double*, int, double*, int);

// The kernel for `dim` rows and `cols` columns: the residual and Jacobian blocks of the
// built-in factors (SE2: 3 x 3; SE2 to a point: 2 x 3 and 2 x 2; SE3: 6 x 6; SE3 to a point:
// 3 x 6 and 3 x 3; residuals: dim x 1) have their own, anything else the general one.
WhitenFn KernelFor(int dim, int cols) {
  struct Entry {
    int dim, cols;
    WhitenFn fn;
  };
  static constexpr Entry kFixed[] = {{3, 1, Whiten<3, 1>}, {3, 3, Whiten<3, 3>}, {2, 1, Whiten<2, 1>},
                                     {2, 2, Whiten<2, 2>}, {2, 3, Whiten<2, 3>}, {6, 1, Whiten<6, 1>},
                                     {6, 6, Whiten<6, 6>}, {3, 6, Whiten<3, 6>}};
  for (const Entry& e : kFixed) {
    if (e.dim == dim && e.cols == cols) return e.fn;
  }
  return Whiten<0, 0>;
}

}  // namespace

void SqrtInformation::WhitenVector(double* v) const { WhitenRowMajor(v, 1); }

void SqrtInformation::WhitenRowMajor(double* m, int cols) const {
  if (diagonal_) {
    for (int i = 0; i < dim_; ++i) {
      const double d = big_[static_cast<std::size_t>(i)];
      for (int c = 0; c < cols; ++c) m[i * cols + c] *= d;
    }
    return;
  }
  KernelFor(dim_, cols)(data(), dim_, m, cols);
}

bool RepairInformation(InformationRepair mode, Eigen::MatrixXd* omega) {
  SqrtInformation tmp;
  if (SqrtInformation::TryFromInformation(*omega, &tmp, nullptr)) return false;
  if (mode == InformationRepair::kNone || !omega->allFinite()) return false;
  const int n = static_cast<int>(omega->rows());
  const Eigen::MatrixXd sym = 0.5 * (*omega + omega->transpose());
  if (mode == InformationRepair::kIsotropic) {
    const double mean = sym.trace() / n;
    *omega = (mean > 0 ? mean : 1.0) * Eigen::MatrixXd::Identity(n, n);
    return true;
  }
  // Nearest symmetric positive definite matrix in the Frobenius norm: keep the eigenvectors
  // and raise every eigenvalue to a floor relative to the largest one.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(sym);
  Eigen::VectorXd ev = es.eigenvalues();
  const double top = ev.cwiseAbs().maxCoeff();
  const double floor = std::max(top, 1.0) * 1e-9;
  for (int i = 0; i < n; ++i) ev(i) = std::max(ev(i), floor);
  *omega = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  *omega = 0.5 * (*omega + omega->transpose());
  return true;
}

}  // namespace tether
