// Powell's dog-leg: a trust region of radius r around the current values (Euclidean norm in
// tangent coordinates). With the linear model chi2(d) ~ chi2 + 2 g.d + d^T H d:
//   the Gauss-Newton point   d_gn = -H^-1 g           (one solve per linearisation)
//   the Cauchy point         d_sd = -(g.g / g^T H g) g (the model's minimum along -g)
// the step is d_gn where |d_gn| <= r; else d_sd cut at r where |d_sd| >= r; else the point
// at distance r on the segment from d_sd to d_gn (the "dog leg"). A rejected step only
// shrinks r: the next step is blended from the same two points, without a new solve.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "step_strategy.h"

namespace tether {
namespace internal {

namespace {

double Dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

class DogLeg : public StepStrategy {
 public:
  explicit DogLeg(const DogLegOptions& o) : o_(o), radius_(o.initial_radius) {}

  const char* display_name() const override { return "dog-leg"; }
  void Describe(IterationSummary* it) const override { it->trust_radius = radius_; }

  Step ComputeStep(StepSystem& system, std::vector<double>* delta, IterationSummary* it) override {
    Step step;
    if (system.assemblies() != linearisation_) {
      step.status = ComputePoints(system, it);
      if (step.status != LinearSolverStatus::kOk) return step;
    }
    if (radius_ == 0) radius_ = std::sqrt(Dot(gn_, gn_));  // initial_radius 0: the first GN step
    it->trust_radius = radius_;
    Blend(delta);
    step_norm_ = std::sqrt(Dot(*delta, *delta));
    system.MultiplyUndamped(*delta, &work_);
    step.predicted_decrease = -2 * Dot(system.gradient(), *delta) - Dot(*delta, work_);
    return step;
  }

  void StepAccepted(double rho) override {
    if (rho > o_.grow_above) {
      radius_ = std::min(o_.max_radius, std::max(radius_, o_.grow_factor * step_norm_));
    } else if (rho < o_.shrink_below) {
      radius_ = o_.shrink_factor * step_norm_;
    }
  }
  void StepRejected() override { radius_ = o_.shrink_factor * step_norm_; }
  bool Exhausted(const char** why) const override {
    *why = "no step lowers chi2 any further (the trust region shrank below min_radius)";
    return radius_ < o_.min_radius;
  }
  std::string Settings() const override {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "initial_radius %g%s, min_radius %g, max_radius %g, grow x%g above rho %g, shrink x%g below rho %g",
                  o_.initial_radius, o_.initial_radius == 0 ? " (first Gauss-Newton step)" : "", o_.min_radius,
                  o_.max_radius, o_.grow_factor, o_.grow_above, o_.shrink_factor, o_.shrink_below);
    return buf;
  }

 private:
  // The Gauss-Newton and Cauchy points of the current linearisation.
  LinearSolverStatus ComputePoints(StepSystem& system, IterationSummary* it) {
    const std::vector<double>& g = system.gradient();
    const std::size_t n = g.size();
    for (std::vector<double>* v : {&gn_, &sd_, &work_}) v->resize(n);
    const LinearSolverStatus status = system.Solve(0.0, &gn_, it);
    if (status != LinearSolverStatus::kOk) return status;
    system.MultiplyUndamped(g, &work_);
    const double gg = Dot(g, g), gHg = Dot(g, work_);
    // H is positive definite where the solve succeeded; guard against round-off all the same.
    const double alpha = gHg > 0 ? gg / gHg : 0.0;
    for (std::size_t i = 0; i < n; ++i) sd_[i] = -alpha * g[i];
    linearisation_ = system.assemblies();
    return status;
  }

  void Blend(std::vector<double>* delta) const {
    std::vector<double>& d = *delta;
    const double r2 = radius_ * radius_;
    const double gn2 = Dot(gn_, gn_), sd2 = Dot(sd_, sd_);
    if (gn2 <= r2) {
      d = gn_;
      return;
    }
    if (sd2 >= r2) {
      const double s = radius_ / std::sqrt(sd2);
      for (std::size_t i = 0; i < d.size(); ++i) d[i] = s * sd_[i];
      return;
    }
    // |sd + beta (gn - sd)| = r for beta in (0, 1): a beta^2 + b beta + c = 0 with c < 0.
    double a = 0, b = 0;
    for (std::size_t i = 0; i < d.size(); ++i) {
      const double e = gn_[i] - sd_[i];
      a += e * e;
      b += 2 * sd_[i] * e;
    }
    const double c = sd2 - r2;
    const double root = std::sqrt(b * b - 4 * a * c);
    // The positive root, in the form that does not cancel.
    const double beta = b > 0 ? -2 * c / (b + root) : (root - b) / (2 * a);
    for (std::size_t i = 0; i < d.size(); ++i) d[i] = sd_[i] + beta * (gn_[i] - sd_[i]);
  }

  DogLegOptions o_;
  double radius_;
  double step_norm_ = 0;    // |delta| of the last step
  int linearisation_ = -1;  // LinearSystem::assemblies() of gn_ and sd_
  std::vector<double> gn_, sd_, work_;
};

}  // namespace

std::unique_ptr<StepStrategy> MakeDogLeg(const SolverOptions& options) {
  return std::make_unique<DogLeg>(options.dogleg);
}

}  // namespace internal
}  // namespace tether
