#include "tether/frontends/lidar/tum_trajectory.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"

namespace tether {
namespace lidar {

void WriteTum(std::ostream& out, const std::vector<StampedPose2>& poses) {
  out << "# timestamp x y z qx qy qz qw\n";
  char line[256];
  for (const StampedPose2& p : poses) {
    const double h = p.pose.theta() / 2;
    std::snprintf(line, sizeof(line), "%.9f %.17g %.17g 0 0 0 %.17g %.17g\n", p.stamp, p.pose.x(), p.pose.y(),
                  std::sin(h), std::cos(h));
    out << line;
  }
}

void WriteTumFile(const std::string& path, const std::vector<StampedPose2>& poses) {
  std::ostringstream s;
  WriteTum(s, poses);
  WriteTextFile(path, s.str(), "trajectory");
}

std::vector<StampedPose2> ReadTum(std::istream& in, const std::string& name) {
  std::vector<StampedPose2> poses;
  std::string text;
  long line = 0;
  const char* fields[] = {"timestamp", "x", "y", "z", "qx", "qy", "qz", "qw"};
  while (std::getline(in, text)) {
    ++line;
    const std::size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos || text[first] == '#') continue;
    const auto fail = [&](const std::string& what) {
      throw ParseError(name + ":" + std::to_string(line) + ": " + what +
                       " (a trajectory line is: timestamp x y z qx qy qz qw)");
    };
    std::istringstream s(text);
    std::string token;
    double v[8];
    int n = 0;
    while (s >> token) {
      if (n == 8) fail("more than 8 fields");
      char* end = nullptr;
      v[n] = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0') fail(std::string(fields[n]) + " '" + token + "' is not a number");
      if (!std::isfinite(v[n])) fail(std::string(fields[n]) + " '" + token + "' is not finite");
      ++n;
    }
    if (n < 8) fail("found " + std::to_string(n) + " fields, expected 8");
    const double norm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (!(norm > 0.9 && norm < 1.1)) fail("the quaternion's norm is " + std::to_string(norm) + ", not 1");
    const double qx = v[4] / norm, qy = v[5] / norm, qz = v[6] / norm, qw = v[7] / norm;
    const double yaw = std::atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz));
    poses.push_back({v[0], SE2<double>(v[1], v[2], yaw)});
  }
  if (in.bad()) throw IoError(name + ": read error after line " + std::to_string(line));
  return poses;
}

std::vector<StampedPose2> ReadTumFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError(path + ": cannot open the trajectory (" + std::strerror(errno) + ")");
  return ReadTum(in, path);
}

}  // namespace lidar
}  // namespace tether
