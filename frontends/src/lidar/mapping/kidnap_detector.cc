#include "tether/frontends/lidar/mapping/kidnap_detector.h"

#include <cmath>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

bool KidnapOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& what) {
    if (why != nullptr) *why = what;
    return false;
  };
  if (filter_size < 1 || filter_size > 1000) {
    return fail("kidnap filter_size is " + std::to_string(filter_size) + "; it must lie in [1, 1000]");
  }
  if (!(std::isfinite(threshold) && threshold > 1)) {
    return fail("kidnap threshold is " + FormatDouble(threshold) + "; it must be finite and above 1");
  }
  if (!(max_overlap >= 0 && max_overlap <= 1)) {
    return fail("kidnap max_overlap is " + FormatDouble(max_overlap) + "; it must lie in [0, 1]");
  }
  if (!(hit_probability > 0.5 && hit_probability <= 1)) {
    return fail("kidnap hit_probability is " + FormatDouble(hit_probability) + "; it must lie in (0.5, 1]");
  }
  if (!(relocate_window >= 0 && relocate_window <= 100)) {
    return fail("kidnap relocate_window is " + FormatDouble(relocate_window) + "; it must lie in [0, 100] m");
  }
  if (!(relocate_max_rise >= 1 && relocate_max_rise <= 10)) {
    return fail("kidnap relocate_max_rise is " + FormatDouble(relocate_max_rise) + "; it must lie in [1, 10]");
  }
  if (!(relocate_min_score > 0 && relocate_min_score < 1)) {
    return fail("kidnap relocate_min_score is " + FormatDouble(relocate_min_score) + "; it must lie in (0, 1)");
  }
  return true;
}

KidnapDetector::KidnapDetector(const KidnapOptions& options) : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("KidnapOptions: " + why);
}

void KidnapDetector::Reset() {
  costs_.clear();
  breaks_.clear();
}

KidnapStep KidnapDetector::Add(double cost, double overlap) {
  if (!std::isfinite(cost)) throw InvalidArgument("KidnapDetector::Add: the cost is not finite");
  const std::size_t f = static_cast<std::size_t>(options_.filter_size);
  KidnapStep step;
  step.cost = cost;
  step.broke = overlap >= 0 && overlap < options_.max_overlap;
  costs_.push_back(cost);
  if (costs_.size() > 2 * f) costs_.pop_front();
  breaks_.push_back(step.broke);
  if (breaks_.size() > f) breaks_.pop_front();
  // Summed afresh each scan: no rounding carried from scan to scan.
  const std::size_t n = costs_.size();
  const std::size_t now = std::min(n, f);
  double sum = 0;
  for (std::size_t i = n - now; i < n; ++i) sum += costs_[i];
  step.filtered = sum / static_cast<double>(now);
  if (n == 2 * f) {
    double before = 0;
    for (std::size_t i = 0; i < f; ++i) before += costs_[i];
    before /= static_cast<double>(f);
    step.before = before;
    if (before > 0) step.ratio = step.filtered / before;
    step.cost_rule = step.ratio > options_.threshold;
    step.detected = step.cost_rule && breaks_.front();
  }
  return step;
}

}  // namespace lidar
}  // namespace tether
