// Scanners tether has not seen: the sensor classes' settings and the class a log's own scans
// point to, the robot's body masked out of its scans, and an IMU's yaw rate as the turn of a
// scan-only prediction.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "testing/lidar_files.h"
#include "testing/synthetic_room.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/degrade_log.h"
#include "tether/frontends/lidar/io/lidar_log.h"
#include "tether/frontends/lidar/lidar_slam_2d.h"
#include "tether/frontends/lidar/sensor/body_mask.h"
#include "tether/frontends/lidar/sensor/imu_yaw.h"
#include "tether/frontends/lidar/sensor/sensor_preset.h"

namespace tether {
namespace lidar {
namespace {

using testing::ErrorOf;
using testing::Segment;

// `n` scans of `beams` beams over `fov` radians, `range_max` m, `rate` scans per second, every
// range 2 m.
std::vector<LaserScan> Scans(int n, int beams, double fov, double range_max, double rate) {
  std::vector<LaserScan> scans;
  for (int k = 0; k < n; ++k) {
    LaserScan s;
    s.stamp = 50 + k / rate;
    s.angle_min = -fov / 2;
    s.angle_increment = fov / (beams - 1);
    s.range_max = range_max;
    s.ranges.assign(static_cast<std::size_t>(beams), 2.0f);
    scans.push_back(std::move(s));
  }
  return scans;
}

// ---------------------------------------------------------------------------------------------
// Presets

TEST(SensorPreset, NamesComeFromOneTable) {
  EXPECT_EQ(EnumNameList<SensorClass>(), "auto, lds, sick or hokuyo");
  SensorClass c = SensorClass::kAuto;
  EXPECT_TRUE(FromString("hokuyo", &c));
  EXPECT_EQ(c, SensorClass::kHokuyo);
  EXPECT_FALSE(FromString("velodyne", &c));
  EXPECT_EQ(c, SensorClass::kHokuyo);
  EXPECT_STREQ(ToString(SensorClass::kLds), "lds");
  for (SensorClass s : {SensorClass::kAuto, SensorClass::kLds, SensorClass::kSick, SensorClass::kHokuyo}) {
    EXPECT_NE(SensorDescription(s), "unknown");
  }
}

TEST(SensorPreset, SickIsTheDefaultsExactly) {
  const LidarSlamOptions d, s = ForSensor(SensorClass::kSick);
  EXPECT_TRUE(s.mask.empty());
  EXPECT_EQ(s.local.limits.min_range, d.local.limits.min_range);
  EXPECT_EQ(s.local.limits.max_range, d.local.limits.max_range);
  EXPECT_EQ(s.local.matching_voxel_size, d.local.matching_voxel_size);
  EXPECT_EQ(s.local.submaps.resolution, d.local.submaps.resolution);
  EXPECT_EQ(s.local.submaps.scans_per_submap, d.local.submaps.scans_per_submap);
  EXPECT_EQ(s.local.correlative.linear_search_window, d.local.correlative.linear_search_window);
  EXPECT_EQ(s.local.correlative.angular_search_window, d.local.correlative.angular_search_window);
  EXPECT_EQ(s.local.weak_prediction_linear_window, d.local.weak_prediction_linear_window);
  EXPECT_EQ(s.local.scan_to_scan_options.max_pair_distance, d.local.scan_to_scan_options.max_pair_distance);
  EXPECT_EQ(s.pose_graph.min_score, d.pose_graph.min_score);
  EXPECT_EQ(s.pose_graph.search_voxel_size, d.pose_graph.search_voxel_size);
}

TEST(SensorPreset, EachClassHasItsOwnValuesAndAllAreValid) {
  const LidarSlamOptions lds = ForSensor(SensorClass::kLds), hokuyo = ForSensor(SensorClass::kHokuyo);
  EXPECT_DOUBLE_EQ(lds.mask.min_range, 0.15);
  EXPECT_TRUE(lds.mask.sectors.empty());
  EXPECT_DOUBLE_EQ(hokuyo.mask.min_range, 0.1);
  for (SensorClass c : {SensorClass::kLds, SensorClass::kSick, SensorClass::kHokuyo}) {
    std::string why;
    EXPECT_TRUE(ForSensor(c).IsValid(&why)) << ToString(c) << ": " << why;
  }
  const std::string m = ErrorOf<InvalidArgument>([] { ForSensor(SensorClass::kAuto); });
  EXPECT_NE(m.find("auto is a class chosen from a log's scans"), std::string::npos) << m;
}

// ---------------------------------------------------------------------------------------------
// The class from the scans' statistics

TEST(SensorChoiceTest, StatisticsOfTheScans) {
  std::vector<LaserScan> scans = Scans(41, 1081, 270 * M_PI / 180, 30, 40);
  scans[3].ranges[7] = 29.5f;
  scans[4].ranges[8] = 31.0f;  // beyond the maximum: no return, not the longest
  scans[5].ranges.resize(1000);
  scans[6].odometry_origin = OdometryOrigin::kScanLine;
  scans[7].has_imu_yaw = true;
  const ScanStatistics s = ComputeScanStatistics(scans);
  EXPECT_EQ(s.scans, 41);
  EXPECT_EQ(s.beams_min, 1000u);
  EXPECT_EQ(s.beams_max, 1081u);
  EXPECT_NEAR(s.field_of_view, 270 * M_PI / 180, 1e-12);
  EXPECT_EQ(s.max_range, 30);
  EXPECT_NEAR(s.longest_return, 29.5, 1e-6);
  EXPECT_NEAR(s.span, 1.0, 1e-9);
  EXPECT_NEAR(s.rate, 40, 1e-6);
  EXPECT_EQ(s.with_odometry, 1);
  EXPECT_EQ(s.with_imu, 1);
  // The first n scans only.
  const ScanStatistics first = ComputeScanStatistics(scans, 5);
  EXPECT_EQ(first.scans, 5);
  EXPECT_EQ(first.beams_min, 1081u);
  EXPECT_NEAR(first.longest_return, 29.5, 1e-6);
  EXPECT_EQ(ComputeScanStatistics(scans, 1000).scans, 41);
  EXPECT_EQ(ComputeScanStatistics(Scans(1, 10, 1, 5, 5)).rate, 0);
  EXPECT_THROW(ComputeScanStatistics({}), InvalidArgument);
}

TEST(SensorChoiceTest, EachClassFromItsScanner) {
  // An LDS: 360 beams over a full turn, 6 m, 5 Hz.
  SensorChoice c = ChooseSensor(ComputeScanStatistics(Scans(20, 360, 2 * M_PI * 359 / 360, 6, 5)));
  EXPECT_EQ(c.sensor, SensorClass::kLds);
  EXPECT_NE(c.why.find("maximum range 6.0 m, at most 16 m"), std::string::npos) << c.why;
  // The same beams degraded from a 180-degree log (lidar-degrade --preset lds): still lds.
  EXPECT_EQ(ChooseSensor(ComputeScanStatistics(Scans(20, 360, M_PI, 6, 5))).sensor, SensorClass::kLds);
  // A SICK LMS: 180 or 361 beams over 180 degrees, 80 m (CARMEN's FLASER) or 50 m (the bags).
  c = ChooseSensor(ComputeScanStatistics(Scans(20, 181, M_PI, 80, 10)));
  EXPECT_EQ(c.sensor, SensorClass::kSick);
  EXPECT_NE(c.why.find("over 40 m"), std::string::npos) << c.why;
  EXPECT_EQ(ChooseSensor(ComputeScanStatistics(Scans(20, 361, M_PI, 50, 75))).sensor, SensorClass::kSick);
  // A Hokuyo UTM-30LX: 1081 beams over 270 degrees, 30 m, 40 Hz.
  c = ChooseSensor(ComputeScanStatistics(Scans(20, 1081, 1.5 * M_PI, 30, 40)));
  EXPECT_EQ(c.sensor, SensorClass::kHokuyo);
  EXPECT_NE(c.why.find("over 16 m and at most 40 m"), std::string::npos) << c.why;
  // The edges.
  ScanStatistics s;
  s.max_range = kLdsMaxRange;
  EXPECT_EQ(ChooseSensor(s).sensor, SensorClass::kLds);
  s.max_range = std::nextafter(kLdsMaxRange, 100.0);
  EXPECT_EQ(ChooseSensor(s).sensor, SensorClass::kHokuyo);
  s.max_range = kHokuyoMaxRange;
  EXPECT_EQ(ChooseSensor(s).sensor, SensorClass::kHokuyo);
  s.max_range = std::nextafter(kHokuyoMaxRange, 100.0);
  EXPECT_EQ(ChooseSensor(s).sensor, SensorClass::kSick);
}

class SensorChoiceLogTest : public testing::LidarFilesTest {};

TEST_F(SensorChoiceLogTest, TheBenchmarkLogsAreSickAndTheirLowCostCopiesLds) {
  for (const char* name : {"intel", "aces", "fr079"}) {
    const std::string path = testing::LidarDataset(std::string("raw/") + name + ".clf.gz");
    if (path.empty()) GTEST_SKIP() << "dataset lidar/raw absent (../shared/datasets not beside the repository)";
    LidarLog log = ReadLidarLog(path);
    const SensorChoice c = ChooseSensor(ComputeScanStatistics(log.scans));
    EXPECT_EQ(c.sensor, SensorClass::kSick) << name << ": " << c.why;
    DegradeOptions lds;
    ASSERT_TRUE(DegradePreset("lds", &lds));
    lds.max_scans = 200;
    const SensorChoice d = ChooseSensor(ComputeScanStatistics(DegradeLog(log, lds).scans));
    EXPECT_EQ(d.sensor, SensorClass::kLds) << name << ": " << d.why;
  }
}

// ---------------------------------------------------------------------------------------------
// The body mask

TEST(BodyMaskTest, SectorsWrapAroundTheBack) {
  std::vector<AngleSector> s;
  std::string why;
  ASSERT_TRUE(ParseAngleSectors("160:200,-10:10", &s, &why)) << why;
  ASSERT_EQ(s.size(), 2u);
  const auto deg = [](double d) { return d * M_PI / 180; };
  EXPECT_TRUE(s[0].Contains(deg(180)));
  EXPECT_TRUE(s[0].Contains(deg(-170)));
  EXPECT_TRUE(s[0].Contains(deg(160)));  // edges included
  EXPECT_TRUE(s[0].Contains(deg(200 - 360)));
  EXPECT_FALSE(s[0].Contains(deg(150)));
  EXPECT_FALSE(s[0].Contains(deg(-150)));
  EXPECT_FALSE(s[0].Contains(0));
  EXPECT_TRUE(s[1].Contains(0));
  EXPECT_TRUE(s[1].Contains(deg(365)));
  EXPECT_FALSE(s[1].Contains(deg(11)));
  EXPECT_EQ(FormatAngleSectors(s), "160:200,-10:10");
  // 170 to -170 is the same sector across the back; -170 to 170 is all but it.
  ASSERT_TRUE(ParseAngleSectors("170:-170", &s, &why));
  EXPECT_TRUE(s[0].Contains(deg(180)));
  EXPECT_FALSE(s[0].Contains(0));
  ASSERT_TRUE(ParseAngleSectors("-170:170", &s, &why));
  EXPECT_FALSE(s[0].Contains(deg(180)));
  EXPECT_TRUE(s[0].Contains(0));
}

TEST(BodyMaskTest, BadSectorsSayWhy) {
  std::vector<AngleSector> s = {{1, 2}};
  std::string why;
  EXPECT_FALSE(ParseAngleSectors("", &s, &why));
  EXPECT_NE(why.find("no sector"), std::string::npos) << why;
  EXPECT_FALSE(ParseAngleSectors("160-200", &s, &why));
  EXPECT_NE(why.find("'160-200' is not a sector from:to"), std::string::npos) << why;
  EXPECT_FALSE(ParseAngleSectors("1:2:3", &s, &why));
  EXPECT_FALSE(ParseAngleSectors("10:20,", &s, &why));
  EXPECT_NE(why.find("'' is not a sector"), std::string::npos) << why;
  EXPECT_FALSE(ParseAngleSectors("a:20", &s, &why));
  EXPECT_NE(why.find("'a' in the sector 'a:20' is not a finite number"), std::string::npos) << why;
  EXPECT_FALSE(ParseAngleSectors("10:20x", &s, &why));
  EXPECT_FALSE(ParseAngleSectors("10:inf", &s, &why));
  EXPECT_FALSE(ParseAngleSectors("10:370", &s, &why));
  EXPECT_NE(why.find("has no width"), std::string::npos) << why;
  ASSERT_EQ(s.size(), 1u);  // untouched by a failure
  EXPECT_EQ(s[0].from, 1);

  BodyMask m;
  EXPECT_TRUE(m.IsValid(&why));
  EXPECT_TRUE(m.empty());
  m.min_range = -0.1;
  EXPECT_FALSE(m.IsValid(&why));
  EXPECT_NE(why.find("min_range is -0.1 m"), std::string::npos) << why;
  m.min_range = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(m.IsValid(&why));
  m.min_range = 0;
  m.sectors = {{0.5, 0.5}};
  EXPECT_FALSE(m.IsValid(&why));
  EXPECT_NE(why.find("has no width"), std::string::npos) << why;
  m.sectors = {{0.5, std::numeric_limits<double>::infinity()}};
  EXPECT_FALSE(m.IsValid(&why));
  LidarSlamOptions o;
  o.mask.min_range = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("body mask: "), std::string::npos) << why;
  EXPECT_THROW(LidarSlam2D{o}, InvalidArgument);
}

TEST(BodyMaskTest, MaskedBeamsBecomeNoReturn) {
  LaserScan s = Scans(1, 361, 2 * M_PI, 10, 10)[0];  // beam i at -180 + i degrees
  s.ranges[0] = 0.05f;
  s.ranges[1] = 0.2f;
  s.ranges[2] = std::numeric_limits<float>::quiet_NaN();  // not valid: not counted
  BodyMask m;
  EXPECT_EQ(ApplyBodyMask(m, &s), 0u);
  EXPECT_EQ(s.ValidCount(), 360u);
  m.min_range = 0.1;
  ASSERT_TRUE(ParseAngleSectors("-10:10", &m.sectors, nullptr));
  EXPECT_EQ(ApplyBodyMask(m, &s), 1u + 21u);
  EXPECT_FALSE(s.Valid(0));
  EXPECT_TRUE(s.Valid(1));
  for (int i = 170; i <= 190; ++i) EXPECT_FALSE(s.Valid(static_cast<std::size_t>(i))) << i;
  EXPECT_TRUE(s.Valid(169));
  EXPECT_TRUE(s.Valid(191));
  EXPECT_EQ(s.ValidCount(), 360u - 22u);
}

// A robot whose body the scanner sees: a mast behind the laser (the beams from 150 to 210
// degrees end at 0.25 m) and two wheel guards (the beams within 8 degrees of either side end at
// 0.12 m). Its points move with the robot: scan to scan they pair with themselves at no motion,
// and in the submaps they draw the robot's path.
void AddBody(LaserScan* s) {
  for (std::size_t i = 0; i < s->ranges.size(); ++i) {
    const double degrees = std::round(std::remainder(s->Angle(i), 2 * M_PI) * 180 / M_PI);
    if (std::abs(degrees) >= 150) s->ranges[i] = 0.25f;
    if (std::abs(std::abs(degrees) - 90) <= 8) s->ranges[i] = 0.12f;
  }
}

// Scan-only along a corridor-like room without odometry: 360 beams, 10 Hz, `n` scans 0.15 m apart
// then turning, with the robot's body in every scan where `body`.
struct BodyRun {
  std::vector<SE2d> truth;
  std::vector<LaserScan> scans;
};

BodyRun Drive(bool body, int n = 160) {
  BodyRun run;
  const std::vector<Segment> world = testing::RoomWithBoxes();
  for (int k = 0; k < n; ++k) {
    // Out along y = 6.5, a turn, back along y = 11.5.
    const double s = 0.15 * k;
    SE2d truth;
    if (s < 14) {
      truth = SE2d(4 + s, 6.5, 0);
    } else {
      const double a = std::min(M_PI, (s - 14) / 2.5);
      truth = SE2d(18 + 2.5 * std::sin(a), 9 - 2.5 * std::cos(a), a);
      if (s - 14 > 2.5 * M_PI) truth = SE2d(18 - (s - 14 - 2.5 * M_PI), 11.5, M_PI);
    }
    run.truth.push_back(truth);
    LaserScan scan;
    scan.stamp = 10 + 0.1 * k;
    scan.angle_min = -M_PI;
    scan.angle_increment = 2 * M_PI / 360;
    scan.range_max = 12;
    for (double r : testing::RayCastScan(world, truth, 360, scan.angle_min, scan.angle_increment)) {
      scan.ranges.push_back(static_cast<float>(std::isfinite(r) && r < 12 ? r : 12));
    }
    if (body) AddBody(&scan);
    run.scans.push_back(std::move(scan));
  }
  return run;
}

// The largest distance between the trajectory and the truth, both relative to their first pose.
double MaxError(const std::vector<StampedPose2>& t, const std::vector<SE2d>& truth) {
  double worst = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const SE2d a = t[0].pose.Inverse() * t[i].pose, b = truth[0].Inverse() * truth[i];
    worst = std::max(worst, (a.translation() - b.translation()).norm());
  }
  return worst;
}

std::vector<StampedPose2> Slam(const std::vector<LaserScan>& scans, const LidarSlamOptions& o,
                               LidarSlamReport* report = nullptr) {
  LidarSlam2D slam(o);
  for (const LaserScan& s : scans) slam.AddScan(s);
  slam.Finish();
  if (report != nullptr) *report = slam.report();
  return slam.Trajectory();
}

LidarSlamOptions NoLoops() {
  LidarSlamOptions o;
  o.pose_graph.loop_closure = false;
  o.pose_graph.threads = 0;
  o.self_check.sample_every = 0;
  return o;
}

TEST(BodyMaskTest, TheBodysReturnsPullTheMatchUnlessMasked) {
  const BodyRun clean = Drive(false), body = Drive(true);
  const double reference = MaxError(Slam(clean.scans, NoLoops()), clean.truth);
  const double unmasked = MaxError(Slam(body.scans, NoLoops()), body.truth);
  LidarSlamOptions masked_options = NoLoops();
  masked_options.mask.min_range = 0.15;
  ASSERT_TRUE(ParseAngleSectors("150:210", &masked_options.mask.sectors, nullptr));
  LidarSlamReport report;
  const std::vector<StampedPose2> masked = Slam(body.scans, masked_options, &report);
  EXPECT_LT(reference, 0.05);
  EXPECT_GT(unmasked, 1.0) << "the body's returns did not pull the match: the test shows nothing";
  // A quarter of the beams gone (the view behind): a little less accurate than all of them.
  EXPECT_LT(MaxError(masked, body.truth), 0.1);
  // 61 beams of the mast and 2 x 17 of the guards in every scan.
  EXPECT_EQ(report.masked_beams, static_cast<long>(body.scans.size()) * (61 + 34));
  // What the mapping saw: the scans without a body, the same beams taken out by hand.
  std::vector<LaserScan> by_hand = clean.scans;
  BodyMask beams;
  ASSERT_TRUE(ParseAngleSectors("150:210,82:98,-98:-82", &beams.sectors, nullptr));
  for (LaserScan& s : by_hand) EXPECT_LE(ApplyBodyMask(beams, &s), 95u);  // beams without a return are not counted
  const std::vector<StampedPose2> expected = Slam(by_hand, NoLoops());
  ASSERT_EQ(expected.size(), masked.size());
  for (std::size_t i = 0; i < masked.size(); ++i) {
    ASSERT_EQ(expected[i].pose.translation(), masked[i].pose.translation()) << i;
    ASSERT_EQ(expected[i].pose.theta(), masked[i].pose.theta()) << i;
  }
}

// ---------------------------------------------------------------------------------------------
// The IMU

LidarLog ImuLog(const std::vector<double>& scan_stamps, const std::vector<ImuSample>& samples) {
  LidarLog log;
  for (double t : scan_stamps) {
    LaserScan s = Scans(1, 10, 1, 5, 5)[0];
    s.stamp = t;
    log.scans.push_back(s);
  }
  log.imu.samples = samples;
  return log;
}

TEST(ImuYawTest, TheRateIntegratedAtTheScansWithTheBiasOff) {
  // 100 Hz; the robot stands for 2 s, then turns at 0.5 rad/s; the gyro reads 0.02 rad/s high.
  std::vector<ImuSample> samples;
  for (int k = 0; k <= 600; ++k) {
    const double t = 100 + 0.01 * k;
    samples.push_back({t, (t >= 102 ? 0.5 : 0.0) + 0.02});
  }
  std::swap(samples[10], samples[11]);  // out of order: sorted first
  LidarLog log = ImuLog({99.5, 100, 101, 102, 103.005, 106, 106.5}, samples);
  AttachImuYaw(1, &log);
  EXPECT_TRUE(log.imu.bias_estimated);
  EXPECT_NEAR(log.imu.bias, 0.02, 1e-12);
  EXPECT_NE(log.imu.bias_why.find("the mean of 101 messages over the first 1 s"), std::string::npos)
      << log.imu.bias_why;
  EXPECT_EQ(log.imu.scans_with_yaw, 5);
  EXPECT_FALSE(log.scans[0].has_imu_yaw);  // before the first message
  EXPECT_FALSE(log.scans[6].has_imu_yaw);  // after the last
  EXPECT_NEAR(log.scans[1].imu_yaw, 0, 1e-12);
  EXPECT_NEAR(log.scans[2].imu_yaw, 0, 1e-12);
  // The rate is taken as linear between messages: the step at 102 s is a ramp over the
  // 0.01 s before it (0.0025 rad).
  EXPECT_NEAR(log.scans[3].imu_yaw, 0.0025, 1e-9);
  // Between messages: the rate's integral up to the scan (1.005 s at 0.5 rad/s).
  EXPECT_NEAR(log.scans[4].imu_yaw, 0.0025 + 0.5025, 1e-9);
  EXPECT_NEAR(log.scans[5].imu_yaw, 0.0025 + 2.0, 1e-9);
  // No bias asked for: the 0.02 rad/s stays in.
  LidarLog raw = ImuLog({100, 106}, samples);
  AttachImuYaw(0, &raw);
  EXPECT_FALSE(raw.imu.bias_estimated);
  EXPECT_NEAR(raw.scans[1].imu_yaw, 0.0025 + 2.0 + 0.12, 1e-9);
  // Turning in the first second: no bias taken off, and the report says why.
  for (ImuSample& s : samples) s.yaw_rate += s.stamp < 101 ? 0.3 : 0;
  LidarLog turning = ImuLog({100, 106}, samples);
  AttachImuYaw(1, &turning);
  EXPECT_FALSE(turning.imu.bias_estimated);
  EXPECT_NE(turning.imu.bias_why.find("the robot turned in the first 1 s"), std::string::npos) << turning.imu.bias_why;
  // No messages: nothing changes.
  LidarLog none = ImuLog({100}, {});
  AttachImuYaw(1, &none);
  EXPECT_FALSE(none.scans[0].has_imu_yaw);
  EXPECT_EQ(none.imu.scans_with_yaw, 0);
}

TEST(ImuYawTest, AHeadingOutOfBoundsIsRefused) {
  LaserScan s = Scans(1, 10, 1, 5, 5)[0];
  s.has_imu_yaw = true;
  s.imu_yaw = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(ScanProblem(s).find("the IMU's heading"), std::string::npos) << ScanProblem(s);
  s.imu_yaw = 3;
  EXPECT_EQ(ScanProblem(s), "");
}

// The robot turns fast at the centre of a round room (testing::TurnInARoundRoom): every heading
// looks the same there, so neither scan-to-scan matching nor the submap can see the turn.
TEST(ImuYawTest, TheGyroKeepsTheHeadingWhereTheScansCannot) {
  const testing::RoundRoomTurn turn = testing::TurnInARoundRoom();
  const std::vector<LaserScan>& scans = turn.scans;
  const std::vector<double>& truth = turn.truth;
  LidarLog log;
  log.scans = scans;
  log.imu.samples = turn.imu;
  AttachImuYaw(1, &log);
  ASSERT_TRUE(log.imu.bias_estimated);
  LidarSlamReport report;
  const std::vector<StampedPose2> with = Slam(log.scans, NoLoops(), &report);
  const std::vector<StampedPose2> without = Slam(scans, NoLoops());
  EXPECT_EQ(report.imu_turns, 39);
  double with_error = 0, without_error = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    with_error = std::max(with_error, std::abs(WrapAngle(with[i].pose.theta() - truth[i])));
    without_error = std::max(without_error, std::abs(WrapAngle(without[i].pose.theta() - truth[i])));
  }
  // The grid's cells make a round room not quite round: the matches add a few hundredths of a
  // radian a scan on top of the gyro's turn.
  EXPECT_LT(with_error, 0.15);
  EXPECT_GT(without_error, 1.0) << "the scans saw the turn: the test shows nothing";
  // With odometry the IMU is not used.
  std::vector<LaserScan> odometry = log.scans;
  for (std::size_t i = 0; i < odometry.size(); ++i) {
    odometry[i].odometry = SE2d(0, 0, truth[i]);
    odometry[i].odometry_origin = OdometryOrigin::kScanLine;
  }
  Slam(odometry, NoLoops(), &report);
  EXPECT_EQ(report.imu_turns, 0);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
