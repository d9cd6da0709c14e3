// Broken on purpose: a different file that calls itself "test_good", like good.cc. Loading
// both must be refused, naming the plugin and both paths.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestGoodTwinPrior", "TEST_GOOD_TWIN_PRIOR"));
}

}  // namespace

TETHER_PLUGIN("test_good", "9.9.9", Register)
