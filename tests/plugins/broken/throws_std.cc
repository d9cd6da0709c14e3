// Broken on purpose: registration adds one valid type, then throws a std::runtime_error. The
// loader must pass the message on and register nothing (not even the valid type).
#include <stdexcept>

#include "point_prior_type.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestThrowsStdPrior", "TEST_THROWS_STD_PRIOR"));
  throw std::runtime_error("test_throws_std cannot find its calibration table");
}

}  // namespace

TETHER_PLUGIN("test_throws_std", "0.1.0", Register)
