#pragma once
// Absolute trajectory error (ATE): how far an estimated trajectory is from the ground truth.
//
// The positions of the poses (SE2 and SE3 variables) whose keys are in both Values are
// compared: with kRigid (the default), after the rotation and translation that best align the
// estimate to the truth in the least-squares sense (Horn / Umeyama without scale, as in the
// TUM RGB-D benchmark); with kNone, as they are (enough for a pose graph whose first pose is
// held at its true value). 2D where every compared pose is an SE2, 3D otherwise (SE2 at z = 0).
// Landmarks are not compared.
#include <string>

#include "tether/core/values.h"

namespace tether {

enum class AteAlignment {
  kNone,   ///< positions compared as they are
  kRigid,  ///< after the best rotation and translation (no scale)
};

struct TrajectoryError {
  int poses = 0;    ///< poses compared (keys that are poses in both)
  double rmse = 0;  ///< root mean square of the position errors, metres (NaN when poses == 0)
  double mean = 0;  ///< mean position error (NaN when poses == 0)
  double max = 0;   ///< largest position error (NaN when poses == 0)
};

/// The ATE of `estimate` against `truth`. Poses whose positions are not finite in either are
/// left out. Never throws; poses == 0 (and NaN errors) where nothing could be compared.
TrajectoryError AbsoluteTrajectoryError(const Values& estimate, const Values& truth,
                                        AteAlignment alignment = AteAlignment::kRigid);

/// A length for reports and legends: three significant digits and " m" ("7.03 m",
/// "0.218 m", "1.2e-05 m"); "n/a" for NaN.
std::string FormatMetres(double metres);

}  // namespace tether
