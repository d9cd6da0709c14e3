#pragma once
// The kidnap detector's signals written out (kidnap_detector.h, LidarSlam2D): a CSV of every
// scan's cost, filtered cost, rise and hit fraction, and an SVG of them, as the thesis's figures
// 5.8 and 5.9 draw them.
//
// The picture, x the scan number (from 1) in three panels: the match cost (grey) and its
// filtered value (blue); the filtered value's rise over the last filtered value before its
// window (blue) against the threshold T (dashed red); the overlap with the scan before (green)
// against the independent signal's threshold (dashed orange). Each declaration is a red vertical
// line through all three (f_size - 1 scans after the break it starts the new trajectory at),
// each break a short orange tick at the bottom.
#include <string>
#include <vector>

#include "tether/frontends/lidar/mapping/kidnap_detector.h"

namespace tether {
namespace lidar {

/// "# scan t trajectory matched cost filtered ratio overlap hit_fraction cost_rule broke
/// detected" and a line per record (scan from 1, t in seconds from `first_stamp`).
std::string KidnapCsv(const std::vector<KidnapRecord>& records, double first_stamp);

/// The SVG document (starting "<svg", ending "</svg>\n").
std::string KidnapSvg(const std::vector<KidnapRecord>& records, const KidnapOptions& options);

}  // namespace lidar
}  // namespace tether
