#include "linear_system.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "builtin_linear_solvers.h"
#include "tether/core/error.h"
#include "tether/core/timing.h"

namespace tether {
namespace internal {

namespace {

using Clock = std::chrono::steady_clock;

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

}  // namespace

LinearSystem::LinearSystem(Problem* p, const LinearSolverEntry& entry, const LinearSolverOptions& options,
                           std::unique_ptr<LinearSolver> solver, bool split, std::vector<char> damped)
    : p_(p),
      form_(entry.form),
      exact_(entry.direct),
      solver_(std::move(solver)),
      split_(split),
      damped_(std::move(damped)) {
  const int n = p->tangent_dim();
  g_.assign(n, 0.0);
  diag_.assign(n, 0.0);
  // The earlier factorisation preconditions later steps only where it is an exact inverse of
  // an earlier H (a direct solver on the normal equations).
  const bool normal = form_ == LinearSystemForm::kNormalEquations;
  if (normal) {
    p->BuildNormalStructure(&mat_, &damping_pos_);
    undamped_diag_.assign(n, 0.0);
    neg_g_.assign(n, 0.0);
  } else {
    p->BuildJacobianStructure(&mat_, &damping_pos_);
    rhs_.assign(mat_.rows, 0.0);
    jx_.assign(mat_.rows, 0.0);
  }
  for (std::vector<double>* v : {&r_, &z_, &p_dir_, &hp_}) v->assign(n, 0.0);
  if (!solver_) solver_ = entry.make(options);
  if (!solver_) throw Error("linear solver '" + entry.name + "' (owner '" + entry.owner + "') made no solver");
  group_ = solver_->processes();
  if (split_ && (group_ == nullptr || !normal))
    throw Error("a split problem needs a solver of the normal equations that spans processes");
  if (split_ && damped_.size() != static_cast<std::size_t>(n)) throw Error("a split problem needs its damped columns");
  solver_->Analyze(View(mat_), p->BlockSizes());
  if (normal && exact_) {
    reuse_ = options.max_reuse_iterations > 0;
    max_reuse_iterations_ = options.max_reuse_iterations;
    ReuseWhileCheaper(solver_->factorize_flops(), solver_->solve_flops(), 4.0 * static_cast<double>(mat_.values.size()),
                      &reuse_, &max_reuse_iterations_);
  }
}

// A reused factorisation costs two solves and a product with H before the first iteration,
// then one of each per iteration; factorising afresh costs a factorisation and a solve. So a
// reuse that converges after k iterations is the cheaper only while
//   (2 + k) s + (1 + k) m < f + s,  i.e.  k < (f - s - m) / (s + m),
// and the iterations stop there. Where not even k = 1 would be cheaper, no reuse is tried: the
// tries that converge at once are too few to pay for those that do not (ais2klinik: 5 tries in
// 6 steps, none converged; the whole run 6% faster without them). The operation counts
// predict the times: on the public files the ratio f / s of the block Cholesky's estimates is
// within 25% of the measured one (intel 4.9 for 4.2, ais2klinik 3.2 for 3.3, M3500 9.3 for
// 6.9); CHOLMOD's supernodal BLAS runs its factorisation faster than its count would say
// (sphere2500 65 for 19), and gives no counts (cholmod_solver.cc says why). Where not even one
// iteration can pay (the sparse 2D factors: MIT, CSAIL, ais2klinik, kitti_00), every step
// factorises; elsewhere up to intel 2, M3500 5, parking-garage 7 iterations.
void ReuseWhileCheaper(double f, double s, double m, bool* reuse, int* max_iterations) {
  if (!(f > 0) || !(s > 0)) return;  // not known: as given
  const double cap = std::floor((f - s - m) / (s + m));
  if (cap < 1) *reuse = false;
  *max_iterations = static_cast<int>(std::min<double>(*max_iterations, std::max(0.0, cap)));
}

void LinearSystem::Assemble() {
  ++assemblies_;
  lambda_ = 0;
  if (form_ == LinearSystemForm::kJacobian) {
    p_->Gradient(g_.data(), diag_.data());
    p_->AssembleJacobian(&mat_, rhs_.data());
    return;
  }
  p_->AssembleNormal(&mat_, g_.data());
  for (std::size_t i = 0; i < damping_pos_.size(); ++i) {
    undamped_diag_[i] = mat_.values[damping_pos_[i]];
    diag_[i] = undamped_diag_[i];
  }
  // Where the solve spans processes: g and diag(H) whole and one on every process.
  Total(g_.data(), static_cast<int>(g_.size()));
  Total(diag_.data(), static_cast<int>(diag_.size()));
  for (std::size_t i = 0; i < g_.size(); ++i) neg_g_[i] = -g_[i];
}

void LinearSystem::Total(double* values, int n) const {
  if (group_ == nullptr) return;
  if (split_) group_->Sum(values, n);
  group_->Broadcast(values, n);
}

double LinearSystem::ClampedDiag(std::size_t i) const { return std::clamp(diag_[i], 1e-6, 1e32); }

void LinearSystem::ApplyDamping(double lambda) {
  lambda_ = lambda;
  for (std::size_t i = 0; i < damping_pos_.size(); ++i) {
    const double d = ClampedDiag(i);
    if (form_ == LinearSystemForm::kJacobian) {
      mat_.values[damping_pos_[i]] = std::sqrt(lambda * d);
    } else {
      // Split between processes: the damping goes into the share of the variable's owner only.
      mat_.values[damping_pos_[i]] = !split_ || damped_[i] ? undamped_diag_[i] + lambda * d : undamped_diag_[i];
    }
  }
}

LinearSolverStatus LinearSystem::Solve(double lambda, std::vector<double>* delta, IterationSummary* it) {
  const Clock::time_point ts = Clock::now();
  ApplyDamping(lambda);
  it->cg_iterations = 0;
  it->reused_factorization = have_factor_ && reuse_ && Pcg(delta, &it->cg_iterations);
  if (have_factor_ && reuse_) {
    // Whether to factorise afresh is a collective decision where the solver spans processes.
    double reused = it->reused_factorization ? 1.0 : 0.0;
    Agree(&reused, 1);
    it->reused_factorization = reused != 0;
    if (it->reused_factorization) Agree(delta->data(), static_cast<int>(delta->size()));
  }
  LinearSolverStatus r = LinearSolverStatus::kOk;
  double factorize = 0;
  if (!it->reused_factorization) {
    it->cg_iterations = 0;
    const Clock::time_point tf = Clock::now();
    r = solver_->Factorize(View(mat_));
    factorize = SecondsSince(tf);
    if (form_ == LinearSystemForm::kNormalEquations) have_factor_ = r == LinearSolverStatus::kOk;
    if (r == LinearSolverStatus::kOk) {
      r = solver_->Solve(form_ == LinearSystemForm::kJacobian ? rhs_.data() : neg_g_.data(), delta->data());
      stats_.iterative_iterations += solver_->last_iterations();
    }
    ++stats_.factorizations;
    stats_.last_factorize_seconds = factorize;
  }
  stats_.solve_seconds += SecondsSince(ts) - factorize;
  stats_.factorize_seconds += factorize;
  if (r == LinearSolverStatus::kOk) {
    double step2 = 0;
    for (double d : *delta) step2 += d * d;
    // A numerically singular system can factorise and still give a non-finite step.
    if (!std::isfinite(step2)) r = LinearSolverStatus::kRankDeficient;
  }
  return r;
}

double LinearSystem::ScaledSquaredNorm(const std::vector<double>& d) const {
  double dDd = 0;
  for (std::size_t i = 0; i < d.size(); ++i) dDd += d[i] * d[i] * ClampedDiag(i);
  Agree(&dDd, 1);
  return dDd;
}

double LinearSystem::PredictedDecrease(const std::vector<double>& d, double lambda, double dDd, bool reused) {
  double decrease = 0;
  if (!reused && exact_) {
    decrease = -Dot(g_, d) + lambda * dDd;
  } else if (form_ == LinearSystemForm::kJacobian) {
    MultiplyJtJ(d, &hp_);  // undamped
    decrease = -2 * Dot(g_, d) - Dot(d, hp_);
  } else {
    MultiplyWholeH(d, &hp_);  // (H + lambda D) d
    decrease = -2 * Dot(g_, d) - (Dot(d, hp_) - lambda * dDd);
  }
  Agree(&decrease, 1);
  return decrease;
}

void LinearSystem::MultiplyUndamped(const std::vector<double>& x, std::vector<double>* y) {
  if (form_ == LinearSystemForm::kJacobian) {
    MultiplyJtJ(x, y);
    return;
  }
  MultiplyWholeH(x, y);
  if (lambda_ != 0) {
    for (std::size_t i = 0; i < x.size(); ++i) (*y)[i] -= lambda_ * ClampedDiag(i) * x[i];
  }
  Agree(y->data(), static_cast<int>(y->size()));
}

void LinearSystem::MultiplyWholeH(const std::vector<double>& x, std::vector<double>* y) const {
  MultiplyH(x, y);
  if (split_) Total(y->data(), static_cast<int>(y->size()));
}

void LinearSystem::MultiplyH(const std::vector<double>& x, std::vector<double>* y) const {
  std::fill(y->begin(), y->end(), 0.0);
  double* out = y->data();
  for (int c = 0; c < mat_.cols; ++c) {
    const double xc = x[c];
    double acc = 0;
    for (int k = mat_.colptr[c]; k < mat_.colptr[c + 1]; ++k) {
      const int r = mat_.rowind[k];
      const double v = mat_.values[k];
      if (r > c) continue;
      if (r == c) {
        acc += v * xc;
      } else {
        out[r] += v * xc;
        acc += v * x[r];
      }
    }
    out[c] += acc;
  }
}

void LinearSystem::MultiplyJtJ(const std::vector<double>& x, std::vector<double>* y) {
  const int m = mat_.rows - mat_.cols;  // the damping rows follow the residual rows
  std::fill(jx_.begin(), jx_.end(), 0.0);
  for (int c = 0; c < mat_.cols; ++c) {
    for (int k = mat_.colptr[c]; k < mat_.colptr[c + 1]; ++k) {
      if (mat_.rowind[k] < m) jx_[mat_.rowind[k]] += mat_.values[k] * x[c];
    }
  }
  for (int c = 0; c < mat_.cols; ++c) {
    double s = 0;
    for (int k = mat_.colptr[c]; k < mat_.colptr[c + 1]; ++k) {
      if (mat_.rowind[k] < m) s += mat_.values[k] * jx_[mat_.rowind[k]];
    }
    (*y)[c] = s;
  }
}

// Conjugate gradients on H delta = -g, preconditioned with the factorisation of an earlier
// H (close to this one once the steps are small), started from that factorisation's solve.
// Converged when the error's H-norm, estimated by sqrt(r^T M^-1 r), is below
// kReuseTolerance times the step's, sqrt(b^T M^-1 b): the linear model's decrease is then
// exact to kReuseTolerance^2. False (delta unusable) when the start is too far off to be
// worth iterating (error above kTryRatio^(1/2) of the step in that norm: H has moved too
// far since the factorisation), when the tolerance is not reached within
// max_reuse_iterations_, when the residual shrinks too slowly to reach it in time, or on a
// curvature that is not positive.
bool LinearSystem::Pcg(std::vector<double>* delta, int* iterations) {
  constexpr double kReuseTolerance = 1e-3;
  constexpr double kTryRatio = 1e-2;
  constexpr double kDiagonalGate = 0.3;
  std::vector<double>& x = *delta;
  const std::size_t n = x.size();
  solver_->Solve(neg_g_.data(), x.data());  // x0 = M^-1 b
  const double bMb = Dot(neg_g_, x);
  if (!(bMb > 0) || !std::isfinite(bMb)) return false;
  MultiplyWholeH(x, &hp_);
  // A first look without another solve: the same ratio with diag(H) in place of M. On the
  // public files it is within about 30x of the true one, so far above the gate it spares
  // the solve below (the steps from a rough start).
  double rDr = 0, bDb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    r_[i] = neg_g_[i] - hp_[i];
    const double d = diag_[i] + lambda_ * ClampedDiag(i);  // H + lambda D's diagonal, whole
    rDr += r_[i] * r_[i] / d;
    bDb += neg_g_[i] * neg_g_[i] / d;
  }
  if (!(rDr <= kDiagonalGate * bDb)) return false;
  solver_->Solve(r_.data(), z_.data());
  double rz = Dot(r_, z_);
  const double target = kReuseTolerance * kReuseTolerance * bMb;
  if (!std::isfinite(rz)) return false;
  if (rz <= target) return true;
  if (rz > kTryRatio * bMb) return false;
  p_dir_ = z_;
  const double rz0 = rz;
  for (int k = 1; k <= max_reuse_iterations_; ++k) {
    *iterations = k;
    MultiplyWholeH(p_dir_, &hp_);
    const double curvature = Dot(p_dir_, hp_);
    if (!(curvature > 0) || !std::isfinite(curvature)) return false;
    const double alpha = rz / curvature;
    for (std::size_t i = 0; i < n; ++i) {
      x[i] += alpha * p_dir_[i];
      r_[i] -= alpha * hp_[i];
    }
    solver_->Solve(r_.data(), z_.data());
    const double rz_new = Dot(r_, z_);
    if (!std::isfinite(rz_new)) return false;
    if (rz_new <= target) return true;
    // At the mean rate so far, would the remaining iterations get there?
    const double rate = std::pow(rz_new / rz0, 1.0 / k);
    if (!(rate < 1) || rz_new * std::pow(rate, max_reuse_iterations_ - k) > target) return false;
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::size_t i = 0; i < n; ++i) p_dir_[i] = z_[i] + beta * p_dir_[i];
  }
  return false;
}

}  // namespace internal
}  // namespace tether
