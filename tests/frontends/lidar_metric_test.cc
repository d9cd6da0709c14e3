// TUM trajectories (write, read back, errors), relations files and the relations metric, and
// restamping a derived log from its raw log.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/eval/relations_metric.h"
#include "tether/frontends/lidar/io/restamp.h"
#include "tether/frontends/lidar/io/tum_trajectory.h"

namespace tether {
namespace lidar {
namespace {

using testing::ErrorOf;

class TumTest : public testing::LidarFilesTest {};

TEST_F(TumTest, RoundTripKeepsStampsPositionsAndYaw) {
  const std::vector<StampedPose2> poses = {{976052857.337530, SE2<double>(1.25, -3.5, 0.3)},
                                           {976052857.5, SE2<double>(-1e-3, 1e5, -3.1)},
                                           {976052858, SE2<double>(0, 0, M_PI)}};
  WriteTumFile(P("t.txt"), poses);
  const std::vector<StampedPose2> back = ReadTumFile(P("t.txt"));
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back[i].stamp, poses[i].stamp, 1e-9);
    EXPECT_EQ(back[i].pose.x(), poses[i].pose.x());
    EXPECT_EQ(back[i].pose.y(), poses[i].pose.y());
    EXPECT_NEAR(std::abs(WrapAngle(back[i].pose.theta() - poses[i].pose.theta())), 0, 1e-15);
  }
  std::ostringstream s;
  WriteTum(s, {{1.5, SE2<double>(1, 2, M_PI / 2)}});
  EXPECT_EQ(s.str(), "# timestamp x y z qx qy qz qw\n1.500000000 1 2 0 0 0 0.70710678118654746 0.70710678118654757\n");
}

TEST_F(TumTest, ReadsQuaternionsOfAnyYawAndNormalises) {
  std::istringstream in("# header\n\n  10 1 2 0 0 0 0 1.05\n11 1 2 5 0 0 1 0\n12 0 0 0 0 0 -0.7071 0.7071\r\n");
  const std::vector<StampedPose2> p = ReadTum(in, "x.tum");
  ASSERT_EQ(p.size(), 3u);
  EXPECT_DOUBLE_EQ(p[0].stamp, 10);
  EXPECT_DOUBLE_EQ(p[0].pose.theta(), 0);
  EXPECT_DOUBLE_EQ(p[1].pose.x(), 1);
  EXPECT_NEAR(std::abs(p[1].pose.theta()), M_PI, 1e-15);  // z (5) is dropped
  EXPECT_NEAR(p[2].pose.theta(), -M_PI / 2, 1e-12);
}

TEST_F(TumTest, MalformedLinesNameFileAndLine) {
  const struct {
    std::string text, message;
  } cases[] = {
      {"1 2 3 4 5 6 7\n", "t.tum:1: found 7 fields, expected 8"},
      {"1 2 3 0 0 0 0 1\n1 2 3 0 0 0 0 1 9\n", "t.tum:2: more than 8 fields"},
      {"1 2 y 0 0 0 0 1\n", "t.tum:1: y 'y' is not a number"},
      {"# c\n1 2 3 0 0 0 0 nan\n", "t.tum:2: qw 'nan' is not finite"},
      {"1 2 3 0 0 0 0 2\n", "t.tum:1: the quaternion's norm is 2.000000, not 1"},
      {"1 2 3 0 0 0 0 0\n", "t.tum:1: the quaternion's norm is 0.000000, not 1"},
  };
  for (const auto& c : cases) {
    std::istringstream in(c.text);
    const std::string m = ErrorOf<ParseError>([&] { ReadTum(in, "t.tum"); });
    EXPECT_NE(m.find(c.message), std::string::npos) << c.text << " -> " << m;
  }
  EXPECT_NE(ErrorOf<IoError>([&] { ReadTumFile(P("none.tum")); }).find("none.tum: cannot open the trajectory"),
            std::string::npos);
}

TEST(Relations, ReadsLinesAndRefusesMalformedOnes) {
  std::istringstream in("1 2 0.5 -0.25 0 0 0 0.1\n\n# c\n3 4 1 1 0 0 0 -3\n");
  const std::vector<Relation> r = ReadRelations(in, "r.relations");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_DOUBLE_EQ(r[0].t2, 2);
  EXPECT_DOUBLE_EQ(r[0].delta.y(), -0.25);
  EXPECT_DOUBLE_EQ(r[0].delta.theta(), 0.1);
  EXPECT_EQ(r[1].line, 4);
  const struct {
    std::string text, message;
  } cases[] = {{"1 2 3\n", "r.relations:1: found 3 fields, expected 8"},
               {"1 2 3 4 5 6 7 8 9\n", "r.relations:1: more than 8 fields"},
               {"1 2 0 0 0 0 0 0\n1 t2 0 0 0 0 0 0\n", "r.relations:2: t2 't2' is not a number"},
               {"1 2 0 0 0 inf 0 0\n", "r.relations:1: roll 'inf' is not finite"}};
  for (const auto& c : cases) {
    std::istringstream bad(c.text);
    const std::string m = ErrorOf<ParseError>([&] { ReadRelations(bad, "r.relations"); });
    EXPECT_NE(m.find(c.message), std::string::npos) << c.text << " -> " << m;
  }
  EXPECT_THROW(ReadRelationsFile("/nonexistent/r.relations"), IoError);
}

TEST(Relations, MeanAndStandardDeviation) {
  const MeanStd m = ComputeMeanStd({1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(m.mean, 2.5);
  EXPECT_DOUBLE_EQ(m.std, std::sqrt(5.0 / 3.0));
  EXPECT_DOUBLE_EQ(ComputeMeanStd({7}).std, 0);
  EXPECT_DOUBLE_EQ(ComputeMeanStd({}).mean, 0);
}

// A trajectory on a circle; relations between every pose and the next two.
struct Fixture {
  std::vector<StampedPose2> truth;
  std::vector<Relation> relations;
  Fixture() {
    for (int i = 0; i < 20; ++i)
      truth.push_back({100.0 + i, SE2<double>(std::cos(0.3 * i), std::sin(0.3 * i), 0.3 * i)});
    for (int i = 0; i + 2 < 20; ++i) {
      for (int j : {i + 1, i + 2}) {
        Relation r;
        r.t1 = truth[i].stamp;
        r.t2 = truth[j].stamp;
        r.delta = truth[i].pose.Inverse() * truth[j].pose;
        relations.push_back(r);
      }
    }
  }
};

TEST(RelationsMetric, TheTruthScoresZeroAndAKnownErrorIsMeasured) {
  const Fixture f;
  const RelationsResult exact = EvaluateRelations(f.truth, f.relations);
  EXPECT_EQ(exact.relations, 36u);
  EXPECT_EQ(exact.matched, 36u);
  EXPECT_EQ(exact.unmatched, 0u);
  EXPECT_NEAR(exact.translation.mean, 0, 1e-12);
  EXPECT_NEAR(exact.rotation.mean, 0, 1e-9);
  // Pose 5 moved 0.1 m along its own x axis and turned by 2 degrees: its relations to the poses
  // after it see the turn (and the shift), those from the poses before it the shift only.
  std::vector<StampedPose2> moved = f.truth;
  const double turn = 2 * M_PI / 180;
  moved[5].pose = moved[5].pose * SE2<double>(0.1, 0, turn);
  const RelationsResult r = EvaluateRelations(moved, f.relations);
  ASSERT_EQ(r.matched, 36u);
  int affected = 0;
  for (std::size_t k = 0; k < f.relations.size(); ++k) {
    const Relation& rel = f.relations[k];
    const bool from5 = rel.t1 == 105, to5 = rel.t2 == 105;
    if (to5) {
      EXPECT_NEAR(r.translation_errors[k], 0.1, 1e-12);
      EXPECT_NEAR(r.rotation_errors[k], 2, 1e-9);
    } else if (from5) {
      // delta = (T5 M)^-1 T_j = M^-1 delta*: e = delta*^-1 M^-1 delta*, its rotation -2 deg.
      EXPECT_NEAR(r.rotation_errors[k], 2, 1e-9);
      EXPECT_GT(r.translation_errors[k], 0.05);
    } else {
      EXPECT_NEAR(r.translation_errors[k], 0, 1e-12);
    }
    affected += from5 || to5;
  }
  EXPECT_EQ(affected, 4);
  EXPECT_NEAR(r.rotation.mean, 4 * 2.0 / 36, 1e-9);
  EXPECT_NEAR(r.rotation_squared.mean, 4 * 4.0 / 36, 1e-9);
  EXPECT_NEAR(r.max_rotation, 2, 1e-9);
  double sq = 0;
  for (double e : r.translation_errors) sq += e * e;
  EXPECT_NEAR(r.translation_squared.mean, sq / 36, 1e-15);
  EXPECT_NE(r.Report().find("36 scored, 0 unmatched"), std::string::npos) << r.Report();
}

TEST(RelationsMetric, StampsMatchTheNearestPoseWithinTheTolerance) {
  const Fixture f;
  std::vector<StampedPose2> shifted = f.truth;
  for (StampedPose2& p : shifted) p.stamp += 0.0004;
  shifted.erase(shifted.begin() + 10);  // the relations of pose 10 (4 of them) have nothing to match
  RelationsOptions o;
  const RelationsResult r = EvaluateRelations(shifted, f.relations, o);
  EXPECT_EQ(r.matched, 32u);
  EXPECT_EQ(r.unmatched, 4u);
  EXPECT_NEAR(r.max_stamp_difference, 0.0004, 1e-9);
  EXPECT_NEAR(r.translation.mean, 0, 1e-12);
  o.tolerance = 0.0003;
  EXPECT_EQ(EvaluateRelations(shifted, f.relations, o).matched, 0u);
  o.tolerance = -1;
  EXPECT_THROW(EvaluateRelations(shifted, f.relations, o), InvalidArgument);
  // Order does not matter; of two poses with one stamp the first is used.
  std::vector<StampedPose2> reversed(f.truth.rbegin(), f.truth.rend());
  reversed.insert(reversed.begin(), {105, SE2<double>(50, 50, 0)});
  const RelationsResult d = EvaluateRelations(reversed, f.relations);
  EXPECT_EQ(d.matched, 36u);
  EXPECT_GT(d.max_translation, 40);
}

TEST(Restamp, FindsTheRawScanByItsRangesNearTheLoggerTime) {
  LidarLog raw, derived;
  const auto scan = [](double stamp, double logger, float r) {
    LaserScan s;
    s.stamp = stamp;
    s.logger_stamp = logger;
    s.ranges = {r, r + 1};
    s.odometry = SE2<double>(r, 0, 0);
    return s;
  };
  raw.scans = {scan(1000.001, 1.001, 1), scan(1000.002, 1.0021, 2), scan(1000.5, 1.5, 3), scan(1003, 3, 4)};
  // Logger stamps rounded to 10 ms (1.00, 1.50) and one scan with no raw scan near it.
  derived.scans = {scan(1.00, 1.00, 2), scan(1.5, 1.5, 9), scan(2, 2, 4)};
  const RestampResult r = RestampByReference(derived, raw, 0.005);
  ASSERT_EQ(r.poses.size(), 2u);
  EXPECT_DOUBLE_EQ(r.poses[0].stamp, 1000.002);  // the scan with the same ranges, not the nearest
  EXPECT_DOUBLE_EQ(r.poses[0].pose.x(), 2);      // the derived log's pose
  EXPECT_DOUBLE_EQ(r.poses[1].stamp, 1000.5);    // no same ranges: the nearest in time
  EXPECT_EQ(r.by_ranges, 1u);
  EXPECT_EQ(r.by_time, 1u);
  EXPECT_EQ(r.dropped, 1u);
  EXPECT_NEAR(r.max_time_difference, 0.0021, 1e-12);
  EXPECT_THROW(RestampByReference(derived, raw, -1), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
