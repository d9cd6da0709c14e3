#pragma once
// AutoDiffFactor: a factor whose error is a templated function, differentiated with ceres::Jet.
//
// Write a class with
//   static constexpr const char* kTypeName = "MyFactor";
//   template <typename T> bool operator()(const T* const* params, T* error) const;
// where params[k] holds the raw parameters of key k (layouts in variable.h), and derive
//   class MyFactor : public AutoDiffFactor<MyFactor, kErrorDim, SE2d, Eigen::Vector2d>
// listing the keys' variable types by their value types (any registered type works, through
// its VariableTraits). The Jacobians with respect to each variable's tangent delta are
// obtained by evaluating the error at x_k (+) delta_k with Jet-valued deltas at zero, so they
// match the box-plus the solvers use. Any error size and any number of keys work.
#include <ceres/jet.h>

#include <array>
#include <utility>

#include "tether/core/factor.h"

namespace tether {

template <class Derived, int kErrorDim, class... Vars>
class AutoDiffFactor : public TypedFactor<Derived, kErrorDim, Vars...> {
 public:
  static constexpr int kNumKeys = sizeof...(Vars);
  static constexpr int kTangentTotal = (VariableTraits<Vars>::kTangent + ...);
  static constexpr int kAmbientTotal = (VariableTraits<Vars>::kAmbient + ...);
  using Jet = ceres::Jet<double, kTangentTotal>;

  AutoDiffFactor(std::vector<Key> keys, SqrtInformation noise)
      : TypedFactor<Derived, kErrorDim, Vars...>(std::move(keys), std::move(noise)) {}

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    const Derived& self = static_cast<const Derived&>(*this);
    if (jacobians == nullptr) {
      std::array<const double*, kNumKeys> p;
      for (int k = 0; k < kNumKeys; ++k) p[k] = params[k];
      return self(p.data(), error);
    }
    // Retract each variable by a Jet delta that is zero with unit derivative in its slot.
    std::array<Jet, kAmbientTotal> x;
    std::array<const Jet*, kNumKeys> xp;
    PerturbAll(params, &x, &xp, std::index_sequence_for<Vars...>{});
    std::array<Jet, kErrorDim> e;
    if (!self(xp.data(), e.data())) return false;
    constexpr std::array<int, kNumKeys> dims = {VariableTraits<Vars>::kTangent...};
    int offset = 0;
    for (int k = 0; k < kNumKeys; ++k) {
      const int d = dims[k];
      if (jacobians[k] != nullptr) {
        for (int r = 0; r < kErrorDim; ++r)
          for (int c = 0; c < d; ++c) jacobians[k][r * d + c] = e[r].v[offset + c];
      }
      offset += d;
    }
    for (int r = 0; r < kErrorDim; ++r) error[r] = e[r].a;
    return true;
  }

 private:
  template <std::size_t... I>
  static void PerturbAll(const double* const* params, std::array<Jet, kAmbientTotal>* x,
                         std::array<const Jet*, kNumKeys>* xp, std::index_sequence<I...>) {
    int ambient = 0, tangent = 0;
    (Perturb<Vars>(params[I], x, &ambient, &tangent, &(*xp)[I]), ...);
  }
  template <class V>
  static void Perturb(const double* p, std::array<Jet, kAmbientTotal>* x, int* ambient, int* tangent, const Jet** out) {
    using Tr = VariableTraits<V>;
    std::array<Jet, Tr::kAmbient> xj;
    std::array<Jet, Tr::kTangent> dj;
    for (int i = 0; i < Tr::kAmbient; ++i) xj[i] = Jet(p[i]);
    for (int i = 0; i < Tr::kTangent; ++i) dj[i] = Jet(0.0, *tangent + i);
    Jet* dst = x->data() + *ambient;
    Tr::template Retract<Jet>(xj.data(), dj.data(), dst);
    *out = dst;
    *ambient += Tr::kAmbient;
    *tangent += Tr::kTangent;
  }
};

}  // namespace tether
