// Broken on purpose: a description whose build fingerprint differs from tether's in two
// fields, as if the plugin had been built with other Eigen alignment flags against another
// minor version of tether. The loader must name both fields with both values.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestFingerprintPrior", "TEST_FINGERPRINT_PRIOR"));
}

tether::PluginDescription Describe() {
  tether::BuildFingerprint f = tether::CurrentBuildFingerprint();
  f.tether_minor += 1;
  f.eigen_max_align_bytes = f.eigen_max_align_bytes == 16 ? 32 : 16;
  return {TETHER_PLUGIN_INTERFACE_VERSION, "test_fingerprint_mismatch", "0.1.0", f, Register};
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const tether::PluginDescription* tether_plugin_entry() {
  static const tether::PluginDescription description = Describe();
  return &description;
}
