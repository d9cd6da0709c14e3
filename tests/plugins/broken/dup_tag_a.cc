// Loads fine on its own; dup_tag_b.cc claims the same tag (TEST_SHARED_TAG).
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestDupA", "TEST_SHARED_TAG"));
}

}  // namespace

TETHER_PLUGIN("test_dup_a", "0.1.0", Register)
