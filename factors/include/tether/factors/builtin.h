#pragma once
// Registration of the built-in factor types, through the same Registry calls plugins use.
//
// | name          | g2o tag                   | keys        | measurement             |
// |---------------|---------------------------|-------------|-------------------------|
// | BetweenSE2    | EDGE_SE2                  | SE2, SE2    | x y theta               |
// | BetweenSE3    | EDGE_SE3:QUAT             | SE3, SE3    | x y z qx qy qz qw       |
// | PosePoint2    | EDGE_SE2_XY               | SE2, Point2 | x y                     |
// | RangeBearing2 | EDGE_RANGE_BEARING_SE2_XY | SE2, Point2 | range bearing           |
// | PriorSE2      | EDGE_PRIOR_SE2            | SE2         | x y theta               |
// | PosePoint3    | (none)                    | SE3, Point3 | x y z                   |
// | PriorSE3      | (none)                    | SE3         | x y z qx qy qz qw       |
//
// and the switchable constraints of tether/factors/switchable.h (the Switch variable type,
// VERTEX_SWITCH; EDGE_SWITCH_PRIOR, EDGE_SE2_SWITCHABLE, EDGE_SE3_SWITCHABLE).
#include "tether/core/registry.h"

namespace tether {

/// Adds the built-in types to `registry` (throws if any is registered already).
void RegisterBuiltinFactors(Registry& registry);

/// The process-wide registry, with the built-in types registered on first use.
Registry& DefaultRegistry();

}  // namespace tether
