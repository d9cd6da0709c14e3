#include "tether/core/robust_kernels.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "tether/core/error.h"

namespace tether {
namespace {

double CheckScale(const char* kernel, double scale) {
  if (!(std::isfinite(scale) && scale > 0)) {
    throw InvalidArgument(std::string("the scale of the ") + kernel + " loss must be a finite number above 0, not " +
                          std::to_string(scale));
  }
  return scale;
}

}  // namespace

HuberLoss::HuberLoss(double delta) : delta_(CheckScale("huber", delta)) {}
std::string HuberLoss::name() const { return LossName("huber", delta_); }
void HuberLoss::Evaluate(double s, double rho[3]) const {
  const double d2 = delta_ * delta_;
  if (s <= d2) {
    rho[0] = s;
    rho[1] = 1;
    rho[2] = 0;
  } else {
    const double r = std::sqrt(s);  // the whitened error's norm
    rho[0] = 2 * delta_ * r - d2;
    rho[1] = delta_ / r;
    rho[2] = -0.5 * rho[1] / s;
  }
}

CauchyLoss::CauchyLoss(double c) : c_(CheckScale("cauchy", c)) {}
std::string CauchyLoss::name() const { return LossName("cauchy", c_); }
void CauchyLoss::Evaluate(double s, double rho[3]) const {
  const double c2 = c_ * c_;
  const double inv = 1 / (1 + s / c2);
  rho[0] = c2 * std::log1p(s / c2);
  rho[1] = inv;
  rho[2] = -inv * inv / c2;
}

TukeyLoss::TukeyLoss(double c) : c_(CheckScale("tukey", c)) {}
std::string TukeyLoss::name() const { return LossName("tukey", c_); }
void TukeyLoss::Evaluate(double s, double rho[3]) const {
  const double c2 = c_ * c_;
  if (s <= c2) {
    const double u = 1 - s / c2;
    rho[0] = c2 / 3 * (1 - u * u * u);
    rho[1] = u * u;
    rho[2] = -2 * u / c2;
  } else {
    rho[0] = c2 / 3;
    rho[1] = 0;
    rho[2] = 0;
  }
}

GemanMcClureLoss::GemanMcClureLoss(double c) : c_(CheckScale("gm", c)) {}
std::string GemanMcClureLoss::name() const { return LossName("gm", c_); }
void GemanMcClureLoss::Evaluate(double s, double rho[3]) const {
  const double c2 = c_ * c_;
  const double inv = 1 / (c2 + s);
  rho[0] = c2 * s * inv;
  rho[1] = c2 * c2 * inv * inv;
  rho[2] = -2 * rho[1] * inv;
}

DcsLoss::DcsLoss(double phi) : phi_(CheckScale("dcs", phi)) {}
std::string DcsLoss::name() const { return LossName("dcs", phi_); }
void DcsLoss::Evaluate(double s, double rho[3]) const {
  if (s <= phi_) {
    rho[0] = s;
    rho[1] = 1;
    rho[2] = 0;
  } else {
    const double inv = 1 / (phi_ + s);
    const double w = 2 * phi_ * inv;  // the scaling of the whitened error
    rho[0] = phi_ * (3 * s - phi_) * inv;
    rho[1] = w * w;
    rho[2] = -2 * rho[1] * inv;
  }
}

double RobustWeight(const LossFunction* loss, double s, double* cost) {
  if (loss == nullptr || !std::isfinite(s)) {
    if (cost) *cost = s;
    return 1;
  }
  double rho[3];
  loss->Evaluate(s, rho);
  if (cost) *cost = rho[0];
  return std::sqrt(std::max(rho[1], 0.0));
}

void RegisterBuiltinLosses(LossRegistry& registry) {
  // Each factory is given a scale checked already (finite, above 0) and no parameter.
  const auto entry = [&](const char* name, const char* description, LossFactory make) {
    LossEntry e;
    e.name = name;
    e.description = description;
    e.make = std::move(make);
    registry.Register(std::move(e));
  };
  entry("huber", "Huber: s up to SCALE^2, then linear in the error's norm",
        [](double d, double) { return std::make_shared<HuberLoss>(d); });
  entry("cauchy", "Cauchy: SCALE^2 log(1 + s / SCALE^2)",
        [](double c, double) { return std::make_shared<CauchyLoss>(c); });
  entry("tukey", "Tukey's biweight: constant beyond s = SCALE^2",
        [](double c, double) { return std::make_shared<TukeyLoss>(c); });
  entry("gm", "Geman-McClure: SCALE^2 s / (SCALE^2 + s)",
        [](double c, double) { return std::make_shared<GemanMcClureLoss>(c); });
  entry("dcs", "dynamic covariance scaling: s up to SCALE, then SCALE (3 s - SCALE) / (SCALE + s)",
        [](double phi, double) { return std::make_shared<DcsLoss>(phi); });
}

double Chi2Quantile(int k, double p) {
  // The standard normal quantile by bisection on erfc (p in (0, 1)).
  double lo = -10, hi = 10;
  for (int i = 0; i < 100; ++i) {
    const double z = 0.5 * (lo + hi);
    (0.5 * std::erfc(-z / std::sqrt(2.0)) < p ? lo : hi) = z;
  }
  const double z = 0.5 * (lo + hi), a = 2.0 / (9.0 * k);
  const double t = std::max(0.0, 1 - a + z * std::sqrt(a));  // far in the lower tail of few dof: 0
  return k * t * t * t;
}

}  // namespace tether
