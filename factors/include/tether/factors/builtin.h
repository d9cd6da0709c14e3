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
// | PosePoint3    | EDGE_SE3_TRACKXYZ         | SE3, Point3 | x y z                   |
// | PriorSE3      | EDGE_SE3_PRIOR            | SE3         | x y z qx qy qz qw       |
//
// EDGE_SE3_TRACKXYZ and EDGE_SE3_PRIOR are read and written as g2o has them, with a parameter
// id after the vertex ids naming a `PARAMS_SE3OFFSET id x y z qx qy qz qw` line (the sensor's
// pose on the robot): EDGE_SE3_TRACKXYZ pose point offset_id x y z I(6) and EDGE_SE3_PRIOR pose
// offset_id x y z qx qy qz qw I(21). An identity offset is used as it is; another offset is
// applied exactly to EDGE_SE3_TRACKXYZ (measurement P z, information R_P Omega R_P^T) and refused
// for EDGE_SE3_PRIOR. Both are written with parameter 0 and the line
// "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1" at the top of the file.
//
// and the switchable constraints of tether/factors/switchable.h (the Switch variable type,
// VERTEX_SWITCH; EDGE_SWITCH_PRIOR, EDGE_SE2_SWITCHABLE, EDGE_SE3_SWITCHABLE), and ScanMatchSE2
// (tether/factors/scan_match_se2.h: a scan against a probability grid; no g2o tag, since a
// file cannot hold the grid).
#include "tether/core/registry.h"

namespace tether {

/// Adds the built-in types to `registry` (throws if any is registered already).
void RegisterBuiltinFactors(Registry& registry);

/// The process-wide registry, with the built-in types registered on first use.
Registry& DefaultRegistry();

}  // namespace tether
