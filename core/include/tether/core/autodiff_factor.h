#pragma once
// AutoDiffFactor: a factor whose error is a templated function, differentiated with ceres::Jet.
//
// Write a class with
//   template <typename T> bool operator()(const T* const* params, T* error) const;
// where params[k] holds the raw parameters of key k (layouts in variable.h), and derive
//   class MyFactor : public AutoDiffFactor<MyFactor, kErrorDim, VarType::kSE2, VarType::kPoint2>
// The Jacobians with respect to each variable's tangent delta are obtained by evaluating
// the error at x_k (+) delta_k with Jet-valued deltas at zero, so they match the box-plus
// the solvers use.
#include <ceres/jet.h>

#include <array>

#include "tether/core/factor.h"

namespace tether {

template <class Derived, int kErrorDim, VarType... kTypes>
class AutoDiffFactor : public Factor {
 public:
  static constexpr int kNumKeys = sizeof...(kTypes);
  static constexpr int kTangentTotal = (TangentDim(kTypes) + ...);
  using Jet = ceres::Jet<double, kTangentTotal>;
  static_assert(kErrorDim >= 1 && kErrorDim <= kMaxResidualDim, "error dimension must be 1 to 6");

  AutoDiffFactor(std::vector<Key> keys, SqrtInformation noise) : Factor(std::move(keys), noise) {}

  std::vector<VarType> variable_types() const override { return {kTypes...}; }
  int residual_dim() const override { return kErrorDim; }

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    static constexpr std::array<VarType, kNumKeys> types = {kTypes...};
    const Derived& self = static_cast<const Derived&>(*this);
    if (jacobians == nullptr) {
      std::array<const double*, kNumKeys> p;
      for (int k = 0; k < kNumKeys; ++k) p[k] = params[k];
      return self(p.data(), error);
    }
    // Retract each variable by a Jet delta that is zero with unit derivative in its slot.
    std::array<std::array<Jet, 7>, kNumKeys> x;
    std::array<const Jet*, kNumKeys> xp;
    int offset = 0;
    for (int k = 0; k < kNumKeys; ++k) {
      const VarType t = types[k];
      std::array<Jet, 7> xj, dj;
      for (int i = 0; i < AmbientDim(t); ++i) xj[i] = Jet(params[k][i]);
      for (int i = 0; i < TangentDim(t); ++i) dj[i] = Jet(0.0, offset + i);
      RetractParams<Jet>(t, xj.data(), dj.data(), x[k].data());
      xp[k] = x[k].data();
      offset += TangentDim(t);
    }
    std::array<Jet, kErrorDim> e;
    if (!self(xp.data(), e.data())) return false;
    offset = 0;
    for (int k = 0; k < kNumKeys; ++k) {
      const int d = TangentDim(types[k]);
      if (jacobians[k] != nullptr) {
        for (int r = 0; r < kErrorDim; ++r)
          for (int c = 0; c < d; ++c) jacobians[k][r * d + c] = e[r].v[offset + c];
      }
      offset += d;
    }
    for (int r = 0; r < kErrorDim; ++r) error[r] = e[r].a;
    return true;
  }
};

}  // namespace tether
