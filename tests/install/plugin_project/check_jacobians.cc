// check_jacobians PLUGIN.so: loads the plugin as tether does and, for each of its factor
// types, compares the Jacobians with central differences taken along the same box-plus the
// solvers use (tether::CheckJacobians), at 100 random points. Exits with 1 on a mismatch.
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "tether/core/jacobian_check.h"
#include "tether/plugins/plugin_loader.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: check_jacobians PLUGIN.so\n");
    return 2;
  }
  tether::Registry registry;  // the built-in variable types, and no factor types but the plugin's
  tether::PluginLoader loader(registry);
  tether::LoadedPlugin plugin;
  try {
    plugin = loader.Load(argv[1]);
  } catch (const tether::PluginError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  const std::set<std::string> angle_errors = {"Bearing2D"};  // types whose error is an angle

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> step(-2.0, 2.0), measurement(0.5, 2.0);
  bool all_ok = true;
  for (const std::string& name : plugin.type_names) {
    const tether::FactorType& type = *registry.FindByName(name);
    tether::JacobianCheckOptions options;
    if (angle_errors.count(name)) options.angle_rows = {0};  // differences across +-pi are wrapped
    double largest = 0;
    int failed = 0;
    for (int trial = 0; trial < 100; ++trial) {
      // Keys 0, 1, ...: each the identity of its type moved by a random box-plus step.
      tether::Values values;
      std::vector<tether::Key> keys;
      for (const tether::VarType t : type.variable_types) {
        std::vector<double> x(tether::AmbientDim(t)), d(tether::TangentDim(t));
        tether::IdentityParams(t, x.data());
        for (double& v : d) v = step(rng);
        tether::RetractParams<double>(t, x.data(), d.data(), x.data());
        keys.push_back(keys.size());
        values.InsertParams(keys.back(), t, x.data());
      }
      std::vector<double> m(type.measurement_size);
      for (double& v : m) v = measurement(rng);
      const auto factor = type.make(keys, m.data(), tether::SqrtInformation::Identity(type.dim));
      const tether::JacobianCheck check = tether::CheckJacobians(*factor, values, options);
      if (check.max_abs_error > largest) largest = check.max_abs_error;
      if (!check.ok && failed++ == 0) std::printf("%s", check.Report().c_str());  // the first one
    }
    std::printf("%-12s 100 random points, largest difference %.1e: ", name.c_str(), largest);
    if (failed == 0) {
      std::printf("ok\n");
    } else {
      std::printf("MISMATCH at %d points\n", failed);
    }
    all_ok = all_ok && failed == 0;
  }
  return all_ok ? 0 : 1;
}
