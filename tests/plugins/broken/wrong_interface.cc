// Broken on purpose: a hand-written entry that claims the next plugin interface version, as
// a plugin built against a newer tether would.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestWrongInterfacePrior", "TEST_WRONG_INTERFACE_PRIOR"));
}

}  // namespace

extern "C" __attribute__((visibility("default"))) const tether::PluginDescription* tether_plugin_entry() {
  static const tether::PluginDescription description = {TETHER_PLUGIN_INTERFACE_VERSION + 1, "test_wrong_interface",
                                                        "0.1.0", tether::CurrentBuildFingerprint(), Register};
  return &description;
}
