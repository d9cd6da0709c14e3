// Loads fine on its own, but claims the tag of dup_tag_a.cc (TEST_SHARED_TAG) under another
// type name: loading it after test_dup_a must be refused, naming both plugins.
#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestDupB", "TEST_SHARED_TAG"));
}

}  // namespace

TETHER_PLUGIN("test_dup_b", "0.1.0", Register)
