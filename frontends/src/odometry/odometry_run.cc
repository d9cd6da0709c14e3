#include "tether/frontends/odometry/odometry_run.h"

#include <cmath>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/format.h"
#include "tether/core/registry.h"

namespace tether {
namespace odometry {

std::string OdometryReport::Summary() const {
  std::ostringstream s;
  s << "odometry: " << messages << " poses over " << StringPrintf("%.1f", duration) << " s, " << steps << " steps"
    << (merged > 0 ? " (" + std::to_string(merged) + " stamps that did not advance merged)" : "") << ", "
    << StringPrintf("%.1f m driven, %.1f rad turned; ", distance, turned) << poses << " poses in the graph";
  if (sideways > 0)
    s << "; " << sideways << " steps moved sideways by over 1 cm (kept as measured; floor_sigma covers them)";
  s << "\n";
  return s.str();
}

OdometryRunResult RunOdometry(const std::vector<double>& stamps, const std::vector<SE2d>& poses,
                              OdometryFrontEndOptions options) {
  if (stamps.size() != poses.size()) {
    throw InvalidArgument("RunOdometry: " + std::to_string(stamps.size()) + " stamps for " +
                          std::to_string(poses.size()) + " poses");
  }
  if (poses.size() < 2) throw InvalidArgument("RunOdometry: the track needs at least two poses");
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const SE2d& p = poses[i];
    if (!std::isfinite(stamps[i]) || !std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.theta())) {
      throw InvalidArgument("RunOdometry: pose " + std::to_string(i) + " or its stamp is not finite");
    }
    if (i > 0 && stamps[i] < stamps[i - 1]) {
      throw InvalidArgument("RunOdometry: stamp " + std::to_string(i) + " (" + FormatDouble(stamps[i]) +
                            ") is before the one before it (" + FormatDouble(stamps[i - 1]) + ")");
    }
  }
  options.start = poses.front();
  OdometryFrontEnd front_end(options);  // throws for invalid options
  OdometryRunResult r;
  OdometryReport& rep = r.report;
  rep.messages = static_cast<int>(poses.size());
  rep.duration = stamps.back() - stamps.front();
  r.stamps.push_back(stamps.front());
  std::size_t last = 0;  // the pose the next step starts from
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const double dt = stamps[i] - stamps[last];
    if (!(dt > 0)) {  // a stamp that did not advance: its motion joins the next step's
      ++rep.merged;
      continue;
    }
    const Control u = ControlBetween(poses[last], poses[i], dt);
    const SE2d d = poses[last].Inverse() * poses[i];
    const SE2d arc = SE2d::Exp(Eigen::Vector3d(u.v * dt, 0.0, u.w * dt));
    if (std::hypot(arc.x() - d.x(), arc.y() - d.y()) > 0.01) ++rep.sideways;
    rep.distance += std::abs(u.v) * dt;
    rep.turned += std::abs(u.w) * dt;
    ++rep.steps;
    if (front_end.AddMotion(d, dt)) r.stamps.push_back(stamps[i]);
    last = i;
  }
  if (rep.steps == 0) throw InvalidArgument("RunOdometry: no stamp of the track advances; there is no motion to take");
  if (front_end.Flush()) r.stamps.push_back(stamps[last]);  // the steps after the last full pose
  front_end.TakeNew(&r.graph, &r.values);
  r.trajectory = front_end.trajectory();
  rep.poses = static_cast<int>(r.trajectory.size());
  return r;
}

}  // namespace odometry
}  // namespace tether
