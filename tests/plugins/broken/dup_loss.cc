// Registers a valid factor type, a loss of its own ("test_fine"), then a loss named "huber",
// which tether has built in: the load must fail and register none of them.
#include <memory>

#include "point_prior_type.h"
#include "tether/core/robust_kernels.h"

namespace {

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType("TestDupLossPrior", "TEST_DUP_LOSS_PRIOR"));
  r.AddLoss("test_fine", [](double c, double) { return std::make_shared<tether::CauchyLoss>(c); });
  r.AddLoss("huber", [](double c, double) { return std::make_shared<tether::HuberLoss>(c); });
}

}  // namespace

TETHER_PLUGIN("test_dup_loss", "0.1.0", Register)
