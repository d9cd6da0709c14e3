// Broken on purpose: registration adds one valid type, then throws something that is not a
// std::exception.
#include "point_prior_type.h"

namespace {

struct NotAStdException {
  int code;
};

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestThrowsNonStdPrior", "TEST_THROWS_NON_STD_PRIOR"));
  throw NotAStdException{42};
}

}  // namespace

TETHER_PLUGIN("test_throws_non_std", "0.1.0", Register)
