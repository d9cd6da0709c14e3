#pragma once
// The Jacobian check of every factor type a plugin registers, at random points: what `tether
// check-plugin PLUGIN.so` and Python's check_factor_types run, so a plugin's author needs no
// checker of their own (docs/writing-a-factor-plugin.md).
//
//   tether::Registry registry;
//   tether::PluginLoader loader(registry);
//   const tether::LoadedPlugin p = loader.Load("my_factors.so");
//   for (const auto& c : tether::CheckFactorTypes(registry, p.type_names)) std::cout << c.Line() << "\n";
//
// Each trial puts every variable of the factor at the identity of its type moved by a random
// box-plus step, draws each measurement field uniformly from [measurement_min,
// measurement_max], makes the factor with identity noise through the type's factory and runs
// CheckJacobians (tether/core/jacobian_check.h). A trial whose factor the factory refuses (a
// measurement the type cannot take) is counted, not failed.
#include <cstdint>
#include <string>
#include <vector>

#include "tether/core/jacobian_check.h"
#include "tether/core/registry.h"

namespace tether {

struct FactorTypeCheckOptions {
  int trials = 100;        ///< random points per type, at least 1
  std::uint64_t seed = 7;  ///< the random points' seed
  double step = 2.0;       ///< each tangent coordinate of a variable drawn from [-step, step]
  double measurement_min = 0.5, measurement_max = 2.0;
  JacobianCheckOptions jacobian;  ///< the tolerances and the differentiation step

  bool IsValid(std::string* why) const;
};

struct FactorTypeCheck {
  std::string type;
  int trials = 0;             ///< trials run
  int failed = 0;             ///< trials whose Jacobians did not match (or did not evaluate)
  int refused = 0;            ///< trials whose factor the type's factory refused
  double largest = 0;         ///< the largest |analytic - numeric| over the trials
  std::string first_failure;  ///< CheckJacobians' report of the first failed trial
  std::string refusal;        ///< why the factory refused the first refused trial

  /// Every trial made a factor and matched.
  bool ok() const { return failed == 0 && refused < trials; }
  /// "Range2D      100 random points, largest difference 4.7e-10: ok" (or MISMATCH at N
  /// points, or how many the factory refused).
  std::string Line() const;
};

/// Checks each named factor type of `registry`. Throws InvalidArgument for invalid options or
/// a name the registry does not hold.
std::vector<FactorTypeCheck> CheckFactorTypes(const Registry& registry, const std::vector<std::string>& type_names,
                                              const FactorTypeCheckOptions& options = {});

}  // namespace tether
