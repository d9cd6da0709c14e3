#pragma once
// The relations metric of Kümmerle et al. ("On measuring the accuracy of SLAM algorithms",
// Autonomous Robots 27, 2009), as the Freiburg SLAM benchmark computes it for 2D logs.
//
// A relation (t1, t2, delta*) is the true pose of the robot at t2 in the frame of its pose at
// t1. An estimated trajectory gives delta = T(t1)^-1 T(t2); the relation's error is
// e = delta*^-1 delta, its translational error |t(e)| (m) and its rotational error |theta(e)|
// (degrees). The metric is the mean (and standard deviation) of both over the relations, and
// of their squares.
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/frontends/lidar/sensor/odometry_track.h"

namespace tether {
namespace lidar {

/// One line `t1 t2 x y z roll pitch yaw` (metres, radians); z, roll and pitch are kept but
/// must be zero for a planar relation.
struct Relation {
  double t1 = 0, t2 = 0;
  SE2<double> delta;  ///< (x, y, yaw)
  double z = 0, roll = 0, pitch = 0;
  long line = 0;
};

/// Reads a relations file. Throws ParseError "name:line: ..." on a line without 8 finite
/// numbers; IoError where the file cannot be opened.
std::vector<Relation> ReadRelations(std::istream& in, const std::string& name);
std::vector<Relation> ReadRelationsFile(const std::string& path);

struct RelationsOptions {
  /// A relation's stamp matches the trajectory's pose with the nearest stamp when they differ by
  /// at most this (seconds); otherwise the relation is unmatched and left out.
  double tolerance = 1e-3;
};

/// Mean and sample standard deviation (n - 1; 0 for fewer than two values).
struct MeanStd {
  double mean = 0, std = 0;
};
MeanStd ComputeMeanStd(const std::vector<double>& values);

struct RelationsResult {
  std::size_t relations = 0;  ///< in the file
  std::size_t matched = 0;    ///< both stamps matched a pose: the ones scored
  std::size_t unmatched = 0;  ///< relations - matched
  /// The largest |relation stamp - matched pose stamp| over the matched relations.
  double max_stamp_difference = 0;
  MeanStd translation;          ///< m
  MeanStd rotation;             ///< deg
  MeanStd translation_squared;  ///< m^2
  MeanStd rotation_squared;     ///< deg^2
  double max_translation = 0, max_rotation = 0;
  std::vector<double> translation_errors, rotation_errors;  ///< per matched relation, file order

  /// "translational 0.0229 ± 0.0131 m, rotational 0.453 ± 0.31 deg over 2984 relations ..."
  std::string Report() const;
};

/// Scores the trajectory (any order; stamps need not be unique: the first of equal stamps is
/// used) on the relations. Throws InvalidArgument on a negative or non-finite tolerance.
RelationsResult EvaluateRelations(const std::vector<StampedPose2>& trajectory, const std::vector<Relation>& relations,
                                  const RelationsOptions& options = {});

}  // namespace lidar
}  // namespace tether
