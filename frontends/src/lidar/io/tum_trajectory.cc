#include "tether/frontends/lidar/io/tum_trajectory.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "number_lines.h"
#include "tether/core/error.h"
#include "tether/core/format.h"
#include "tether/core/output_file.h"

namespace tether {
namespace lidar {

void WriteTum(std::ostream& out, const std::vector<StampedPose2>& poses) {
  out << "# timestamp x y z qx qy qz qw\n";
  for (const StampedPose2& p : poses) {
    const double h = p.pose.theta() / 2;
    out << StringPrintf("%.9f %.17g %.17g 0 0 0 %.17g %.17g\n", p.stamp, p.pose.x(), p.pose.y(), std::sin(h),
                        std::cos(h));
  }
}

void WriteTumFile(const std::string& path, const std::vector<StampedPose2>& poses) {
  std::ostringstream s;
  WriteTum(s, poses);
  WriteTextFile(path, s.str(), "trajectory");
}

std::vector<StampedPose2> ReadTum(std::istream& in, const std::string& name) {
  static const char* const kFields[] = {"timestamp", "x", "y", "z", "qx", "qy", "qz", "qw"};
  std::vector<StampedPose2> poses;
  long line = 0;
  double v[8];
  while (
      internal::ReadNumberLine(in, name, kFields, 8, "a trajectory line is: timestamp x y z qx qy qz qw", &line, v)) {
    const double norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (!(norm > 0.9 && norm < 1.1)) {
      throw ParseError(name + ":" + std::to_string(line) + ": the quaternion's norm is " + std::to_string(norm) +
                       ", not 1");
    }
    const double qx = v[4] / norm, qy = v[5] / norm, qz = v[6] / norm, qw = v[7] / norm;
    const double yaw = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
    poses.push_back({v[0], SE2<double>(v[1], v[2], yaw)});
  }
  return poses;
}

std::vector<StampedPose2> ReadTumFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError(path + ": cannot open the trajectory (" + std::strerror(errno) + ")");
  return ReadTum(in, path);
}

TrajectoryError StampedTrajectoryError(const std::vector<StampedPose2>& estimate,
                                       const std::vector<StampedPose2>& truth, double tolerance) {
  // The matched poses, by their index in the estimate as Values keys.
  Values matched, reference;
  std::size_t k = 0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    while (k < truth.size() && truth[k].stamp < estimate[i].stamp - tolerance) ++k;
    if (k < truth.size() && std::abs(truth[k].stamp - estimate[i].stamp) <= tolerance) {
      matched.Insert(static_cast<Key>(i), estimate[i].pose);
      reference.Insert(static_cast<Key>(i), truth[k].pose);
    }
  }
  return AbsoluteTrajectoryError(matched, reference);
}

}  // namespace lidar
}  // namespace tether
