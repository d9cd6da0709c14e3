#pragma once
// CheckJacobians: compares a factor's analytic Jacobians with central differences taken along
// the same box-plus the solvers use (variable.h). Use it in the tests of every factor you
// write, built in or plugin:
//
//   const tether::JacobianCheck c = tether::CheckJacobians(factor, values);
//   EXPECT_TRUE(c.ok) << c.Report();
//
// Where an error row is an angle, list it in angle_rows: its differences are wrapped to
// (-pi, pi] so that a step across +-pi does not look like a jump of 2 pi.
#include <string>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/values.h"

namespace tether {

struct JacobianCheckOptions {
  double step = 1e-6;                ///< central-difference step along each tangent direction
  double absolute_tolerance = 1e-6;  ///< an entry passes if |analytic - numeric| <= this ...
  double relative_tolerance = 1e-6;  ///< ... plus this times |numeric|
  std::vector<int> angle_rows;       ///< error rows that are angles (wrapped differences)
};

/// One Jacobian entry: d error[row] / d delta_key[column].
struct JacobianEntry {
  int key = 0, row = 0, column = 0;
  double analytic = 0, numeric = 0;
};

struct JacobianCheck {
  bool ok = false;                        ///< every entry within tolerance, and every evaluation succeeded
  bool evaluated = false;                 ///< Evaluate returned true at the point and at every step
  double max_abs_error = 0;               ///< largest |analytic - numeric|
  std::vector<JacobianEntry> mismatches;  ///< the entries outside the tolerance
  /// "Range2D: d e[0] / d delta_1[1]: analytic 0.5, numeric 0.6" for each mismatch, or
  /// "Range2D: ok (largest difference 1e-10)".
  std::string Report() const;
  std::string factor;  ///< the factor's type name, for Report
};

/// Checks d error / d delta_k for every key of `f` at `values`. Throws InvalidArgument where
/// a key is missing from `values` or holds another type.
JacobianCheck CheckJacobians(const Factor& f, const Values& values, const JacobianCheckOptions& options = {});

}  // namespace tether
