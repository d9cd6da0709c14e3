#include "tether/plugins/plugin_check.h"

#include <cmath>
#include <cstdio>
#include <random>

#include "tether/core/error.h"
#include "tether/core/variable.h"

namespace tether {

bool FactorTypeCheckOptions::IsValid(std::string* why) const {
  std::string reason;
  if (trials < 1) {
    reason = "trials must be at least 1";
  } else if (!(std::isfinite(step) && step >= 0)) {
    reason = "step must be finite and not negative";
  } else if (!(std::isfinite(measurement_min) && std::isfinite(measurement_max) &&
               measurement_min <= measurement_max)) {
    reason = "measurement_min and measurement_max must be finite, the minimum not above the maximum";
  } else if (!(jacobian.step > 0 && std::isfinite(jacobian.step))) {
    reason = "jacobian.step must be positive and finite";
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

std::string FactorTypeCheck::Line() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%-16s %d random points, largest difference %.1e: ", type.c_str(), trials, largest);
  std::string line = buf;
  if (failed > 0) {
    line += "MISMATCH at " + std::to_string(failed) + " points";
  } else if (refused == trials) {
    line += "NOT CHECKED: the factory refused every measurement (" + refusal + ")";
  } else {
    line += "ok";
  }
  if (refused > 0 && refused < trials) line += " (" + std::to_string(refused) + " measurements refused)";
  return line;
}

namespace {

FactorTypeCheck CheckOne(const FactorType& type, const FactorTypeCheckOptions& options, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> step(-options.step, options.step);
  std::uniform_real_distribution<double> measurement(options.measurement_min, options.measurement_max);
  FactorTypeCheck c;
  c.type = type.name;
  for (int trial = 0; trial < options.trials; ++trial) {
    ++c.trials;
    // Keys 0, 1, ...: each the identity of its type moved by a random box-plus step.
    Values values;
    std::vector<Key> keys;
    for (const VarType t : type.variable_types) {
      std::vector<double> x(static_cast<std::size_t>(AmbientDim(t))), d(static_cast<std::size_t>(TangentDim(t)));
      IdentityParams(t, x.data());
      for (double& v : d) v = step(rng);
      RetractParams<double>(t, x.data(), d.data(), x.data());
      keys.push_back(static_cast<Key>(keys.size()));
      values.InsertParams(keys.back(), t, x.data());
    }
    std::vector<double> m(static_cast<std::size_t>(type.measurement_size));
    for (double& v : m) v = measurement(rng);
    std::unique_ptr<Factor> factor;
    try {
      factor = type.make(keys, m.data(), SqrtInformation::Identity(type.dim));
    } catch (const Error& e) {
      if (c.refused++ == 0) c.refusal = e.what();
      continue;
    }
    const JacobianCheck check = CheckJacobians(*factor, values, options.jacobian);
    if (check.max_abs_error > c.largest || std::isnan(check.max_abs_error)) c.largest = check.max_abs_error;
    if (!check.ok && c.failed++ == 0) c.first_failure = check.Report();
  }
  return c;
}

}  // namespace

std::vector<FactorTypeCheck> CheckFactorTypes(const Registry& registry, const std::vector<std::string>& type_names,
                                              const FactorTypeCheckOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("factor type check: " + why);
  std::vector<const FactorType*> types;
  for (const std::string& name : type_names) {
    const FactorType* t = registry.FindByName(name);
    if (t == nullptr) throw InvalidArgument("factor type check: no factor type named '" + name + "' is registered");
    if (!t->make) throw InvalidArgument("factor type check: '" + name + "' has no factory to make it from fields");
    types.push_back(t);
  }
  std::mt19937_64 rng(options.seed);
  std::vector<FactorTypeCheck> out;
  for (const FactorType* t : types) out.push_back(CheckOne(*t, options, rng));
  return out;
}

}  // namespace tether
