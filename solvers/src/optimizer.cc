#include "tether/solvers/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "gauge.h"
#include "linear_solver.h"
#include "problem.h"
#include "tether/core/error.h"
#include "tether/solvers/ceres_adapter.h"

namespace tether {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

// Largest |a_i|; NaN if any entry is NaN (so that no tolerance test passes on NaN).
double MaxAbs(const std::vector<double>& a) {
  double m = 0;
  for (double v : a) {
    if (!(std::abs(v) <= m)) m = std::abs(v);
  }
  return m;
}

// One linear solve of the damped system, whichever back-end is in use.
class StepSolver {
 public:
  StepSolver(internal::Problem* p, LinearSolverType type, int max_reuse_iterations)
      : p_(p), type_(type), max_reuse_iterations_(type == LinearSolverType::kQR ? 0 : max_reuse_iterations) {
    const int n = p->tangent_dim();
    g_.assign(n, 0.0);
    diag_.assign(n, 0.0);
    if (type == LinearSolverType::kQR) {
      p->BuildJacobianStructure(&mat_, &damping_pos_);
      rhs_.assign(mat_.rows, 0.0);
      qr_ = internal::MakeSpqr();
      qr_->Analyze(mat_);
    } else {
      p->BuildNormalStructure(&mat_, &damping_pos_);
      chol_ = type == LinearSolverType::kCholmod ? internal::MakeCholmod() : internal::MakeEigenLDLT();
      chol_->Analyze(mat_);
      undamped_diag_.assign(n, 0.0);
      neg_g_.assign(n, 0.0);
      if (max_reuse_iterations_ > 0) {
        for (std::vector<double>* v : {&r_, &z_, &p_dir_, &hp_}) v->assign(n, 0.0);
      }
    }
  }

  /// After Problem::Linearize: builds H (or J) and the gradient for the current point.
  void Assemble() {
    if (type_ == LinearSolverType::kQR) {
      p_->Gradient(g_.data(), diag_.data());
      p_->AssembleJacobian(&mat_, rhs_.data());
    } else {
      p_->AssembleNormal(&mat_, g_.data());
      for (std::size_t i = 0; i < damping_pos_.size(); ++i) {
        undamped_diag_[i] = mat_.values[damping_pos_[i]];
        diag_[i] = undamped_diag_[i];
        neg_g_[i] = -g_[i];
      }
    }
  }

  /// delta solving (H + lambda D) delta = -g with D = clamp(diag(H)); the numeric
  /// factorisation's share of the time goes to *factorize_seconds. Where a factorisation of
  /// an earlier H exists, the system is first solved by conjugate gradients preconditioned
  /// with it (at most max_reuse_iterations); only if that does not converge is H factorised
  /// afresh. *reused: whether the earlier factorisation did; *cg_iterations: its iterations.
  internal::FactorResult Solve(double lambda, std::vector<double>* delta, double* factorize_seconds, bool* reused,
                               int* cg_iterations) {
    const std::size_t n = damping_pos_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double d = std::clamp(diag_[i], 1e-6, 1e32);
      if (type_ == LinearSolverType::kQR) {
        mat_.values[damping_pos_[i]] = std::sqrt(lambda * d);
      } else {
        mat_.values[damping_pos_[i]] = undamped_diag_[i] + lambda * d;
      }
    }
    *factorize_seconds = 0;
    *cg_iterations = 0;
    *reused = have_factor_ && max_reuse_iterations_ > 0 && Pcg(delta, cg_iterations);
    if (*reused) return internal::FactorResult::kOk;
    *cg_iterations = 0;
    internal::FactorResult r;
    const Clock::time_point tf = Clock::now();
    if (type_ == LinearSolverType::kQR) {
      r = qr_->Factorize(mat_);
      *factorize_seconds = SecondsSince(tf);
      if (r == internal::FactorResult::kOk) qr_->Solve(rhs_.data(), delta->data());
    } else {
      r = chol_->Factorize(mat_);
      *factorize_seconds = SecondsSince(tf);
      have_factor_ = r == internal::FactorResult::kOk;
      if (r == internal::FactorResult::kOk) chol_->Solve(neg_g_.data(), delta->data());
    }
    return r;
  }

  /// The linear model's decrease of chi2 along d, -2 g.d - d^T H d (H undamped; dDd = d^T D d).
  /// For a step solved exactly, (H + lambda D) d = -g turns it into -g.d + lambda d^T D d; a
  /// step from conjugate gradients is exact only to their tolerance, so H d is formed.
  double PredictedDecrease(const std::vector<double>& d, double lambda, double dDd, bool reused) {
    if (!reused) return -Dot(g_, d) + lambda * dDd;
    MultiplyH(d, &hp_);  // (H + lambda D) d
    return -2 * Dot(g_, d) - (Dot(d, hp_) - lambda * dDd);
  }

  const std::vector<double>& gradient() const { return g_; }
  double ClampedDiag(std::size_t i) const { return std::clamp(diag_[i], 1e-6, 1e32); }

 private:
  // y = H x, H symmetric given by its upper triangle (mat_, damping included). mat_ holds
  // the diagonal blocks whole; their entries below the diagonal are skipped, as CHOLMOD
  // skips them.
  void MultiplyH(const std::vector<double>& x, std::vector<double>* y) const {
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

  // Conjugate gradients on H delta = -g, preconditioned with the factorisation of an earlier
  // H (close to this one once the steps are small), started from that factorisation's solve.
  // Converged when the error's H-norm, estimated by sqrt(r^T M^-1 r), is below
  // kReuseTolerance times the step's, sqrt(b^T M^-1 b): the linear model's decrease is then
  // exact to kReuseTolerance^2. False (delta unusable) when the start is too far off to be
  // worth iterating (error above kTryRatio^(1/2) of the step in that norm: H has moved too
  // far since the factorisation), when the tolerance is not reached within
  // max_reuse_iterations_, when the residual shrinks too slowly to reach it in time, or on a
  // curvature that is not positive.
  bool Pcg(std::vector<double>* delta, int* iterations) {
    constexpr double kReuseTolerance = 1e-3;
    constexpr double kTryRatio = 1e-2;
    constexpr double kDiagonalGate = 0.3;
    std::vector<double>& x = *delta;
    const std::size_t n = x.size();
    chol_->Solve(neg_g_.data(), x.data());  // x0 = M^-1 b
    const double bMb = Dot(neg_g_, x);
    if (!(bMb > 0) || !std::isfinite(bMb)) return false;
    MultiplyH(x, &hp_);
    // A first look without another solve: the same ratio with diag(H) in place of M. On the
    // public files it is within about 30x of the true one, so far above the gate it spares
    // the solve below (the steps from a rough start).
    double rDr = 0, bDb = 0;
    for (std::size_t i = 0; i < n; ++i) {
      r_[i] = neg_g_[i] - hp_[i];
      const double d = mat_.values[damping_pos_[i]];
      rDr += r_[i] * r_[i] / d;
      bDb += neg_g_[i] * neg_g_[i] / d;
    }
    if (!(rDr <= kDiagonalGate * bDb)) return false;
    chol_->Solve(r_.data(), z_.data());
    double rz = Dot(r_, z_);
    const double target = kReuseTolerance * kReuseTolerance * bMb;
    if (!std::isfinite(rz)) return false;
    if (rz <= target) return true;
    if (rz > kTryRatio * bMb) return false;
    p_dir_ = z_;
    const double rz0 = rz;
    for (int k = 1; k <= max_reuse_iterations_; ++k) {
      *iterations = k;
      MultiplyH(p_dir_, &hp_);
      const double curvature = Dot(p_dir_, hp_);
      if (!(curvature > 0) || !std::isfinite(curvature)) return false;
      const double alpha = rz / curvature;
      for (std::size_t i = 0; i < n; ++i) {
        x[i] += alpha * p_dir_[i];
        r_[i] -= alpha * hp_[i];
      }
      chol_->Solve(r_.data(), z_.data());
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

  internal::Problem* p_;
  LinearSolverType type_;
  internal::Csc mat_;
  std::vector<int> damping_pos_;
  std::vector<double> g_, neg_g_, diag_, undamped_diag_, rhs_;
  int max_reuse_iterations_ = 0;
  bool have_factor_ = false;                // chol_ holds the factorisation of an earlier H
  std::vector<double> r_, z_, p_dir_, hp_;  // conjugate-gradient work (no allocation per step)
  std::unique_ptr<internal::SparseCholesky> chol_;
  std::unique_ptr<internal::SparseQR> qr_;
};

// The solve itself; `holder` receives the Problem so that Optimize can restore the last good
// values if a factor (or an allocation) throws mid-solve.
SolverSummary Run(const FactorGraph& graph, Values* values, const SolverOptions& options,
                  std::unique_ptr<internal::Problem>* holder) {
  const Clock::time_point t0 = Clock::now();
  SolverSummary s;
  s.algorithm = options.algorithm;
  s.linear_solver = options.linear_solver;
  s.num_factors = static_cast<int>(graph.size());
  std::string why;
  if (!options.IsValid(&why)) {
    s.status = SolverStatus::kInvalidInput;
    s.message = "invalid options: " + why;
    return s;
  }
  const std::set<Key> fixed = internal::ChooseFixed(graph, *values, &s);
  std::unique_ptr<internal::Problem>& problem = *holder;
  try {
    problem = std::make_unique<internal::Problem>(graph, values, fixed, options.num_threads);
  } catch (const Error& e) {
    s.status = SolverStatus::kInvalidInput;
    s.message = e.what();
    return s;
  }
  internal::Problem& p = *problem;
  s.num_variables = p.num_free();
  s.num_fixed = static_cast<int>(values->size()) - p.num_free();
  s.num_residuals = p.num_residuals();
  s.tangent_dim = p.tangent_dim();

  double chi2 = p.Linearize();
  s.initial_chi2 = s.final_chi2 = chi2;
  if (!std::isfinite(chi2) || !p.jacobian_finite()) {
    s.status = SolverStatus::kInvalidInput;
    s.message = std::isfinite(chi2) ? "the Jacobian at the initial values is not finite; check the initial values"
                                    : "chi2 at the initial values is not finite; check the initial values and "
                                      "measurements";
    return s;
  }
  // The log grows without reallocating for the first 1024 iterations (none in the loop).
  s.log.reserve(static_cast<std::size_t>(std::min(options.max_iterations, 1023)) + 1);
  auto report = [&](const IterationSummary& it) {
    s.log.push_back(it);
    if (options.callback) options.callback(it);
  };
  IterationSummary it0;
  it0.chi2 = chi2;
  it0.lambda = options.algorithm == Algorithm::kLevenbergMarquardt && options.initial_lambda >= options.min_lambda
                   ? options.initial_lambda
                   : 0.0;
  if (p.tangent_dim() == 0) {
    s.status = SolverStatus::kConverged;
    s.message = "nothing to optimise: every variable is fixed";
    s.total_seconds = SecondsSince(t0);
    it0.seconds = s.total_seconds;
    report(it0);
    return s;
  }

  std::unique_ptr<StepSolver> solver;
  try {
    solver = std::make_unique<StepSolver>(&p, options.linear_solver, options.max_reuse_iterations);
  } catch (const Error& e) {
    s.status = SolverStatus::kInvalidInput;
    s.message = e.what();
    return s;
  }
  s.setup_seconds = SecondsSince(t0);
  const bool lm = options.algorithm == Algorithm::kLevenbergMarquardt;
  const int n = p.tangent_dim();
  std::vector<double> delta(n, 0.0);
  // LM damping; below min_lambda it is switched off and the step is a Gauss-Newton step.
  double lambda = options.initial_lambda < options.min_lambda ? 0.0 : options.initial_lambda, nu = 2.0;
  double best_chi2 = chi2;  // GN: the best state seen is kept in the Problem's save slot
  p.Save();

  Clock::time_point tl = Clock::now();
  solver->Assemble();
  s.linearize_seconds += SecondsSince(tl);
  it0.seconds = SecondsSince(t0);
  report(it0);

  s.status = SolverStatus::kMaxIterations;
  s.message = "reached the maximum number of iterations (" + std::to_string(options.max_iterations) + ")";
  if (MaxAbs(solver->gradient()) < options.gradient_tolerance) {
    s.status = SolverStatus::kConverged;
    s.message = "gradient below gradient_tolerance at the start";
  }
  // LM: a step that failed or did not lower chi2 is logged as rejected and the damping grows.
  auto reject = [&](IterationSummary& it) {
    it.accepted = false;
    it.chi2 = chi2;
    it.seconds = SecondsSince(t0);
    report(it);
    if (lambda < options.min_lambda) {
      lambda = options.min_lambda;  // (re)start the damping
    } else {
      lambda *= nu;
      nu *= 2.0;
    }
  };
  while (s.status == SolverStatus::kMaxIterations && s.iterations < options.max_iterations) {
    if (options.max_seconds > 0 && SecondsSince(t0) > options.max_seconds) {
      s.status = SolverStatus::kTimeLimit;
      s.message = "reached the time limit";
      break;
    }
    ++s.iterations;
    IterationSummary it;
    it.iteration = s.iterations;
    it.lambda = lm ? lambda : 0.0;
    const Clock::time_point ts = Clock::now();
    double factorize = 0;
    internal::FactorResult fr =
        solver->Solve(lm ? lambda : 0.0, &delta, &factorize, &it.reused_factorization, &it.cg_iterations);
    s.solve_seconds += SecondsSince(ts) - factorize;
    s.factorize_seconds += factorize;
    if (!it.reused_factorization) {
      ++s.factorizations;
      s.last_factorize_seconds = factorize;
    }
    double step2 = 0;
    if (fr == internal::FactorResult::kOk) {
      for (double d : delta) step2 += d * d;
      // A numerically singular system can factorise and still give a non-finite step.
      if (!std::isfinite(step2)) fr = internal::FactorResult::kRankDeficient;
    }
    if (fr != internal::FactorResult::kOk) {
      if (lm && lambda < options.max_lambda) {
        reject(it);
        continue;
      }
      if (fr == internal::FactorResult::kFailed) {
        s.status = SolverStatus::kDiverged;
        s.message = std::string("the ") + ToString(options.linear_solver) +
                    " factorisation failed (out of memory or numerical trouble); try another --linear solver";
        break;
      }
      s.status = SolverStatus::kRankDeficient;
      s.message = std::string("the linear system is singular (") +
                  (fr == internal::FactorResult::kNotPositiveDefinite ? "not positive definite" : "rank deficient") +
                  "): some variables are not constrained; fix a pose, add a prior, or check that the graph "
                  "is connected";
      break;
    }
    it.step_norm = std::sqrt(step2);
    // Predicted decrease of the linear model, -2 g.d - d^T H d (StepSolver::PredictedDecrease).
    double dDd = 0;
    for (int i = 0; i < n; ++i) dDd += delta[i] * delta[i] * solver->ClampedDiag(i);
    const double predicted = solver->PredictedDecrease(delta, lambda, dDd, it.reused_factorization);
    const double x_norm = p.ParameterNorm();
    if (lm) p.Save();
    p.Retract(delta.data());
    tl = Clock::now();
    double new_chi2 = p.Chi2();
    double predicted_now = predicted;
    // LM: an undamped step that overshoots is first tried at half length, a few times, before
    // the damping starts: a chi2 evaluation is far cheaper than the factorisation a damped step
    // needs, and along the very flat directions some datasets have (parking-garage) damping
    // shortens the steps far too much. Along a*d the model predicts -g.d (2a - a^2) at lambda 0.
    if (lm && lambda == 0.0) {
      double a = 1.0;
      for (int h = 0; h < options.max_step_halvings && !(std::isfinite(new_chi2) && new_chi2 < chi2); ++h) {
        p.Restore();
        for (double& d : delta) d *= 0.5;
        a *= 0.5;
        ++it.step_halvings;
        p.Retract(delta.data());
        new_chi2 = p.Chi2();
      }
      predicted_now = predicted * (2 * a - a * a);
      it.step_norm *= a;
    }
    s.linearize_seconds += SecondsSince(tl);
    it.relative_decrease = (chi2 - new_chi2) / chi2;

    if (lm) {
      if (std::isfinite(new_chi2) && new_chi2 < chi2) {
        const double rho = predicted_now > 0 ? (chi2 - new_chi2) / predicted_now : 0.0;
        lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
        if (lambda < options.min_lambda) lambda = 0.0;
        nu = 2.0;
      } else {
        p.Restore();
        reject(it);
        if (lambda > options.max_lambda) {
          s.status = SolverStatus::kConverged;
          s.message = "no step lowers chi2 any further (damping reached max_lambda)";
        }
        continue;
      }
    } else if (!std::isfinite(new_chi2)) {
      s.status = SolverStatus::kDiverged;
      s.message = "chi2 became non-finite after a Gauss-Newton step; try --solver lm";
      it.accepted = false;
      it.chi2 = chi2;
      it.seconds = SecondsSince(t0);
      report(it);
      break;
    }
    const double old_chi2 = chi2;
    tl = Clock::now();
    chi2 = p.Linearize();
    if (!p.jacobian_finite()) {
      // A finite cost with a non-finite Jacobian: the step cannot be built on.
      if (lm) {
        p.Restore();
        chi2 = p.Linearize();
        solver->Assemble();
        s.linearize_seconds += SecondsSince(tl);
        chi2 = old_chi2;
        reject(it);
        continue;
      }
      s.status = SolverStatus::kDiverged;
      s.message = "the Jacobian became non-finite after a Gauss-Newton step; try --solver lm";
      it.accepted = false;
      it.chi2 = old_chi2;
      it.seconds = SecondsSince(t0);
      report(it);
      break;
    }
    ++s.accepted_iterations;
    solver->Assemble();
    s.linearize_seconds += SecondsSince(tl);
    if (!lm && chi2 < best_chi2) {
      best_chi2 = chi2;
      p.Save();
    }
    it.chi2 = chi2;
    it.seconds = SecondsSince(t0);
    report(it);
    if (std::abs(old_chi2 - chi2) <= options.function_tolerance * old_chi2) {
      s.status = SolverStatus::kConverged;
      s.message = "relative decrease of chi2 below function_tolerance";
    } else if (MaxAbs(solver->gradient()) < options.gradient_tolerance) {
      s.status = SolverStatus::kConverged;
      s.message = "gradient below gradient_tolerance";
    } else if (it.step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      s.status = SolverStatus::kConverged;
      s.message = "step below parameter_tolerance";
    }
  }
  if (!lm && chi2 > best_chi2) {
    // Gauss-Newton wandered uphill: hand back the best state it visited.
    p.Restore();
    chi2 = best_chi2;
    if (s.status != SolverStatus::kConverged) s.message += "; returned the best values visited";
  }
  if (!lm && s.status == SolverStatus::kDiverged) {
    p.Restore();
    chi2 = best_chi2;
  }
  s.final_chi2 = chi2;
  s.total_seconds = SecondsSince(t0);
  return s;
}

}  // namespace

SolverSummary Optimize(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  if (values == nullptr) throw InvalidArgument("Optimize: values must not be null");
  if (options.algorithm == Algorithm::kCeres) return OptimizeWithCeres(graph, values, options);
  std::unique_ptr<internal::Problem> problem;
  try {
    return Run(graph, values, options, &problem);
  } catch (const std::exception& e) {
    // A factor's Evaluate threw, or memory ran out: keep the last good values (LM: the last
    // accepted state; GN: the best visited) and say what happened.
    if (problem) problem->Restore();
    SolverSummary s;
    s.algorithm = options.algorithm;
    s.linear_solver = options.linear_solver;
    s.num_factors = static_cast<int>(graph.size());
    s.status = problem ? SolverStatus::kDiverged : SolverStatus::kInvalidInput;
    s.message = std::string("the solve stopped on an exception: ") + e.what() +
                (problem ? "; the last good values were kept" : "; values untouched");
    return s;
  }
}

}  // namespace tether
