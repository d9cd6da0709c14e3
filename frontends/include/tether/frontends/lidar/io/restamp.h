#pragma once
// Gives a derived log's scans the stamps of the raw log they came from. The corrected CARMEN
// logs (Radish) carry, in place of the ipc_timestamp that the benchmark's relations use, the raw
// log's logger_timestamp rounded to 6 significant digits (10 ms after 1000 s), and the intel
// log holds scans less than 10 ms apart: a scan is therefore identified by its ranges among the
// raw scans near its time.
#include <vector>

#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

struct RestampResult {
  std::vector<StampedPose2> poses;  ///< the log's odometry poses with the reference's ipc stamps
  std::size_t by_ranges = 0;        ///< matched to a reference scan with the same ranges
  std::size_t by_time = 0;          ///< no scan with the same ranges near it: the nearest in time
  std::size_t dropped = 0;          ///< no reference scan within the tolerance
  double max_time_difference = 0;   ///< |logger stamp - reference logger stamp| over the matched
};

/// For each scan of `log`: the reference scans whose logger_stamp lies within `tolerance` of
/// the scan's logger_stamp; the nearest of those whose ranges equal the scan's (to 1e-4 m), else
/// the nearest; its `stamp` replaces the scan's. Throws InvalidArgument on a negative or
/// non-finite tolerance.
RestampResult RestampByReference(const LidarLog& log, const LidarLog& reference, double tolerance);

}  // namespace lidar
}  // namespace tether
