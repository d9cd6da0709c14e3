// A minimal working plugin: one factor type, TestGoodPrior (tag TEST_GOOD_PRIOR).
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestGoodPrior", "TEST_GOOD_PRIOR"));
}

}  // namespace

TETHER_PLUGIN("test_good", "0.1.0", Register)
