// Example plugin "pcg": a linear solver for the normal equations H x = b by conjugate
// gradients, preconditioned with the inverses of H's diagonal blocks (block Jacobi; a block
// is one variable's tangent block, as the solver is told in Analyze).
//
//   tether optimize --plugin build/plugins/pcg.so --linear pcg FILE
//
// No factorisation of H is ever formed: memory stays at the size of H, and each iteration
// costs one product with H. Its settings come from SolverOptions::linear:
// iterative_tolerance (stop once |b - H x| <= tolerance |b|) and iterative_max_iterations
// (0: as many as H has columns). A solve that runs out of iterations still returns its best x:
// the step strategy judges the step by the decrease of chi2 it brings.
//
// A linear solver plugin implements tether::LinearSolver (tether/core/linear_solver.h) and
// registers a factory under a name, the way a factor plugin registers its types.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/linear_solver.h"
#include "tether/plugins/plugin.h"

namespace {

using tether::LinearSolverStatus;
using tether::SparseMatrixView;

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

class BlockJacobiPcg : public tether::LinearSolver {
 public:
  explicit BlockJacobiPcg(const tether::LinearSolverOptions& o)
      : tolerance_(o.iterative_tolerance), max_iterations_(o.iterative_max_iterations) {}

  void Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) override {
    n_ = a.cols;
    colptr_.assign(a.colptr, a.colptr + n_ + 1);
    rowind_.assign(a.rowind, a.rowind + colptr_[n_]);
    values_.assign(rowind_.size(), 0.0);
    block_start_.assign(1, 0);
    for (int d : block_sizes) block_start_.push_back(block_start_.back() + d);
    if (block_start_.back() != n_) {
      throw tether::Error("pcg: the block sizes add up to " + std::to_string(block_start_.back()) + ", but H has " +
                          std::to_string(n_) + " columns");
    }
    inverse_start_.assign(1, 0);
    for (int d : block_sizes) inverse_start_.push_back(inverse_start_.back() + d * d);
    inverses_.assign(inverse_start_.back(), 0.0);
    for (std::vector<double>* v : {&r_, &z_, &p_, &hp_}) v->assign(n_, 0.0);
  }

  // Keeps H's values and inverts its diagonal blocks.
  LinearSolverStatus Factorize(const SparseMatrixView& a) override {
    std::copy(a.values, a.values + values_.size(), values_.begin());
    for (std::size_t b = 0; b + 1 < block_start_.size(); ++b) {
      if (!InvertBlock(b)) return LinearSolverStatus::kNotPositiveDefinite;
    }
    return LinearSolverStatus::kOk;
  }

  LinearSolverStatus Solve(const double* b, double* x) override {
    std::fill(x, x + n_, 0.0);
    std::copy(b, b + n_, r_.begin());  // r = b - H x with x = 0
    const double stop = tolerance_ * std::sqrt(Dot(r_, r_));
    const int max_iterations = max_iterations_ > 0 ? max_iterations_ : n_;
    last_iterations_ = 0;
    if (stop == 0) return LinearSolverStatus::kOk;
    Precondition(r_, &z_);
    p_ = z_;
    double rz = Dot(r_, z_);
    for (int k = 1; k <= max_iterations; ++k) {
      last_iterations_ = k;
      Multiply(p_, &hp_);
      const double curvature = Dot(p_, hp_);
      if (!(curvature > 0) || !std::isfinite(curvature)) return LinearSolverStatus::kNotPositiveDefinite;
      const double alpha = rz / curvature;
      for (int i = 0; i < n_; ++i) {
        x[i] += alpha * p_[i];
        r_[i] -= alpha * hp_[i];
      }
      if (std::sqrt(Dot(r_, r_)) <= stop) break;
      Precondition(r_, &z_);
      const double rz_new = Dot(r_, z_);
      const double beta = rz_new / rz;
      rz = rz_new;
      for (int i = 0; i < n_; ++i) p_[i] = z_[i] + beta * p_[i];
    }
    return LinearSolverStatus::kOk;
  }

  std::string Description() const override { return "conjugate gradients, block-Jacobi preconditioner"; }
  int last_iterations() const override { return last_iterations_; }

 private:
  // The diagonal block b of H (its upper triangle, mirrored), inverted by Cholesky.
  bool InvertBlock(std::size_t b) {
    const int first = block_start_[b], d = block_start_[b + 1] - first;
    Eigen::MatrixXd block = Eigen::MatrixXd::Zero(d, d);
    for (int c = first; c < first + d; ++c) {
      for (int k = colptr_[c]; k < colptr_[c + 1]; ++k) {
        const int r = rowind_[k];
        if (r >= first && r <= c) block(r - first, c - first) = block(c - first, r - first) = values_[k];
      }
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(block);
    if (llt.info() != Eigen::Success) return false;
    Eigen::Map<Eigen::MatrixXd>(inverses_.data() + inverse_start_[b], d, d) =
        llt.solve(Eigen::MatrixXd::Identity(d, d));
    return true;
  }

  // z = M^-1 r, block by block.
  void Precondition(const std::vector<double>& r, std::vector<double>* z) const {
    for (std::size_t b = 0; b + 1 < block_start_.size(); ++b) {
      const int first = block_start_[b], d = block_start_[b + 1] - first;
      const double* inv = inverses_.data() + inverse_start_[b];
      for (int i = 0; i < d; ++i) {
        double s = 0;
        for (int j = 0; j < d; ++j) s += inv[j * d + i] * r[first + j];
        (*z)[first + i] = s;
      }
    }
  }

  // y = H x from the upper triangle (entries below the diagonal skipped).
  void Multiply(const std::vector<double>& x, std::vector<double>* y) const {
    std::fill(y->begin(), y->end(), 0.0);
    for (int c = 0; c < n_; ++c) {
      double acc = 0;
      for (int k = colptr_[c]; k < colptr_[c + 1]; ++k) {
        const int r = rowind_[k];
        if (r > c) continue;
        acc += values_[k] * x[r];
        if (r != c) (*y)[r] += values_[k] * x[c];
      }
      (*y)[c] += acc;
    }
  }

  double tolerance_;
  int max_iterations_;
  int n_ = 0;
  int last_iterations_ = 0;
  std::vector<int> colptr_, rowind_, block_start_, inverse_start_;
  std::vector<double> values_, inverses_;
  std::vector<double> r_, z_, p_, hp_;  // work (no allocation per solve)
};

void RegisterPcg(tether::PluginRegistrar& r) {
  r.AddLinearSolver("pcg", [](const tether::LinearSolverOptions& o) -> std::unique_ptr<tether::LinearSolver> {
    return std::make_unique<BlockJacobiPcg>(o);
  });
}

}  // namespace

TETHER_PLUGIN("pcg", "1.0.0", RegisterPcg)
