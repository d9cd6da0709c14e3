// Example plugin "barron_loss": Barron's general and adaptive robust loss (J. T. Barron, "A
// General and Adaptive Robust Loss Function", CVPR 2019) as the robust loss "barron":
//
//   barron:SCALE:ALPHA    e.g. --robust loop=barron:1:-2; barron:SCALE takes alpha = 1,
//                         barron alone scale 1 and alpha 1
//
// Barron's loss of an error x, with shape alpha and scale c, is
//   f(x) = |alpha - 2| / alpha ((x^2 / c^2 / |alpha - 2| + 1)^(alpha / 2) - 1).
// tether's losses act on the squared whitened error s = x^2 and have rho'(0) = 1, so this is
// rho(s) = 2 c^2 f(sqrt(s)); with b = |alpha - 2| and u = s / (b c^2):
//   rho   = 2 c^2 b / alpha ((1 + u)^(alpha / 2) - 1) = 2 c^2 b / alpha expm1(alpha / 2 log1p(u))
//   rho'  = (1 + u)^(alpha / 2 - 1)
//   rho'' = rho' (alpha - 2) / (2 (b c^2 + s))
// alpha 2 is least squares (rho = s), 1 pseudo-Huber 2 c^2 (sqrt(1 + s / c^2) - 1), 0 the
// limit 2 c^2 log(1 + s / (2 c^2)) (Cauchy), -2 Geman-McClure 4 c^2 s / (4 c^2 + s), and
// alpha -> -inf the limit 2 c^2 (1 - exp(-s / (2 c^2))) (Welsch); the smaller alpha, the less
// an outlier weighs. 2 and -inf have branches of their own, 0 only in rho (rho' and rho'' are
// regular there); expm1 and log1p keep alpha near 0 and near 2 exact.
#include <cmath>
#include <memory>
#include <string>

#include "tether/core/error.h"
#include "tether/plugins/plugin.h"

namespace {

// ---- the loss (lines counted in docs/writing-a-factor-plugin.md) ----
struct BarronLoss : tether::LossFunction {
  BarronLoss(double c, double alpha) : c(c), a(alpha), b(std::abs(alpha - 2)) {
    if (!(alpha < HUGE_VAL)) throw tether::InvalidArgument("alpha must be below infinity (-inf: Welsch's loss)");
  }
  std::string name() const override { return tether::LossName("barron", c, a); }
  void Evaluate(double s, double rho[3]) const override {
    const double c2 = c * c;
    if (a == 2) {  // least squares
      rho[0] = s, rho[1] = 1, rho[2] = 0;
    } else if (std::isinf(a)) {  // alpha = -inf: Welsch
      rho[1] = std::exp(-s / (2 * c2)), rho[2] = -rho[1] / (2 * c2);
      rho[0] = -2 * c2 * std::expm1(-s / (2 * c2));
    } else {
      const double l = std::log1p(s / (b * c2));
      rho[0] = 2 * c2 * (a == 0 ? l : b / a * std::expm1(a / 2 * l));  // alpha = 0: the limit, log(1 + u)
      rho[1] = std::exp((a / 2 - 1) * l);
      rho[2] = rho[1] * (a - 2) / (2 * (b * c2 + s));
    }
  }
  double c, a, b;  // the scale, alpha and |alpha - 2|
};

void Register(tether::PluginRegistrar& r) {
  tether::LossEntry e;
  e.name = "barron";
  e.parameter = "alpha";    // barron:SCALE:ALPHA
  e.default_parameter = 1;  // barron:SCALE
  e.description = "Barron's general loss: alpha 2 least squares, 1 pseudo-Huber, 0 Cauchy, -2 Geman-McClure";
  e.make = [](double c, double alpha) { return std::make_shared<BarronLoss>(c, alpha); };
  r.AddLoss(std::move(e));
}
// ---- end of the loss ----

}  // namespace

TETHER_PLUGIN("barron_loss", "1.0.0", Register)
