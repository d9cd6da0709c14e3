#pragma once
// Shared test helper: the public Jacobian checker (tether/core/jacobian_check.h) as
// GoogleTest expectations, one per Jacobian entry.
#include <gtest/gtest.h>

#include <vector>

#include "tether/core/jacobian_check.h"

namespace tether {
namespace testing {

/// Checks d error / d delta_k for every key of `f` at `values` with an absolute tolerance;
/// `angle_rows` marks error rows that are angles. Returns the largest absolute difference.
inline double CheckJacobians(const Factor& f, const Values& values, double tolerance,
                             const std::vector<int>& angle_rows = {}) {
  JacobianCheckOptions o;
  o.absolute_tolerance = tolerance;
  o.relative_tolerance = 0;
  o.angle_rows = angle_rows;
  const JacobianCheck c = tether::CheckJacobians(f, values, o);
  EXPECT_TRUE(c.evaluated) << f.type_name() << ": Evaluate failed";
  for (const JacobianEntry& e : c.mismatches) {
    ADD_FAILURE() << f.type_name() << ": d e[" << e.row << "] / d delta_" << e.key << "[" << e.column << "]: analytic "
                  << e.analytic << ", numeric " << e.numeric << " (tolerance " << tolerance << ")";
  }
  return c.max_abs_error;
}

}  // namespace testing
}  // namespace tether
