#include "tether/solvers/ceres_problem.h"

#include <ceres/loss_function.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <unordered_set>

#include "tether/core/error.h"

namespace tether {

namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The rotation and, for SE3, the (normalised) quaternion that RetractParams works from:
// FromParams wraps the SE2 angle and normalises the SE3 quaternion before retracting.
Eigen::Matrix2d Rotation2(const double* x) { return SE2d::FromParams(x).rotation().matrix(); }

// For SE3 at the unit quaternion q = (v, w): Q = d (q (x) Exp(omega)) / d omega at 0, rows
// (qx, qy, qz, qw). To first order Exp(omega) = (omega / 2, 1), and q (x) (u, 0) has vector
// part w u + v x u and scalar part -v . u, so Q = [w I + [v]x; -v^T] / 2. Its columns are
// orthogonal with norm 1/2, hence Q^T Q = I / 4 and 4 Q^T is a left inverse.
Eigen::Matrix<double, 4, 3> QuaternionRetractJacobian(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d v = q.vec();
  Eigen::Matrix<double, 4, 3> m;
  m.topRows<3>() = q.w() * Eigen::Matrix3d::Identity() + Skew(v);
  m.row(3) = -v.transpose();
  return 0.5 * m;
}

// A factor's robust loss for Ceres: the same rho(s), rho'(s), rho''(s) (Ceres's convention for
// the squared norm of the residual is tether's).
class CeresLoss : public ceres::LossFunction {
 public:
  explicit CeresLoss(std::shared_ptr<const tether::LossFunction> loss) : loss_(std::move(loss)) {}
  void Evaluate(double s, double rho[3]) const override { loss_->Evaluate(s, rho); }

 private:
  std::shared_ptr<const tether::LossFunction> loss_;
};

}  // namespace

void RetractJacobian(VarType type, const double* x, double* jacobian) {
  const int a = AmbientDim(type), t = TangentDim(type);
  Eigen::Map<RowMajor> p(jacobian, a, t);
  p.setZero();
  switch (type) {
    case VarType::kSE2:
      p.topLeftCorner<2, 2>() = Rotation2(x);
      p(2, 2) = 1.0;
      break;
    case VarType::kSE3: {
      const SE3d pose = SE3d::FromParams(x);
      p.topLeftCorner<3, 3>() = pose.rotation().matrix();
      p.bottomRightCorner<4, 3>() = QuaternionRetractJacobian(pose.quaternion());
      break;
    }
    case VarType::kPoint2:
    case VarType::kPoint3:
      p.setIdentity();
      break;
    default: {
      // A registered type: central differences of its box-plus. Exactness is not needed here:
      // Ceres multiplies by P only after the cost function has multiplied by L, a left
      // inverse of this same P (see the header), so J_a P = J_t whatever P's rounding.
      std::vector<double> d(static_cast<std::size_t>(t), 0.0), plus(a), minus(a);
      double scale = 1.0;  // a step relative to the parameters' size, so that x + h != x
      for (int i = 0; i < a; ++i) scale = std::max(scale, std::abs(x[i]));
      const double h = 1e-6 * scale;
      for (int c = 0; c < t; ++c) {
        d[c] = h;
        RetractParams<double>(type, x, d.data(), plus.data());
        d[c] = -h;
        RetractParams<double>(type, x, d.data(), minus.data());
        d[c] = 0.0;
        for (int r = 0; r < a; ++r) p(r, c) = (plus[r] - minus[r]) / (2 * h);
      }
    }
  }
}

void RetractJacobianLeftInverse(VarType type, const double* x, double* jacobian) {
  const int a = AmbientDim(type), t = TangentDim(type);
  Eigen::Map<RowMajor> l(jacobian, t, a);
  l.setZero();
  switch (type) {
    case VarType::kSE2:
      l.topLeftCorner<2, 2>() = Rotation2(x).transpose();
      l(2, 2) = 1.0;
      break;
    case VarType::kSE3: {
      const SE3d pose = SE3d::FromParams(x);
      l.topLeftCorner<3, 3>() = pose.rotation().matrix().transpose();
      l.bottomRightCorner<3, 4>() = 4.0 * QuaternionRetractJacobian(pose.quaternion()).transpose();
      break;
    }
    case VarType::kPoint2:
    case VarType::kPoint3:
      l.setIdentity();
      break;
    default: {
      // A registered type: the pseudo-inverse (P^T P)^-1 P^T of its P.
      RowMajor p(a, t);
      RetractJacobian(type, x, p.data());
      l = (p.transpose() * p).ldlt().solve(p.transpose());
    }
  }
}

bool VariableManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  RetractParams(type_, x, delta, x_plus_delta);
  return true;
}

bool VariableManifold::PlusJacobian(const double* x, double* jacobian) const {
  RetractJacobian(type_, x, jacobian);
  return true;
}

bool VariableManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  LocalParams(type_, x, y, y_minus_x);
  return true;
}

bool VariableManifold::MinusJacobian(const double* x, double* jacobian) const {
  RetractJacobianLeftInverse(type_, x, jacobian);
  return true;
}

void EvaluationErrors::Record(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!any_.load(std::memory_order_relaxed)) first_ = what;
  any_.store(true, std::memory_order_relaxed);
}

std::string EvaluationErrors::first() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return first_;
}

FactorCostFunction::FactorCostFunction(const Factor* factor, EvaluationErrors* errors)
    : factor_(factor), errors_(errors), types_(factor->variable_types()) {
  set_num_residuals(factor->dim());
  const std::vector<Key>& keys = factor->keys();
  for (std::size_t k = 0; k < keys.size(); ++k) {
    tangent_offset_.push_back(tangent_total_);
    tangent_total_ += TangentDim(types_[k]);
    const auto seen = std::find(block_keys_.begin(), block_keys_.end(), keys[k]);
    if (seen != block_keys_.end()) {
      block_of_.push_back(static_cast<int>(seen - block_keys_.begin()));
      continue;
    }
    block_of_.push_back(static_cast<int>(block_keys_.size()));
    block_keys_.push_back(keys[k]);
    block_types_.push_back(types_[k]);
    mutable_parameter_block_sizes()->push_back(AmbientDim(types_[k]));
  }
}

bool FactorCostFunction::Evaluate(const double* const* parameters, double* residuals, double** jacobians) const {
  // Per-thread workspace: Ceres may evaluate residual blocks on several threads.
  struct Workspace {
    std::vector<const double*> params;
    std::vector<double*> tangent_ptrs;
    std::vector<double> tangent;
    std::vector<double> left_inverse;
  };
  thread_local Workspace w;
  const std::size_t nk = block_of_.size();
  const int m = num_residuals();
  w.params.resize(nk);
  w.tangent_ptrs.assign(nk, nullptr);
  w.tangent.resize(static_cast<std::size_t>(tangent_total_) * m);
  for (std::size_t k = 0; k < nk; ++k) {
    w.params[k] = parameters[block_of_[k]];
    if (jacobians != nullptr && jacobians[block_of_[k]] != nullptr) {
      w.tangent_ptrs[k] = w.tangent.data() + static_cast<std::size_t>(tangent_offset_[k]) * m;
    }
  }
  try {
    if (!factor_->Linearize(w.params.data(), residuals, jacobians != nullptr ? w.tangent_ptrs.data() : nullptr)) {
      return false;
    }
  } catch (const std::exception& e) {
    if (errors_ != nullptr) errors_->Record(factor_->type_name() + " factor threw: " + e.what());
    return false;
  } catch (...) {
    if (errors_ != nullptr) errors_->Record(factor_->type_name() + " factor threw an unknown exception");
    return false;
  }
  if (jacobians == nullptr) return true;
  // J_a = J_t L(x), summed over the keys that share a block.
  for (std::size_t b = 0; b < block_keys_.size(); ++b) {
    if (jacobians[b] == nullptr) continue;
    const VarType type = block_types_[b];
    const int a = AmbientDim(type), t = TangentDim(type);
    Eigen::Map<RowMajor> ja(jacobians[b], m, a);
    ja.setZero();
    w.left_inverse.resize(static_cast<std::size_t>(t) * a);
    RetractJacobianLeftInverse(type, parameters[b], w.left_inverse.data());
    const Eigen::Map<const RowMajor> l(w.left_inverse.data(), t, a);
    for (std::size_t k = 0; k < nk; ++k) {
      if (block_of_[k] != static_cast<int>(b)) continue;
      ja.noalias() += Eigen::Map<const RowMajor>(w.tangent_ptrs[k], m, t) * l;
    }
  }
  return true;
}

ceres::Problem::Options CeresProblem::ProblemOptions() {
  ceres::Problem::Options o;
  o.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  o.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // the manifolds are members
  return o;
}

CeresProblem::CeresProblem(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed)
    : problem_(ProblemOptions()) {
  // Check every factor first (as the native solver does), then collect the used variables in
  // the Values' insertion order.
  std::unordered_set<Key> used;
  for (std::size_t fi = 0; fi < graph.size(); ++fi) {
    const Factor& f = graph.at(fi);
    try {
      f.CheckShape();
      f.GatherParams(values);  // throws for missing or mistyped keys
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("factor " + std::to_string(fi) + ": " + e.what());
    }
    used.insert(f.keys().begin(), f.keys().end());
  }
  std::size_t size = 0;
  for (Key k : values.keys()) {
    if (!used.count(k)) continue;
    const VarType t = values.TypeOf(k);
    index_.emplace(k, static_cast<int>(keys_.size()));
    keys_.push_back(k);
    types_.push_back(t);
    offsets_.push_back(size);
    const bool is_fixed = fixed.count(k) != 0;
    constant_.push_back(is_fixed ? 1 : 0);
    if (!is_fixed) {
      ++num_free_;
      tangent_dim_ += TangentDim(t);
    }
    size += AmbientDim(t);
  }
  params_.resize(size);
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    std::copy_n(values.Params(keys_[i]), AmbientDim(types_[i]), params_.data() + offsets_[i]);
  }
  start_ = params_;
  // params_ never reallocates from here on: Ceres keeps pointers into it.
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    ceres::Manifold* manifold = nullptr;
    if (!IsPoint(types_[i])) {  // points are Euclidean; poses and registered types get their box-plus
      std::unique_ptr<VariableManifold>& m = manifolds_[types_[i]];
      if (!m) m = std::make_unique<VariableManifold>(types_[i]);
      manifold = m.get();
    }
    double* block = params_.data() + offsets_[i];
    problem_.AddParameterBlock(block, AmbientDim(types_[i]), manifold);
    if (constant_[i]) problem_.SetParameterBlockConstant(block);
  }
  for (const auto& f : graph.factors()) {
    num_residuals_ += f->dim();
    if (f->keys().empty()) {
      keyless_chi2_ += f->Cost(values);
      continue;
    }
    auto cost = std::make_unique<FactorCostFunction>(f.get(), &errors_);
    std::vector<double*> blocks;
    for (Key k : cost->block_keys()) blocks.push_back(Block(k));
    // A robust loss maps to a ceres::LossFunction that evaluates it (nullptr: plain squared
    // error). Ceres minimises half the sum of rho, so its optimum is the native solver's.
    ceres::LossFunction* loss = f->loss() ? new CeresLoss(f->shared_loss()) : nullptr;
    problem_.AddResidualBlock(cost.release(), loss, blocks);
  }
}

double* CeresProblem::Block(Key k) {
  const auto it = index_.find(k);
  return it == index_.end() ? nullptr : params_.data() + offsets_[it->second];
}

bool CeresProblem::IsConstant(Key k) const {
  const auto it = index_.find(k);
  return it != index_.end() && constant_[it->second];
}

bool CeresProblem::WriteBack(Values* values) const {
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (constant_[i]) continue;
    for (int j = 0; j < AmbientDim(types_[i]); ++j) {
      if (!std::isfinite(params_[offsets_[i] + j])) return false;
    }
  }
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (!constant_[i]) std::copy_n(params_.data() + offsets_[i], AmbientDim(types_[i]), values->Params(keys_[i]));
  }
  return true;
}

}  // namespace tether
