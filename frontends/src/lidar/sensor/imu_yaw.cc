#include "tether/frontends/lidar/sensor/imu_yaw.h"

#include <algorithm>
#include <cmath>

#include "tether/core/registry.h"
#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {

namespace {

// The mean rate over the first `seconds` of samples, where the robot stood still then.
void EstimateBias(double seconds, ImuTrack* imu) {
  imu->bias = 0;
  imu->bias_estimated = false;
  if (seconds <= 0) {
    imu->bias_why = "no bias taken off (none asked for)";
    return;
  }
  const double end = imu->samples.front().stamp + seconds;
  double sum = 0, squares = 0;
  long n = 0;
  for (const ImuSample& s : imu->samples) {
    if (s.stamp > end) break;
    sum += s.yaw_rate;
    squares += s.yaw_rate * s.yaw_rate;
    ++n;
  }
  const double mean = sum / static_cast<double>(n);
  const double spread = std::sqrt(std::max(0.0, squares / static_cast<double>(n) - mean * mean));
  if (n < 2) {
    imu->bias_why = "no bias taken off (one message in the first " + FormatDouble(seconds) + " s)";
  } else if (spread > kStillSpread || std::abs(mean) > kStillRate) {
    imu->bias_why = "no bias taken off (the robot turned in the first " + FormatDouble(seconds) + " s: mean " +
                    FormatFixed(mean, 4) + " rad/s, spread " + FormatFixed(spread, 4) + " rad/s)";
  } else {
    imu->bias = mean;
    imu->bias_estimated = true;
    imu->bias_why = "bias " + FormatFixed(mean, 5) + " rad/s, the mean of " + std::to_string(n) +
                    " messages over the first " + FormatDouble(seconds) + " s (standing still)";
  }
}

}  // namespace

void AttachImuYaw(double bias_seconds, LidarLog* log) {
  ImuTrack& imu = log->imu;
  imu.scans_with_yaw = 0;
  if (imu.samples.empty()) return;
  std::stable_sort(imu.samples.begin(), imu.samples.end(),
                   [](const ImuSample& a, const ImuSample& b) { return a.stamp < b.stamp; });
  EstimateBias(bias_seconds, &imu);
  // The heading at each sample.
  const std::vector<ImuSample>& s = imu.samples;
  std::vector<double> yaw(s.size(), 0.0);
  for (std::size_t k = 1; k < s.size(); ++k) {
    yaw[k] = yaw[k - 1] + 0.5 * (s[k - 1].yaw_rate + s[k].yaw_rate - 2 * imu.bias) * (s[k].stamp - s[k - 1].stamp);
  }
  for (LaserScan& scan : log->scans) {
    scan.has_imu_yaw = false;
    scan.imu_yaw = 0;
    if (scan.stamp < s.front().stamp || scan.stamp > s.back().stamp) continue;
    const auto after =
        std::lower_bound(s.begin(), s.end(), scan.stamp, [](const ImuSample& a, double t) { return a.stamp < t; });
    const std::size_t k = static_cast<std::size_t>(after - s.begin());
    if (k == 0 || s[k].stamp == scan.stamp) {
      scan.imu_yaw = yaw[k];
    } else {
      const double dt = s[k].stamp - s[k - 1].stamp;
      const double f = dt > 0 ? (scan.stamp - s[k - 1].stamp) / dt : 0;
      // The rate is linear between the two samples: its integral up to the scan.
      const double r0 = s[k - 1].yaw_rate - imu.bias;
      const double r1 = s[k].yaw_rate - imu.bias;
      const double rate_at = r0 + f * (r1 - r0);
      scan.imu_yaw = yaw[k - 1] + 0.5 * (r0 + rate_at) * (scan.stamp - s[k - 1].stamp);
    }
    scan.has_imu_yaw = true;
    ++imu.scans_with_yaw;
  }
}

}  // namespace lidar
}  // namespace tether
