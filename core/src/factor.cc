#include "tether/core/factor.h"

#include <cmath>
#include <limits>

#include "tether/core/error.h"
#include "tether/core/values.h"

namespace tether {

bool Factor::Linearize(const double* const* params, double* residual, double* const* jacobians) const {
  if (!Evaluate(params, residual, jacobians)) return false;
  noise_.WhitenVector(residual);
  if (jacobians != nullptr) {
    const std::vector<VarType> types = variable_types();
    for (std::size_t k = 0; k < keys_.size(); ++k) {
      if (jacobians[k] != nullptr) noise_.WhitenRowMajor(jacobians[k], TangentDim(types[k]));
    }
  }
  return true;
}

void Factor::CheckShape() const {
  const std::size_t n = variable_types().size();
  if (keys_.size() != n) {
    throw InvalidArgument(type_name() + " factor has " + std::to_string(keys_.size()) + " keys but its type takes " +
                          std::to_string(n) + "; build it with the right keys");
  }
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (keys_[i] == keys_[j]) {
        throw InvalidArgument(type_name() + " factor connects " + KeyToString(keys_[i]) + " to itself (it is key " +
                              std::to_string(j) + " and key " + std::to_string(i) +
                              "); a factor's keys must be distinct");
      }
    }
  }
  if (dim() < 1 || dim() != residual_dim()) {
    throw InvalidArgument(type_name() + " factor has a noise model of dimension " + std::to_string(dim()) +
                          " for an error of dimension " + std::to_string(residual_dim()) +
                          "; give it a noise model of the error's dimension");
  }
}

std::vector<const double*> Factor::GatherParams(const Values& values) const {
  const std::vector<VarType> types = variable_types();
  std::vector<const double*> p(keys_.size());
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    if (!values.Has(keys_[k])) {
      throw InvalidArgument(type_name() + " factor refers to key " + KeyToString(keys_[k]) +
                            ", which has no value; add the variable first");
    }
    const VarType t = values.TypeOf(keys_[k]);
    if (t != types[k]) {
      throw InvalidArgument(type_name() + " factor expects " + std::string(ToString(types[k])) + " for key " +
                            KeyToString(keys_[k]) + " but it holds " + std::string(ToString(t)));
    }
    p[k] = values.Params(keys_[k]);
  }
  return p;
}

std::string Factor::Describe() const {
  std::string s = type_name() + ", keys";
  for (std::size_t i = 0; i < keys_.size(); ++i) s += (i ? ", " : " ") + KeyToString(keys_[i]);
  return s;
}

double Factor::Chi2(const Values& values) const {
  CheckShape();
  const std::vector<const double*> p = GatherParams(values);
  std::vector<double> r(static_cast<std::size_t>(dim()));
  if (!Linearize(p.data(), r.data(), nullptr)) return std::numeric_limits<double>::infinity();
  double s = 0;
  for (int i = 0; i < dim(); ++i) s += r[i] * r[i];
  return s;
}

double Factor::Cost(const Values& values) const {
  const double s = Chi2(values);
  if (loss_ == nullptr || !std::isfinite(s)) return s;
  double rho[3];
  loss_->Evaluate(s, rho);
  return rho[0];
}

}  // namespace tether
