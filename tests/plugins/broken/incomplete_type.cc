// Broken on purpose: registration returns normally, but its second type is incomplete (no
// residual dimension), so the registry refuses it. The first, valid type must not be
// registered either.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestIncompleteFirstPrior", "TEST_INCOMPLETE_FIRST_PRIOR"));
  tether::FactorType bad = tether_test::PointPriorType("TestIncompleteSecondPrior", "TEST_INCOMPLETE_SECOND_PRIOR");
  bad.dim = 0;
  r.AddFactorType(bad);
}

}  // namespace

TETHER_PLUGIN("test_incomplete_type", "0.1.0", Register)
