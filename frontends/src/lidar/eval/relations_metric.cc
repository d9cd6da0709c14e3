#include "tether/frontends/lidar/eval/relations_metric.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "../io/number_lines.h"
#include "tether/core/error.h"
#include "tether/core/format.h"

namespace tether {
namespace lidar {

std::vector<Relation> ReadRelations(std::istream& in, const std::string& name) {
  static const char* const kFields[] = {"t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"};
  std::vector<Relation> out;
  long line = 0;
  double v[8];
  while (internal::ReadNumberLine(in, name, kFields, 8, "a relation line is: t1 t2 x y z roll pitch yaw", &line, v)) {
    Relation r;
    r.t1 = v[0];
    r.t2 = v[1];
    r.delta = SE2<double>(v[2], v[3], v[7]);
    r.z = v[4];
    r.roll = v[5];
    r.pitch = v[6];
    r.line = line;
    out.push_back(r);
  }
  return out;
}

std::vector<Relation> ReadRelationsFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError(path + ": cannot open the relations (" + std::strerror(errno) + ")");
  return ReadRelations(in, path);
}

MeanStd ComputeMeanStd(const std::vector<double>& values) {
  MeanStd r;
  if (values.empty()) return r;
  double sum = 0;
  for (double v : values) sum += v;
  r.mean = sum / static_cast<double>(values.size());
  if (values.size() < 2) return r;
  double ss = 0;
  for (double v : values) ss += (v - r.mean) * (v - r.mean);
  r.std = std::sqrt(ss / static_cast<double>(values.size() - 1));
  return r;
}

namespace {

// The index of the pose whose stamp is nearest `t` (the earlier on a tie) in `sorted`, or -1
// where none lies within `tolerance`.
long Nearest(const std::vector<StampedPose2>& sorted, double t, double tolerance) {
  const auto it =
      std::lower_bound(sorted.begin(), sorted.end(), t, [](const StampedPose2& a, double v) { return a.stamp < v; });
  long best = -1;
  double best_d = tolerance;
  const auto consider = [&](std::vector<StampedPose2>::const_iterator c) {
    const double d = std::abs(c->stamp - t);
    if (d < best_d || (d == best_d && best < 0)) {
      best_d = d;
      best = c - sorted.begin();
    }
  };
  if (it != sorted.begin()) consider(it - 1);
  if (it != sorted.end()) consider(it);
  return best;
}

}  // namespace

RelationsResult EvaluateRelations(const std::vector<StampedPose2>& trajectory, const std::vector<Relation>& relations,
                                  const RelationsOptions& options) {
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance)) {
    throw InvalidArgument("relations metric: the stamp tolerance must be finite and not negative");
  }
  std::vector<StampedPose2> sorted = trajectory;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const StampedPose2& a, const StampedPose2& b) { return a.stamp < b.stamp; });
  // Equal stamps: the first one (in the trajectory's order) is used.
  sorted.erase(std::unique(sorted.begin(), sorted.end(),
                           [](const StampedPose2& a, const StampedPose2& b) { return a.stamp == b.stamp; }),
               sorted.end());
  RelationsResult r;
  r.relations = relations.size();
  std::vector<double> t2, r2;
  for (const Relation& rel : relations) {
    const long i = Nearest(sorted, rel.t1, options.tolerance);
    const long j = Nearest(sorted, rel.t2, options.tolerance);
    if (i < 0 || j < 0) continue;
    const StampedPose2& a = sorted[static_cast<std::size_t>(i)];
    const StampedPose2& b = sorted[static_cast<std::size_t>(j)];
    r.max_stamp_difference = std::max({r.max_stamp_difference, std::abs(a.stamp - rel.t1), std::abs(b.stamp - rel.t2)});
    const SE2<double> estimate = a.pose.Inverse() * b.pose;
    const SE2<double> error = rel.delta.Inverse() * estimate;
    const double et = error.translation().norm();
    const double er = std::abs(error.theta()) * 180.0 / M_PI;
    r.translation_errors.push_back(et);
    r.rotation_errors.push_back(er);
    t2.push_back(et * et);
    r2.push_back(er * er);
    r.max_translation = std::max(r.max_translation, et);
    r.max_rotation = std::max(r.max_rotation, er);
  }
  r.matched = r.translation_errors.size();
  r.unmatched = r.relations - r.matched;
  r.translation = ComputeMeanStd(r.translation_errors);
  r.rotation = ComputeMeanStd(r.rotation_errors);
  r.translation_squared = ComputeMeanStd(t2);
  r.rotation_squared = ComputeMeanStd(r2);
  return r;
}

std::string RelationsResult::Report() const {
  return StringPrintf(
      "relations: %zu in the file, %zu scored, %zu unmatched (no pose within the tolerance)\n"
      "translational error: %.4f +- %.4f m (max %.4f)\n"
      "rotational error:    %.3f +- %.3f deg (max %.3f)\n"
      "squared translational error: %.6f +- %.6f m^2\n"
      "squared rotational error:    %.4f +- %.4f deg^2\n"
      "relations off by more than 1 m: %zu\n",
      relations, matched, unmatched, translation.mean, translation.std, max_translation, rotation.mean, rotation.std,
      max_rotation, translation_squared.mean, translation_squared.std, rotation_squared.mean, rotation_squared.std,
      static_cast<std::size_t>(
          std::count_if(translation_errors.begin(), translation_errors.end(), [](double e) { return e > 1; })));
}

}  // namespace lidar
}  // namespace tether
