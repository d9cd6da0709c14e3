// Broken on purpose: a new factor type that claims the built-in g2o tag EDGE_SE2. Its other
// type is valid and must not be registered either.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestDupBuiltinOkPrior", "TEST_DUP_BUILTIN_OK_PRIOR"));
  r.AddFactorType(tether_test::PointPriorType("TestDupBuiltinPrior", "EDGE_SE2"));
}

}  // namespace

TETHER_PLUGIN("test_dup_builtin_tag", "0.1.0", Register)
