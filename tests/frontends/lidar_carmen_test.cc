// The CARMEN reader on generated logs: each message type, odometry from the line and
// interpolated, plain and gzip, and every malformed line reported with file:line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <sstream>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/lidar_log.h"

namespace tether {
namespace lidar {
namespace {

using testing::ErrorOf;

// "FLASER 4 1 2 3 4 <laser pose> <odometry> stamp host logger"
std::string Flaser(double stamp, const std::string& laser = "1 2 0.5", const std::string& odom = "1 2 0.5",
                   const std::string& ranges = "4 1.5 2.25 81.9 0.5") {
  std::ostringstream s;
  s.precision(17);
  s << "FLASER " << ranges << " " << laser << " " << odom << " " << stamp << " nohost " << stamp - 100 << "\n";
  return s.str();
}

std::string Odom(double stamp, double x, double y, double theta) {
  std::ostringstream s;
  s.precision(17);
  s << "ODOM " << x << " " << y << " " << theta << " 0.1 0.2 0 " << stamp << " nohost " << stamp - 100 << "\n";
  return s.str();
}

// ROBOTLASER1 with 3 ranges and 2 remissions.
std::string RobotLaser(const std::string& ranges = "3 1 2 3", const std::string& remissions = "2 0.5 0.6") {
  return "ROBOTLASER1 0 -1.5 1.5 0.75 40 0.01 0 " + ranges + " " + remissions +
         " 10.1 20 0.3 10 20 0.3 0.5 0.1 0.2 0.3 0.4 1234.5 host 34.5\n";
}

// RAWLASER1 with 3 ranges and 2 remissions (no pose on the line).
std::string RawLaser(double stamp, const std::string& ranges = "3 1 2 3", const std::string& remissions = "2 0.5 0.6") {
  std::ostringstream s;
  s.precision(17);
  s << "RAWLASER1 0 -1.5 1.5 0.75 40 0.01 0 " << ranges << " " << remissions << " " << stamp << " host " << stamp - 100
    << "\n";
  return s.str();
}

class CarmenTest : public testing::LidarFilesTest {};

TEST_F(CarmenTest, FlaserGivesRangesAnglesStampAndLineOdometry) {
  const std::string path = Write("a.clf", "# a comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n\n" +
                                              Flaser(1000.25, "1.1 2 0.5", "1 2 0.5") + "SYNC x\nNEFF 3\n");
  const LidarLog log = ReadCarmenLog(path);
  ASSERT_EQ(log.scans.size(), 1u);
  const LaserScan& s = log.scans[0];
  EXPECT_EQ(log.format, LogFormat::kCarmen);
  EXPECT_DOUBLE_EQ(s.stamp, 1000.25);
  EXPECT_DOUBLE_EQ(s.logger_stamp, 900.25);
  EXPECT_EQ(s.source_index, 4);
  ASSERT_EQ(s.ranges.size(), 4u);
  EXPECT_FLOAT_EQ(s.ranges[1], 2.25f);
  // 4 beams over pi, the first and the last on the edges.
  EXPECT_DOUBLE_EQ(s.angle_min, -M_PI / 2);
  EXPECT_DOUBLE_EQ(s.angle_increment, M_PI / 3);
  EXPECT_NEAR(s.Angle(3), M_PI / 2, 1e-15);
  EXPECT_DOUBLE_EQ(s.range_max, 80.0);
  EXPECT_TRUE(s.Valid(0));
  EXPECT_FALSE(s.Valid(2));  // 81.9: no return
  EXPECT_EQ(s.ValidCount(), 3u);
  EXPECT_EQ(s.odometry_origin, OdometryOrigin::kScanLine);
  EXPECT_DOUBLE_EQ(s.odometry.x(), 1);
  EXPECT_DOUBLE_EQ(s.odometry.theta(), 0.5);
  // The laser sits 0.1 m along the robot's world x axis: in the robot's frame, rotated by -0.5.
  EXPECT_NEAR(s.laser_in_robot.x(), 0.1 * std::cos(0.5), 1e-12);
  EXPECT_NEAR(s.laser_in_robot.y(), -0.1 * std::sin(0.5), 1e-12);
  EXPECT_NEAR(s.laser_in_robot.theta(), 0, 1e-15);
}

TEST_F(CarmenTest, FlaserOptionsSetFieldOfViewAndMaximumRange) {
  LidarReadOptions o;
  o.flaser_fov = M_PI / 2;
  o.flaser_max_range = 2;
  o.limits.min_range = 1.0;
  const LidarLog log = ReadCarmenLog(Write("a.clf", Flaser(1)), o);
  const LaserScan& s = log.scans.at(0);
  EXPECT_DOUBLE_EQ(s.angle_min, -M_PI / 4);
  EXPECT_DOUBLE_EQ(s.angle_increment, M_PI / 6);
  EXPECT_DOUBLE_EQ(s.range_max, 2);
  EXPECT_DOUBLE_EQ(s.range_min, 1);
  EXPECT_EQ(s.ValidCount(), 1u);  // 1.5 only: 2.25 and 81.9 too far, 0.5 too near
}

TEST_F(CarmenTest, RobotLaser1FollowsItsOwnLayout) {
  const LidarLog log = ReadCarmenLog(Write("r.log", RobotLaser()));
  ASSERT_EQ(log.scans.size(), 1u);
  const LaserScan& s = log.scans[0];
  EXPECT_DOUBLE_EQ(s.angle_min, -1.5);
  EXPECT_DOUBLE_EQ(s.angle_increment, 0.75);
  EXPECT_DOUBLE_EQ(s.range_max, 40);
  ASSERT_EQ(s.ranges.size(), 3u);
  EXPECT_FLOAT_EQ(s.ranges[2], 3.0f);
  EXPECT_DOUBLE_EQ(s.stamp, 1234.5);
  EXPECT_DOUBLE_EQ(s.logger_stamp, 34.5);
  EXPECT_DOUBLE_EQ(s.odometry.x(), 10);
  EXPECT_DOUBLE_EQ(s.odometry.y(), 20);
  EXPECT_DOUBLE_EQ(s.odometry.theta(), 0.3);
  EXPECT_NEAR(s.laser_in_robot.x(), 0.1 * std::cos(0.3), 1e-12);
  EXPECT_EQ(s.odometry_origin, OdometryOrigin::kScanLine);
  // Without remissions the layout still holds.
  EXPECT_EQ(ReadCarmenLog(Write("r0.log", RobotLaser("3 1 2 3", "0"))).scans.size(), 1u);
}

TEST_F(CarmenTest, RawLaser1TakesItsOdometryFromOdomLinesWhereThereAreAny) {
  // Without ODOM lines: no odometry at all, whatever kAuto finds.
  const LidarLog bare = ReadCarmenLog(Write("raw.log", "# raw\n" + RawLaser(10) + RawLaser(10.5, "3 1 2 3", "0")));
  ASSERT_EQ(bare.scans.size(), 2u);
  const LaserScan& s = bare.scans[0];
  EXPECT_DOUBLE_EQ(s.angle_min, -1.5);
  EXPECT_DOUBLE_EQ(s.angle_increment, 0.75);
  EXPECT_DOUBLE_EQ(s.range_max, 40);
  EXPECT_DOUBLE_EQ(s.range_min, 0);
  ASSERT_EQ(s.ranges.size(), 3u);
  EXPECT_FLOAT_EQ(s.ranges[2], 3.0f);
  EXPECT_DOUBLE_EQ(s.stamp, 10);
  EXPECT_DOUBLE_EQ(s.logger_stamp, -90);
  EXPECT_EQ(s.source_index, 2);
  EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
  EXPECT_EQ(s.odometry.translation(), Eigen::Vector2d::Zero());
  EXPECT_EQ(s.laser_in_robot.translation(), Eigen::Vector2d::Zero());
  EXPECT_EQ(bare.scans[1].odometry_origin, OdometryOrigin::kNone);
  EXPECT_EQ(bare.clamped_odometry, 0u);
  // kInterpolated insists on ODOM lines; kScanLine on poses on the scan lines.
  LidarReadOptions o;
  o.odometry = OdometrySource::kInterpolated;
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadCarmenLog(P("raw.log"), o); }).find("no odometry messages"),
            std::string::npos);
  o.odometry = OdometrySource::kScanLine;
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadCarmenLog(P("raw.log"), o); }).find("scan 2 carries no odometry"),
            std::string::npos);
  // With ODOM lines: interpolated (kAuto and kInterpolated alike), clamped outside them.
  const std::string path = Write("odom.log", Odom(10, 0, 0, 0) + RawLaser(10.25) + Odom(11, 2, 0, 1) + RawLaser(12));
  for (OdometrySource source : {OdometrySource::kAuto, OdometrySource::kInterpolated}) {
    o.odometry = source;
    const LidarLog log = ReadCarmenLog(path, o);
    ASSERT_EQ(log.scans.size(), 2u);
    EXPECT_EQ(log.scans[0].odometry_origin, OdometryOrigin::kInterpolated);
    EXPECT_DOUBLE_EQ(log.scans[0].odometry.x(), 0.5);
    EXPECT_DOUBLE_EQ(log.scans[0].odometry.theta(), 0.25);
    EXPECT_EQ(log.scans[1].odometry_origin, OdometryOrigin::kClamped);
    EXPECT_DOUBLE_EQ(log.scans[1].odometry.x(), 2);
    EXPECT_EQ(log.clamped_odometry, 1u);
  }
  // ReadLidarLog takes it for a CARMEN log too.
  EXPECT_EQ(ReadLidarLog(path).scans.size(), 2u);
}

TEST_F(CarmenTest, OdometryNoneDropsEveryScansOdometry) {
  const std::string path =
      Write("f.clf", Odom(10, 0, 0, 0) + Flaser(10.5, "1.1 2 0.5", "1 2 0.5") + Odom(11, 1, 0, 0) + RawLaser(10.5));
  LidarReadOptions o;
  o.odometry = OdometrySource::kNone;
  const LidarLog log = ReadCarmenLog(path, o);
  ASSERT_EQ(log.scans.size(), 2u);
  for (const LaserScan& s : log.scans) {
    EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
    EXPECT_EQ(s.odometry.translation(), Eigen::Vector2d::Zero());
    EXPECT_EQ(s.odometry.theta(), 0);
  }
  // The laser's pose on the robot is kept (it is not odometry), and so are the ODOM messages.
  EXPECT_NEAR(log.scans[0].laser_in_robot.x(), 0.1 * std::cos(0.5), 1e-12);
  EXPECT_EQ(log.odometry.size(), 2u);
  EXPECT_EQ(log.clamped_odometry, 0u);
  // As the default would read it: the line's pose, and the interpolated one.
  const LidarLog with = ReadCarmenLog(path);
  EXPECT_EQ(with.scans[0].odometry_origin, OdometryOrigin::kScanLine);
  EXPECT_EQ(with.scans[1].odometry_origin, OdometryOrigin::kInterpolated);
  EXPECT_DOUBLE_EQ(with.scans[1].odometry.x(), 0.5);
}

TEST_F(CarmenTest, OdometryIsInterpolatedFromOdomLinesInAnyOrder) {
  // ODOM lines out of time order (as in the intel log); scans between, before and after them.
  const std::string text = Odom(12, 2, 0, 3.0) + Odom(10, 0, 0, 0) + Odom(11, 1, 0, 3.0) + Flaser(11.25) + Flaser(9) +
                           Flaser(13) + Flaser(11);
  const std::string path = Write("o.clf", text);
  LidarReadOptions o;
  o.odometry = OdometrySource::kInterpolated;
  const LidarLog log = ReadCarmenLog(path, o);
  ASSERT_EQ(log.scans.size(), 4u);
  ASSERT_EQ(log.odometry.size(), 3u);
  EXPECT_DOUBLE_EQ(log.odometry.Sorted()[0].stamp, 10);
  const LaserScan& mid = log.scans[0];
  EXPECT_EQ(mid.odometry_origin, OdometryOrigin::kInterpolated);
  EXPECT_DOUBLE_EQ(mid.odometry.x(), 1.25);
  EXPECT_DOUBLE_EQ(mid.odometry.theta(), 3.0);
  EXPECT_EQ(log.scans[1].odometry_origin, OdometryOrigin::kClamped);
  EXPECT_DOUBLE_EQ(log.scans[1].odometry.x(), 0);
  EXPECT_EQ(log.scans[2].odometry_origin, OdometryOrigin::kClamped);
  EXPECT_DOUBLE_EQ(log.scans[2].odometry.x(), 2);
  EXPECT_EQ(log.scans[3].odometry_origin, OdometryOrigin::kInterpolated);  // exactly on an ODOM stamp
  EXPECT_DOUBLE_EQ(log.scans[3].odometry.x(), 1);
  EXPECT_EQ(log.clamped_odometry, 2u);
  // The default takes the line's own pose.
  const LidarLog line = ReadCarmenLog(path);
  EXPECT_EQ(line.scans[0].odometry_origin, OdometryOrigin::kScanLine);
  EXPECT_DOUBLE_EQ(line.scans[0].odometry.x(), 1);
  EXPECT_EQ(line.clamped_odometry, 0u);
  // No ODOM lines to interpolate from.
  EXPECT_NE(ErrorOf<ParseError>([&] {
              ReadCarmenLog(Write("n.clf", Flaser(1)), o);
            }).find("no odometry messages to interpolate from"),
            std::string::npos);
}

TEST_F(CarmenTest, GzipAndPlainGiveTheSameLog) {
  std::string text;
  for (int i = 0; i < 200; ++i) text += Odom(10 + i, i * 0.1, 0, 0) + Flaser(10.5 + i);
  const LidarLog plain = ReadCarmenLog(Write("p.clf", text));
  const LidarLog gz = ReadCarmenLog(WriteGz("p.clf.gz", text));
  ASSERT_EQ(plain.scans.size(), 200u);
  ASSERT_EQ(gz.scans.size(), 200u);
  EXPECT_EQ(gz.odometry.size(), 200u);
  for (std::size_t i = 0; i < 200; ++i) {
    EXPECT_EQ(gz.scans[i].stamp, plain.scans[i].stamp);
    EXPECT_EQ(gz.scans[i].ranges, plain.scans[i].ranges);
    EXPECT_EQ(gz.scans[i].source_index, plain.scans[i].source_index);
  }
  // ReadLidarLog recognises both as CARMEN.
  EXPECT_EQ(ReadLidarLog(P("p.clf.gz")).scans.size(), 200u);
  EXPECT_EQ(DetectLogFormat(P("p.clf.gz")), LogFormat::kCarmen);
}

TEST_F(CarmenTest, LinesLongerThanTheReadBufferAndCrLf) {
  std::string ranges = "30000";
  for (int i = 0; i < 30000; ++i) ranges += " 12.3456";
  const std::string text = Flaser(5, "1 2 0.5", "1 2 0.5", ranges);
  std::string crlf = text;
  crlf.insert(crlf.size() - 1, "\r");
  for (const std::string& path : {WriteGz("long.gz", text), Write("long.clf", crlf)}) {
    const LidarLog log = ReadCarmenLog(path);
    ASSERT_EQ(log.scans.size(), 1u) << path;
    EXPECT_EQ(log.scans[0].ranges.size(), 30000u);
    EXPECT_FLOAT_EQ(log.scans[0].ranges.back(), 12.3456f);
    EXPECT_DOUBLE_EQ(log.scans[0].stamp, 5);
  }
}

TEST_F(CarmenTest, LinesEndAtLfCrLfOrALoneCr) {
  const std::string lf = Odom(1, 0, 0, 0) + Flaser(2) + Odom(3, 1, 0, 0) + Flaser(4);
  std::string cr = lf, crlf;
  for (char& c : cr) c = c == '\n' ? '\r' : c;
  for (char c : lf) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const LidarLog a = ReadCarmenLog(Write("lf.clf", lf));
  for (const std::string& text : {cr, crlf}) {
    const LidarLog b = ReadCarmenLog(Write("other.clf", text));
    ASSERT_EQ(b.scans.size(), 2u);
    EXPECT_EQ(b.scans[1].source_index, a.scans[1].source_index);  // line 4 either way
    EXPECT_EQ(b.scans[1].ranges, a.scans[1].ranges);
  }
  // A message on a CR-only log's third line names line 3.
  std::string bad = Odom(1, 0, 0, 0) + Flaser(2) + "FLASER 2 x\n";
  for (char& c : bad) c = c == '\n' ? '\r' : c;
  const std::string m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("bad_cr.clf", bad)); });
  EXPECT_NE(m.find("bad_cr.clf:3: FLASER"), std::string::npos) << m;
}

// The message reading `text` (as file bad.clf, after a good first line) gives.
class CarmenErrorTest : public testing::LidarFilesTest {
 protected:
  std::string Error(const std::string& line) {
    const std::string path = Write("bad.clf", Odom(1, 0, 0, 0) + line);
    return ErrorOf<ParseError>([&] { ReadCarmenLog(path); });
  }
};

TEST_F(CarmenErrorTest, EveryMalformedFieldNamesFileLineAndField) {
  const struct {
    std::string line, message;
  } cases[] = {
      {"FLASER\n", "bad.clf:2: FLASER: expected at least 2 fields"},
      {"FLASER x 1 2\n", "bad.clf:2: FLASER: field 1 (number of readings) 'x' is not an integer"},
      {"FLASER -3 1 2\n", "bad.clf:2: FLASER: field 1 (number of readings) -3 is outside [0, 1048576]"},
      {"FLASER 99999999999999999999 1\n", "field 1 (number of readings) '99999999999999999999' is not an integer"},
      {"FLASER 1 2 1 2 0.5 1 2 0.5 1 h 1\n", "bad.clf:2: FLASER: a scan needs at least 2 readings"},
      {"FLASER 4 1 2 3 1 2 0.5 1 2 0.5 7 h 1\n", "bad.clf:2: FLASER: expected 15 fields (FLASER n r1..rn"},
      {Flaser(7, "1 2 0.5", "1 2 0.5", "4 1 2 abc 4"), "bad.clf:2: FLASER: field 4 (range 2) 'abc' is not a number"},
      {Flaser(7, "1 2 0.5", "1 2 0.5", "4 1 2 -3 4"), "bad.clf:2: FLASER: field 4 (range 2) -3 is negative"},
      {Flaser(7, "1 2 0.5", "1 2 0.5", "4 1 2 nan 4"), "bad.clf:2: FLASER: field 4 (range 2) 'nan' is not finite"},
      {Flaser(7, "1 2 0.5", "1 2 0.5", "4 1 2 1e999 4"), "field 4 (range 2) '1e999' is not finite"},
      {Flaser(7, "1 2 0.5x", "1 2 0.5"), "bad.clf:2: FLASER: field 8 (theta) '0.5x' is not a number"},
      {Flaser(7, "1 2 0.5", "1 y 0.5"), "bad.clf:2: FLASER: field 10 (odom_y) 'y' is not a number"},
      {"FLASER 2 1 2 1 2 0.5 1 2 0.5 t h 1\n", "bad.clf:2: FLASER: field 10 (ipc_timestamp) 't' is not a number"},
      {"FLASER 2 1 2 1 2 0.5 1 2 0.5 1 h l\n", "bad.clf:2: FLASER: field 12 (logger_timestamp) 'l' is not a number"},
      {"ODOM 1 2 3\n", "bad.clf:2: ODOM: expected 10 fields (ODOM x y theta tv rv accel"},
      {"ODOM 1 2 3 4 5 6 7 h 8 9\n", "bad.clf:2: ODOM: expected 10 fields"},
      {"ODOM 1 2 z 4 5 6 7 h 8\n", "bad.clf:2: ODOM: field 3 (theta) 'z' is not a number"},
      {"ODOM 1 2 3 4 5 6 t h 8\n", "bad.clf:2: ODOM: field 7 (ipc_timestamp) 't' is not a number"},
      {"ROBOTLASER1 0 -1.5 3\n", "bad.clf:2: ROBOTLASER1: expected at least 9 fields"},
      {RobotLaser("3 1 2 3", "3 0.5 0.6"), "bad.clf:2: ROBOTLASER1: expected 30 fields"},
      {RobotLaser("3 1 2 3", "x"), "bad.clf:2: ROBOTLASER1: field 12 (number of remissions) 'x' is not an integer"},
      {RobotLaser("4 1 2 3", "0"), "bad.clf:2: ROBOTLASER1: field 13 (number of remissions) '10.1' is not an integer"},
      {RobotLaser("3 1 q 3"), "bad.clf:2: ROBOTLASER1: field 10 (range 1) 'q' is not a number"},
      {RobotLaser("3 1 2 3", "2 0.5 r"), "bad.clf:2: ROBOTLASER1: field 14 (remission) 'r' is not a number"},
      {"ROBOTLASER1 0 -1.5 3.0 0 40 0.01 0 3 1 2 3 0 10.1 20 0.3 10 20 0.3 0.5 0.1 0.2 0.3 0.4 1 h 3\n",
       "bad.clf:2: ROBOTLASER1: field 4 (angular_resolution) must be positive"},
      {"ROBOTLASER1 0 -1.5 1.4 0.7 -1 0.01 0 3 1 2 3 0 10.1 20 0.3 10 20 0.3 0.5 0.1 0.2 0.3 0.4 1 h 3\n",
       "bad.clf:2: ROBOTLASER1: field 5 (maximum_range) must be positive"},
      {"ROBOTLASER1 0 -1.5 1.4 0.7 40 0.01 0 3 1 2 3 0 10.1 20 0.3 10 20 0.3 0.5 0.1 0.2 0.3 0.4 1 h 3 extra\n",
       "bad.clf:2: ROBOTLASER1: expected 27 fields"},
      {"ROBOTLASER1 0 -1.5 1.4 0.7 40 0.01 0 3 1 2 3 0 10.1 20 0.3 10 20 0.3 0.5 v 0.2 0.3 0.4 1 h 3\n",
       "bad.clf:2: ROBOTLASER1: field 20 (rv) 'v' is not a number"},
      {"RAWLASER1 0 -1.5 3\n", "bad.clf:2: RAWLASER1: expected at least 9 fields (RAWLASER1 laser_type"},
      {RawLaser(7, "3 1 2 3", "3 0.5 0.6"), "bad.clf:2: RAWLASER1: expected 19 fields"},
      {RawLaser(7, "3 1 2 3", "2 0.5 0.6 0.7"), "bad.clf:2: RAWLASER1: expected 18 fields"},
      {RawLaser(7, "3 1 2 3", "x"), "bad.clf:2: RAWLASER1: field 12 (number of remissions) 'x' is not an integer"},
      {RawLaser(7, "1 2", "0"), "bad.clf:2: RAWLASER1: a scan needs at least 2 readings, the line says 1"},
      {RawLaser(7, "3 1 -2 3"), "bad.clf:2: RAWLASER1: field 10 (range 1) -2 is negative"},
      {RawLaser(7, "3 1 2 3", "2 0.5 e"), "bad.clf:2: RAWLASER1: field 14 (remission) 'e' is not a number"},
      {"RAWLASER1 0 -1.5 3.0 0 40 0.01 0 3 1 2 3 0 7 h 3\n",
       "bad.clf:2: RAWLASER1: field 4 (angular_resolution) must be positive"},
      {"RAWLASER1 0 -1.5 1.4 0.7 0 0.01 0 3 1 2 3 0 7 h 3\n",
       "bad.clf:2: RAWLASER1: field 5 (maximum_range) must be positive"},
      {"RAWLASER1 0 -1.5 -3 0.7 40 0.01 0 3 1 2 3 0 7 h 3\n",
       "bad.clf:2: RAWLASER1: field 3 (field_of_view) must be positive"},
      {"RAWLASER1 0 -1.5 1.4 0.7 40 0.01 0 3 1 2 3 0 t h 3\n",
       "bad.clf:2: RAWLASER1: field 13 (ipc_timestamp) 't' is not a number"},
      {"RAWLASER1 0 -1.5 1.4 0.7 40 0.01 0 3 1 2 3 0 7 h l\n",
       "bad.clf:2: RAWLASER1: field 15 (logger_timestamp) 'l' is not a number"},
      {"RAWLASER1 0 -1.5 1.4 0.7 40 0.01 0 3 1 2 3 0 7 h\n", "bad.clf:2: RAWLASER1: expected 16 fields"},
  };
  for (const auto& c : cases) {
    const std::string message = Error(c.line);
    EXPECT_NE(message.find(c.message), std::string::npos) << "line: " << c.line << "\nmessage: " << message;
    EXPECT_NE(message.find(P("bad.clf") + ":2:"), std::string::npos) << message;
  }
}

// Values each finite but beyond any sensor or robot (a hostile or damaged log): refused with
// file:line before they reach the map (cell indices beyond int, rays of billions of cells).
TEST_F(CarmenErrorTest, AbsurdGeometryRangesPosesAndStampsAreRefused) {
  const std::string tail = " 10.1 20 0.3 10 20 0.3 0.5 0.1 0.2 0.3 0.4 1234.5 host 34.5\n";
  const struct {
    std::string line, message;
  } cases[] = {
      {"ROBOTLASER1 0 -1.5 1.5 0.75 1e300 0.01 0 3 1 2 3 0" + tail, "the maximum range 1e+300 m must be"},
      {"ROBOTLASER1 0 -1.5 1.5 0.75 1001 0.01 0 3 1 2 3 0" + tail, "at most 1000 m"},
      {"ROBOTLASER1 0 -1.5 1e300 1e300 40 0.01 0 3 1 2 3 0" + tail, "more than a full turn"},
      {"ROBOTLASER1 0 -1.5 2e-300 1e-300 40 0.01 0 3 1 2 3 0" + tail, "the angle step 1e-300 rad"},
      {"ROBOTLASER1 0 1e300 1.5 0.75 40 0.01 0 3 1 2 3 0" + tail, "the start angle 1e+300 rad is not within"},
      {"ROBOTLASER1 0 -1.5 3 0.75 40 0.01 0 3 1 2 3 0" + tail, "field 3 (field_of_view) 3 rad does not match 3"},
      {"ROBOTLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 0 1e5 0 0 1e8 0 0.3 0.5 0.1 0.2 0.3 0.4 1 h 3\n",
       "(robot_x robot_y robot_theta): a pose lies 1e+08 m from the origin"},
      {Flaser(7, "1 2 1e300", "1 2 0.5"), "(x y theta): a heading of 1e+300 rad is beyond"},
      {Flaser(7, "1 2 0.5", "1e30 2 0.5"), "(odom_x odom_y odom_theta): a pose lies 1e+30 m"},
      {Flaser(1e245), "field 12 (ipc_timestamp): the stamp 1e+245 is beyond"},
      {"ODOM 1e30 0 0 0 0 0 7 h 8\n", "ODOM: fields 1-3 (x y theta): a pose lies 1e+30 m from the origin"},
      {"ODOM 0 0 0 0 0 0 1e300 h 8\n", "ODOM: field 7 (ipc_timestamp): the stamp 1e+300 is beyond"},
  };
  for (const auto& c : cases) {
    const std::string message = Error(c.line);
    EXPECT_NE(message.find(c.message), std::string::npos) << "line: " << c.line << "\nmessage: " << message;
    EXPECT_NE(message.find(P("bad.clf") + ":2:"), std::string::npos) << message;
  }
  // Bytes a terminal would act on are shown escaped, never sent raw.
  const std::string escaped = Error("FLASER 2 1 \x1b[2J 1 2 0.5 1 2 0.5 1 h 1\n");
  EXPECT_NE(escaped.find("field 3 (range 1) '\\x1b[2J' is not a number"), std::string::npos) << escaped;
  EXPECT_EQ(escaped.find('\x1b'), std::string::npos);
  // Both conventions for the field of view ((n - 1) or n steps) are read.
  const std::string n_steps = "ROBOTLASER1 0 -1.5 2.25 0.75 40 0.01 0 3 1 2 3 0" + tail;
  EXPECT_EQ(ReadCarmenLog(Write("n.clf", n_steps)).scans.size(), 1u);
  // A range beyond float (and the maximum) is no return, not undefined behaviour.
  const LidarLog far = ReadCarmenLog(Write("f.clf", Flaser(7, "1 2 0.5", "1 2 0.5", "4 1e300 2 1e30 3")));
  EXPECT_FALSE(far.scans[0].Valid(0));
  EXPECT_TRUE(far.scans[0].Valid(1));
  EXPECT_FALSE(far.scans[0].Valid(2));
}

TEST_F(CarmenErrorTest, ALineLongerThan32MegabytesIsRefusedBeforeItFillsMemory) {
  const std::string huge = Odom(1, 0, 0, 0) + "FLASER 3 " + std::string(33u << 20, '1') + "\n";
  const std::string m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("huge.clf", huge)); });
  EXPECT_NE(m.find("huge.clf:2: the line is longer than 32 MB"), std::string::npos) << m.substr(0, 300);
}

TEST_F(CarmenErrorTest, ALogWithoutASingleValidBeamIsRefused) {
  // Every range 0 (low-cost scanners' "no return") or beyond the maximum.
  const std::string zeros = Flaser(7, "1 2 0.5", "1 2 0.5", "4 0 0 0 0") + Flaser(8, "1 2 0.5", "1 2 0.5", "4 0 0 0 0");
  std::string m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("z.clf", zeros)); });
  EXPECT_NE(m.find("none of the 2 scans has a valid range"), std::string::npos) << m;
  // So is a log whose every beam an option drops; the message gives the options' values.
  LidarReadOptions o;
  o.limits.max_range = 1e-9;
  m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("a.clf", Flaser(7)), o); });
  EXPECT_NE(m.find("none of the 1 scans has a valid range"), std::string::npos) << m;
  EXPECT_NE(m.find("maximum 1e-09 m"), std::string::npos) << m;
}

TEST_F(CarmenErrorTest, DamagedGzipAndMissingFiles) {
  std::string text;
  for (int i = 0; i < 2000; ++i) text += Odom(10 + i, i * 0.1, 0, 0) + Flaser(10.5 + i);
  const std::string gz = WriteGz("t.gz", text);
  const std::string bytes = Read("t.gz");
  const std::string cut = Write("cut.gz", bytes.substr(0, bytes.size() / 2));
  const std::string message = ErrorOf<ParseError>([&] { ReadCarmenLog(cut); });
  EXPECT_NE(message.find(cut + ":"), std::string::npos) << message;
  EXPECT_NE(message.find("the compressed data is damaged"), std::string::npos) << message;
  std::string flipped = bytes;
  flipped[flipped.size() - 6] ^= 0x55;  // the CRC
  const std::string crc = Write("crc.gz", flipped);
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadCarmenLog(crc); }).find("the compressed data is damaged"), std::string::npos);
  EXPECT_NE(ErrorOf<IoError>([&] { ReadCarmenLog(P("none.clf")); }).find("none.clf: cannot open the log"),
            std::string::npos);
  // Bytes after the gzip data that are not gzip are refused, naming how many; zero padding and
  // a second member (as `cat a.gz b.gz` makes) are read as gzip -d reads them.
  const LidarLog whole = ReadCarmenLog(gz);
  ASSERT_EQ(whole.scans.size(), 2000u);
  const std::string garbage = Write("garbage.gz", bytes + "trailing junk\n");
  const std::string m = ErrorOf<ParseError>([&] { ReadCarmenLog(garbage); });
  EXPECT_NE(m.find(garbage + ":"), std::string::npos) << m;
  EXPECT_NE(m.find("14 bytes after the end of the gzip data are not gzip"), std::string::npos) << m;
  EXPECT_EQ(ReadCarmenLog(Write("padded.gz", bytes + std::string(512, '\0'))).scans.size(), 2000u);
  std::string second;
  for (int i = 2000; i < 2100; ++i) second += Odom(10 + i, i * 0.1, 0, 0) + Flaser(10.5 + i);
  WriteGz("more.gz", second);
  const std::string more_bytes = Read("more.gz");
  const LidarLog both = ReadCarmenLog(Write("both.gz", bytes + more_bytes));
  ASSERT_EQ(both.scans.size(), 2100u);
  EXPECT_DOUBLE_EQ(both.scans.back().stamp, 10.5 + 2099);
  EXPECT_NE(ErrorOf<IoError>([&] { ReadLidarLog(P("none.clf")); }).find("cannot open the log"), std::string::npos);
}

TEST_F(CarmenErrorTest, FilesThatAreNotLaserLogs) {
  std::string binary = "FLASER 2 1 2 1 2 0.5 1 2 0.5 7 h 1\n";
  for (int i = 0; i < 64; ++i) binary += static_cast<char>((i * 37 + 11) % 256);
  std::string m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("b.clf", binary)); });
  EXPECT_NE(m.find(P("b.clf") + ":2: not a CARMEN message"), std::string::npos) << m;
  m = ErrorOf<ParseError>([&] { ReadCarmenLog(Write("l.clf", Odom(1, 0, 0, 0) + "flaser 2 1 2\n")); });
  EXPECT_NE(m.find("l.clf:2: not a CARMEN message"), std::string::npos) << m;
  // Other messages, NMEA-GGA among them, are skipped; a log of them alone has no scans.
  m = ErrorOf<ParseError>(
      [&] { ReadCarmenLog(Write("o.clf", "# c\n" + Odom(1, 0, 0, 0) + "NMEA-GGA 1 2 3\nPARAM a b\n")); });
  EXPECT_NE(m.find("o.clf: no FLASER, ROBOTLASER1 or RAWLASER1 line in 4 lines: not a laser log"), std::string::npos)
      << m;
  EXPECT_NE(ErrorOf<ParseError>([&] { ReadCarmenLog(Write("e.clf", "")); }).find("not a laser log"), std::string::npos);
  // A NUL byte inside a line is an error at that line (not a line cut in two).
  m = ErrorOf<ParseError>(
      [&] { ReadCarmenLog(Write("z.clf", Odom(1, 0, 0, 0) + std::string("FLASER 2 1 2\0 3\n", 16) + Flaser(2))); });
  EXPECT_NE(m.find("z.clf:2: a NUL byte in the line"), std::string::npos) << m;
  m = ErrorOf<IoError>([&] { ReadCarmenLog(dir_.string()); });
  EXPECT_NE(m.find("cannot read the log after line 0 (Is a directory)"), std::string::npos) << m;
}

// Damaged logs (bytes changed, cut, duplicated; deterministic) are read or refused with a
// ParseError: never another exception, never a crash (the sanitised build runs this too).
TEST_F(CarmenErrorTest, DamagedLogsAreReadOrRefusedNeverACrash) {
  const std::string good = "# log\n" + Odom(1, 0, 0, 0) + Flaser(1.5) + RobotLaser() + RawLaser(1.6) +
                           Odom(2, 1, 0, 0.5) + Flaser(1.75, "1 2 0.5", "1 2 0.5", "3 1e-3 2.5 1e2") + "PARAM x y\n";
  std::uint32_t state = 12345;
  const auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  const char alphabet[] = " \n\t\r-+.eE0123456789xFLASERODOM#nani\0\x1f\x8b";
  int read = 0, refused = 0;
  for (int round = 0; round < 1500; ++round) {
    std::string text = good;
    const int edits = 1 + static_cast<int>(next() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t at = next() % text.size();
      switch (next() % 4) {
        case 0:
          text[at] = alphabet[next() % (sizeof(alphabet) - 1)];
          break;
        case 1:
          text.erase(at, 1 + next() % 8);
          break;
        case 2:
          text.insert(at, text.substr(next() % text.size(), 1 + next() % 16));
          break;
        default:
          text.resize(at + 1);
      }
      if (text.empty()) text = "x";
    }
    const std::string path = round % 3 == 0 ? WriteGz("m.gz", text) : Write("m.clf", text);
    try {
      const LidarLog log = ReadCarmenLog(path);
      for (const LaserScan& scan : log.scans) {
        EXPECT_GE(scan.ranges.size(), 2u);
        EXPECT_TRUE(std::isfinite(scan.stamp));
      }
      ++read;
    } catch (const ParseError&) {
      ++refused;
    }
  }
  EXPECT_GT(read, 100);
  EXPECT_GT(refused, 100);
}

TEST_F(CarmenTest, UnusableOptionsAreRefused) {
  const std::string path = Write("a.clf", Flaser(1));
  const auto error = [&](const LidarReadOptions& o) {
    return ErrorOf<InvalidArgument>([&] { ReadLidarLog(path, o); });
  };
  LidarReadOptions o;
  o.limits.min_range = -1;
  EXPECT_NE(error(o).find("range limits must be finite"), std::string::npos);
  o = {};
  o.limits.min_range = 5;
  o.limits.max_range = 4;
  EXPECT_NE(error(o).find("minimum range must be below"), std::string::npos);
  o = {};
  o.flaser_max_range = 0;
  EXPECT_NE(error(o).find("flaser_max_range"), std::string::npos);
  o = {};
  o.flaser_fov = 7;
  EXPECT_NE(error(o).find("flaser_fov"), std::string::npos);
  o = {};
  o.scan_topic = "";
  EXPECT_NE(error(o).find("lidar reader: empty topic"), std::string::npos);
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "empty topic name");
  EXPECT_FALSE(o.IsValid(nullptr));
  EXPECT_TRUE(LidarReadOptions().IsValid(&why));
}

TEST(OdometrySourceNames, RoundTrip) {
  for (OdometrySource s :
       {OdometrySource::kAuto, OdometrySource::kScanLine, OdometrySource::kInterpolated, OdometrySource::kNone}) {
    OdometrySource back = OdometrySource::kAuto;
    ASSERT_TRUE(FromString(ToString(s), &back));
    EXPECT_EQ(back, s);
  }
  OdometrySource s = OdometrySource::kScanLine;
  EXPECT_FALSE(FromString("line", &s));
  EXPECT_EQ(s, OdometrySource::kScanLine);
  EXPECT_EQ(EnumNameList<OdometrySource>(), "auto, scan-line, interpolated or none");
  LogFormat f = LogFormat::kAuto;
  EXPECT_TRUE(FromString("rosbag", &f));
  EXPECT_EQ(f, LogFormat::kRosBag);
  EXPECT_STREQ(ToString(OdometryOrigin::kClamped), "clamped");
}

}  // namespace
}  // namespace lidar
}  // namespace tether
