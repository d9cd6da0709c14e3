// Broken on purpose: the description has an empty plugin name.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestUnnamedPrior", "TEST_UNNAMED_PRIOR"));
}

}  // namespace

TETHER_PLUGIN("", "0.1.0", Register)
