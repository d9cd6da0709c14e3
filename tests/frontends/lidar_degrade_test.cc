// The degrader and the CARMEN writer: round trips, determinism for a seed, and each
// degradation's statistics.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "testing/lidar_files.h"
#include "tether/core/error.h"
#include "tether/frontends/lidar/io/carmen_reader.h"
#include "tether/frontends/lidar/io/degrade_log.h"

namespace tether {
namespace lidar {
namespace {

using testing::ErrorOf;

// A log of `scans` scans of `beams` beams over 270 degrees at 10 Hz with odometry on the
// scans' own lines, a laser 0.2 m ahead of the robot and turned a little, and odometry
// messages at 20 Hz: ranges between 0.5 and 25 m, every 7th beam no return.
LidarLog MakeLog(int scans = 40, int beams = 541) {
  LidarLog log;
  log.path = "made.clf";
  log.format = LogFormat::kCarmen;
  for (int k = 0; k <= 2 * scans + 2; ++k) {
    const double t = 1000 + 0.05 * (k - 1);
    log.odometry.Add(t, SE2<double>(0.01 * k, 0.002 * k * k, 0.013 * k));
  }
  for (int k = 0; k < scans; ++k) {
    LaserScan s;
    s.stamp = 1000 + 0.1 * k + 0.025;
    s.logger_stamp = s.stamp - 990;
    s.angle_min = -0.75 * M_PI;
    s.angle_increment = 1.5 * M_PI / (beams - 1);
    s.range_min = 0;
    s.range_max = 30;
    for (int i = 0; i < beams; ++i) {
      s.ranges.push_back(i % 7 == 3 ? 30.0f : static_cast<float>(0.5 + std::fmod(0.37 * i + 0.11 * k, 24.5)));
    }
    log.odometry.At(s.stamp, &s.odometry);
    s.odometry_origin = OdometryOrigin::kScanLine;
    s.laser_in_robot = SE2<double>(0.2, 0.01, 0.05);
    s.source_index = k + 1;
    log.scans.push_back(s);
  }
  return log;
}

class DegradeTest : public testing::LidarFilesTest {
 protected:
  // Writes `log` and reads it back (default read options unless given).
  LidarLog RoundTrip(const LidarLog& log, bool with_odometry, const LidarReadOptions& o = {}) {
    std::ostringstream text;
    WriteCarmenLog(text, log, with_odometry, "a test log\nsecond line");
    return ReadCarmenLog(Write("rt.log", text.str()), o);
  }
  static std::string Text(const LidarLog& log, bool with_odometry = true) {
    std::ostringstream text;
    WriteCarmenLog(text, log, with_odometry);
    return text.str();
  }
};

TEST_F(DegradeTest, RoundTripKeepsRangesOdometryAndTheLaserPose) {
  const LidarLog log = MakeLog();
  const LidarLog back = RoundTrip(log, true);
  ASSERT_EQ(back.scans.size(), log.scans.size());
  EXPECT_EQ(back.odometry.size(), log.odometry.size());
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    const LaserScan &a = log.scans[k], &b = back.scans[k];
    EXPECT_EQ(b.stamp, a.stamp);
    EXPECT_EQ(b.logger_stamp, a.logger_stamp);
    EXPECT_EQ(b.angle_min, a.angle_min);
    EXPECT_NEAR(b.angle_increment, a.angle_increment, 1e-15);
    EXPECT_EQ(b.range_max, a.range_max);
    ASSERT_EQ(b.ranges.size(), a.ranges.size());
    for (std::size_t i = 0; i < a.ranges.size(); ++i) {
      ASSERT_EQ(b.Valid(i), a.Valid(i)) << i;
      if (a.Valid(i)) {
        EXPECT_EQ(b.ranges[i], a.ranges[i]);  // floats read back exactly
      }
    }
    EXPECT_EQ(b.odometry_origin, OdometryOrigin::kScanLine);
    EXPECT_NEAR((b.odometry.translation() - a.odometry.translation()).norm(), 0, 1e-6);
    EXPECT_NEAR(b.odometry.theta(), a.odometry.theta(), 1e-6);
    EXPECT_NEAR((b.laser_in_robot.translation() - a.laser_in_robot.translation()).norm(), 0, 1e-6);
    EXPECT_NEAR(b.laser_in_robot.theta(), a.laser_in_robot.theta(), 1e-6);
  }
  // The ODOM lines give the same odometry by interpolation too.
  LidarReadOptions o;
  o.odometry = OdometrySource::kInterpolated;
  const LidarLog interpolated = RoundTrip(log, true, o);
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    EXPECT_EQ(interpolated.scans[k].odometry_origin, OdometryOrigin::kInterpolated);
    EXPECT_NEAR((interpolated.scans[k].odometry.translation() - log.scans[k].odometry.translation()).norm(), 0, 1e-6);
  }
  // Degrading with the default options changes no scan (the odometry messages are cropped to
  // the scans' span and one on either side).
  const LidarLog same = DegradeLog(log, DegradeOptions());
  EXPECT_TRUE(Text(same, false) == Text(log, false));
  ASSERT_EQ(log.odometry.size(), 83u);   // 999.95 to 1004.05; the scans 1000.025 to 1003.925
  EXPECT_EQ(same.odometry.size(), 80u);  // 1000 to 1003.95
}

TEST_F(DegradeTest, WithoutOdometryScansAreRawLaserLinesWithNone) {
  LidarLog log = MakeLog(6);
  log.scans[0].ranges[0] = std::nanf("");
  log.scans[0].ranges[1] = 31;
  log.scans[0].ranges[2] = 0.1f;
  log.scans[0].range_min = 0.2;
  const std::string text = Text(log, false);
  EXPECT_EQ(text.find("ODOM"), std::string::npos);
  EXPECT_EQ(text.find("ROBOTLASER1"), std::string::npos);
  EXPECT_NE(text.find("RAWLASER1"), std::string::npos);
  const LidarLog back = ReadCarmenLog(Write("raw.log", text));
  ASSERT_EQ(back.scans.size(), 6u);
  for (const LaserScan& s : back.scans) {
    EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
    EXPECT_EQ(s.laser_in_robot.translation().norm(), 0);  // RAWLASER1 carries no laser pose
  }
  // Invalid beams (NaN, beyond the maximum, below the minimum) read back invalid.
  EXPECT_FALSE(back.scans[0].Valid(0));
  EXPECT_FALSE(back.scans[0].Valid(1));
  EXPECT_FALSE(back.scans[0].Valid(2));
  EXPECT_EQ(back.scans[0].ValidCount(), log.scans[0].ValidCount());
}

TEST_F(DegradeTest, NumbersThatAreNotFiniteAreRefused) {
  LidarLog log = MakeLog(2);
  log.scans[1].odometry = SE2<double>(1.5e308, 0, 0);
  log.scans[1].laser_in_robot = SE2<double>(1.5e308, 0, 0);  // the laser's pose overflows
  std::ostringstream out;
  EXPECT_NE(ErrorOf<InvalidArgument>([&] { WriteCarmenLog(out, log, true); }).find("not finite"), std::string::npos);
  std::ostringstream raw;
  WriteCarmenLog(raw, log, false);  // RAWLASER1 lines carry no pose
}

TEST_F(DegradeTest, NoReturnStaysInvalidWhereTheMaximumIsNotAFloat) {
  // 5.6 m (a Hokuyo URG's maximum) has a nearest float below it: a no-return beam written as
  // that float would read back valid.
  const LidarLog log = MakeLog(3);
  DegradeOptions o;
  o.max_range = 5.6;
  o.noise_sigma = 0.5;
  o.drop_fraction = 0.3;
  o.error_share = 0;
  const LidarLog d = DegradeLog(log, o);
  const LidarLog back = RoundTrip(d, true);
  for (std::size_t k = 0; k < d.scans.size(); ++k) {
    for (std::size_t i = 0; i < d.scans[k].ranges.size(); ++i) {
      ASSERT_EQ(back.scans[k].Valid(i), d.scans[k].Valid(i)) << k << " " << i << " " << d.scans[k].ranges[i];
      EXPECT_TRUE(d.scans[k].Valid(i) || !(d.scans[k].ranges[i] > 0 && d.scans[k].ranges[i] < 5.6));
    }
  }
}

TEST_F(DegradeTest, TheSameSeedGivesTheSameBytes) {
  const LidarLog log = MakeLog();
  DegradeOptions o;
  ASSERT_TRUE(DegradePreset("lds", &o));
  o.seed = 42;
  const std::string a = Text(DegradeLog(log, o)), b = Text(DegradeLog(log, o));
  EXPECT_TRUE(a == b);
  o.seed = 43;
  EXPECT_FALSE(Text(DegradeLog(log, o)) == a);
  // Each scan draws from its own streams: cropping leaves the other scans' draws unchanged.
  o.seed = 42;
  const LidarLog whole = DegradeLog(log, o);
  o.first_scan = 4;
  const LidarLog cropped = DegradeLog(log, o);
  ASSERT_EQ(cropped.scans.size() + 2, whole.scans.size());
  EXPECT_EQ(cropped.scans[0].ranges.size(), whole.scans[2].ranges.size());
  for (std::size_t i = 0; i < cropped.scans[0].ranges.size(); ++i) {
    const float x = cropped.scans[0].ranges[i], y = whole.scans[2].ranges[i];
    EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << i;
  }
}

TEST_F(DegradeTest, BeamsAreResampledOverTheFieldOfView) {
  const LidarLog log = MakeLog(3, 541);
  DegradeOptions o;
  o.beams = 181;
  const LidarLog d = DegradeLog(log, o);
  const LaserScan &a = log.scans[1], &b = d.scans[1];
  ASSERT_EQ(b.ranges.size(), 181u);
  EXPECT_DOUBLE_EQ(b.angle_min, a.angle_min);
  EXPECT_NEAR(b.Angle(180), a.Angle(540), 1e-12);  // the last beam stays on the edge
  for (std::size_t j = 0; j < 181; ++j) EXPECT_EQ(b.ranges[j], a.ranges[3 * j]);
  // More beams than the scan has: the nearest beam's range, repeated.
  o.beams = 1081;
  const LaserScan c = DegradeLog(log, o).scans[1];
  ASSERT_EQ(c.ranges.size(), 1081u);
  EXPECT_NEAR(c.Angle(1080), a.Angle(540), 1e-12);
  for (std::size_t j = 0; j < 1081; ++j) {
    EXPECT_EQ(c.ranges[j], a.ranges[static_cast<std::size_t>(std::lround(j * 540.0 / 1080))]) << j;
  }
}

TEST_F(DegradeTest, MaxRangeMakesFartherBeamsNoReturn) {
  const LidarLog log = MakeLog(5);
  DegradeOptions o;
  o.max_range = 6;
  const LidarLog d = DegradeLog(log, o);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    EXPECT_EQ(d.scans[k].range_max, 6);
    for (std::size_t i = 0; i < log.scans[k].ranges.size(); ++i) {
      const bool near = log.scans[k].Valid(i) && log.scans[k].ranges[i] < 6;
      EXPECT_EQ(d.scans[k].Valid(i), near) << i;
      kept += near ? 1 : 0;
    }
  }
  EXPECT_GT(kept, 100u);
  // A limit beyond the scans' own changes nothing.
  o.max_range = 100;
  EXPECT_TRUE(Text(DegradeLog(log, o), false) == Text(log, false));
}

TEST_F(DegradeTest, NoiseHasTheSigmaAskedFor) {
  const LidarLog log = MakeLog(40);
  DegradeOptions o;
  o.noise_sigma = 0.05;
  o.seed = 9;
  const LidarLog d = DegradeLog(log, o);
  double sum = 0, squares = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    for (std::size_t i = 0; i < log.scans[k].ranges.size(); ++i) {
      if (!log.scans[k].Valid(i) || !d.scans[k].Valid(i) || log.scans[k].ranges[i] < 0.3) continue;
      const double e = d.scans[k].ranges[i] - log.scans[k].ranges[i];
      sum += e;
      squares += e * e;
      ++n;
    }
  }
  ASSERT_GT(n, 15000u);
  const double mean = sum / n, sd = std::sqrt(squares / n - mean * mean);
  EXPECT_NEAR(mean, 0, 0.003);
  EXPECT_NEAR(sd, 0.05, 0.005);  // within 10%
}

TEST_F(DegradeTest, DropsTakeTheShareAskedFor) {
  const LidarLog log = MakeLog(40);
  DegradeOptions o;
  o.drop_fraction = 0.2;
  o.error_share = 0.25;
  const LidarLog d = DegradeLog(log, o);
  std::size_t valid = 0, dropped = 0, errors = 0;
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    for (std::size_t i = 0; i < log.scans[k].ranges.size(); ++i) {
      if (!log.scans[k].Valid(i)) continue;
      ++valid;
      if (d.scans[k].Valid(i)) {
        EXPECT_EQ(d.scans[k].ranges[i], log.scans[k].ranges[i]);
        continue;
      }
      ++dropped;
      if (std::isnan(d.scans[k].ranges[i])) {
        ++errors;
      } else {
        EXPECT_EQ(d.scans[k].ranges[i], 30.0f);  // no return
      }
    }
  }
  EXPECT_NEAR(static_cast<double>(dropped) / valid, 0.2, 0.01);
  EXPECT_NEAR(static_cast<double>(errors) / dropped, 0.25, 0.02);
  // Read back, both kinds are invalid.
  const LidarLog back = RoundTrip(d, true);
  for (std::size_t k = 0; k < d.scans.size(); ++k) EXPECT_EQ(back.scans[k].ValidCount(), d.scans[k].ValidCount());
}

TEST_F(DegradeTest, KeepEveryCropAndDropOdometry) {
  const LidarLog log = MakeLog(40);
  DegradeOptions o;
  o.keep_every = 2;
  LidarLog d = DegradeLog(log, o);
  ASSERT_EQ(d.scans.size(), 20u);
  for (std::size_t k = 0; k < 20; ++k) EXPECT_EQ(d.scans[k].stamp, log.scans[2 * k].stamp);
  o.first_scan = 5;
  o.max_scans = 7;
  d = DegradeLog(log, o);
  ASSERT_EQ(d.scans.size(), 7u);
  EXPECT_EQ(d.scans.front().source_index, log.scans[5].source_index);
  EXPECT_EQ(d.scans.back().source_index, log.scans[17].source_index);
  // The odometry messages of the kept span and one on either side.
  const std::vector<StampedPose2>& track = d.odometry.Sorted();
  ASSERT_GE(track.size(), 2u);
  EXPECT_LT(track.front().stamp, d.scans.front().stamp);
  EXPECT_GT(track[1].stamp, d.scans.front().stamp);
  EXPECT_GT(track.back().stamp, d.scans.back().stamp);
  EXPECT_LT(track[track.size() - 2].stamp, d.scans.back().stamp);
  LidarReadOptions interpolated;
  interpolated.odometry = OdometrySource::kInterpolated;
  const LidarLog back = RoundTrip(d, true, interpolated);
  for (std::size_t k = 0; k < d.scans.size(); ++k) {
    EXPECT_EQ(back.scans[k].odometry_origin, OdometryOrigin::kInterpolated);
    EXPECT_NEAR((back.scans[k].odometry.translation() - d.scans[k].odometry.translation()).norm(), 0, 1e-6);
  }
  // No odometry: none on the scans, no messages, and none read back.
  o = {};
  o.drop_odometry = true;
  d = DegradeLog(log, o);
  EXPECT_TRUE(d.odometry.empty());
  for (const LaserScan& s : d.scans) EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
  const LidarLog none = RoundTrip(d, !o.drop_odometry);
  ASSERT_EQ(none.scans.size(), 40u);
  for (const LaserScan& s : none.scans) {
    EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
    EXPECT_EQ(s.odometry.translation().norm(), 0);
  }
  // Written with odometry all the same, scans without any are RAWLASER1 lines.
  EXPECT_TRUE(Text(d, true) == Text(d, false));
}

// Odometry drift: each step perturbed with the sigmas asked for and chained again, so the first
// scan keeps its pose, the steps' errors have the asked spread, the error grows along the log,
// the same seed gives the same log, and the ranges and stamps are left alone.
TEST_F(DegradeTest, OdometryDriftPerturbsEachStepAndAccumulates) {
  LidarLog log = MakeLog(2000, 20);
  // Straight steps of 0.1 m with a turn of 0.02 rad each.
  for (std::size_t k = 0; k < log.scans.size(); ++k) {
    const double kd = static_cast<double>(k);
    log.scans[k].odometry = SE2<double>(0, 0, 0.02 * kd);
    if (k > 0) log.scans[k].odometry = log.scans[k - 1].odometry * SE2<double>(0.1, 0, 0.02);
  }
  DegradeOptions o;
  o.odometry_translation_noise = 0.1;    // sigma 0.01 m per axis per step
  o.odometry_rotation_noise = 0.5;       // sigma 0.01 rad from the turn
  o.odometry_rotation_per_metre = 0.05;  // plus 0.005 rad from the length
  o.seed = 3;
  ASSERT_TRUE(o.DriftsOdometry());
  const LidarLog d = DegradeLog(log, o);
  ASSERT_EQ(d.scans.size(), log.scans.size());
  EXPECT_TRUE(d.odometry.Sorted().empty());  // the messages would not carry the drift
  EXPECT_EQ(d.scans[0].odometry.translation(), log.scans[0].odometry.translation());
  double sx = 0, st = 0;
  const std::size_t n = d.scans.size();
  for (std::size_t k = 1; k < n; ++k) {
    const SE2<double> step = d.scans[k - 1].odometry.Inverse() * d.scans[k].odometry;
    sx += (step.x() - 0.1) * (step.x() - 0.1);
    st += (step.theta() - 0.02) * (step.theta() - 0.02);
    EXPECT_EQ(d.scans[k].ranges, log.scans[k].ranges);
    EXPECT_EQ(d.scans[k].stamp, log.scans[k].stamp);
    EXPECT_EQ(d.scans[k].odometry_origin, log.scans[k].odometry_origin);
  }
  // Sample sigmas of 1999 steps: within 10% of the asked ones.
  EXPECT_NEAR(std::sqrt(sx / static_cast<double>(n - 1)), 0.01, 0.001);
  EXPECT_NEAR(std::sqrt(st / static_cast<double>(n - 1)), 0.01 + 0.005, 0.0015);  // the two add
  // The error accumulates: the end lies farther from the truth than the tenth scan.
  const auto off = [&](std::size_t k) {
    return (d.scans[k].odometry.translation() - log.scans[k].odometry.translation()).norm();
  };
  EXPECT_GT(off(n - 1), 10 * off(10) + 0.1);
  // Deterministic for a seed, different for another.
  EXPECT_EQ(Text(DegradeLog(log, o)), Text(d));
  o.seed = 4;
  EXPECT_NE(Text(DegradeLog(log, o)), Text(d));
  // Refused: negative or not finite; together with dropping the odometry nothing drifts.
  o.odometry_rotation_noise = -0.1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("odometry noise"), std::string::npos) << why;
  o.odometry_rotation_noise = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(DegradeLog(log, o), InvalidArgument);
  o.odometry_rotation_noise = 0.5;
  o.drop_odometry = true;
  for (const LaserScan& s : DegradeLog(log, o).scans) EXPECT_EQ(s.odometry_origin, OdometryOrigin::kNone);
}

TEST_F(DegradeTest, AKidnapCutsScansAndCarriesTheOdometry) {
  // 40 scans at 10 Hz from 1000.025 s; the cut: [1000.025 + 1.0, + 1.5 s): scans 10..24 go.
  const LidarLog log = MakeLog(40);
  DegradeOptions o;
  o.kidnap_at = 1.0;
  o.kidnap_seconds = 1.5;
  o.kidnap_offset = SE2<double>(0.5, -0.25, 0.3);
  std::size_t at = 0;
  const LidarLog cut = DegradeLog(log, o, &at);
  ASSERT_EQ(cut.scans.size(), 25u);
  EXPECT_EQ(at, 10u);
  EXPECT_EQ(cut.scans[9].source_index, 10);
  EXPECT_EQ(cut.scans[10].source_index, 26);
  // The stamps keep their gap; the odometry after the cut continues from the scan before it,
  // moved by the offset, and then follows the logged motion.
  EXPECT_DOUBLE_EQ(cut.scans[10].stamp, log.scans[25].stamp);
  const SE2<double> jump = cut.scans[9].odometry.Inverse() * cut.scans[10].odometry;
  EXPECT_NEAR(jump.x(), 0.5, 1e-12);
  EXPECT_NEAR(jump.y(), -0.25, 1e-12);
  EXPECT_NEAR(jump.theta(), 0.3, 1e-12);
  for (std::size_t k = 11; k < cut.scans.size(); ++k) {
    const SE2<double> step = cut.scans[k - 1].odometry.Inverse() * cut.scans[k].odometry;
    const SE2<double> logged = log.scans[k + 14].odometry.Inverse() * log.scans[k + 15].odometry;
    EXPECT_NEAR(step.x(), logged.x(), 1e-9) << k;
    EXPECT_NEAR(step.y(), logged.y(), 1e-9) << k;
    EXPECT_NEAR(step.theta(), logged.theta(), 1e-9) << k;
  }
  EXPECT_EQ(cut.odometry.size(), 0u);  // the messages would be the logged odometry's
  // Closing the gap: the stamps run on at 10 Hz across the cut.
  o.kidnap_close_gap = true;
  const LidarLog closed = DegradeLog(log, o, &at);
  EXPECT_NEAR(closed.scans[10].stamp - closed.scans[9].stamp, 0.1, 1e-9);
  EXPECT_NEAR(closed.scans[10].logger_stamp - closed.scans[9].logger_stamp, 0.1, 1e-9);
  EXPECT_EQ(closed.odometry.size(), 0u);
  // Keeping the odometry: as logged; with the gap open, the messages too.
  o.kidnap_keep_odometry = true;
  o.kidnap_offset = SE2<double>();
  EXPECT_EQ(DegradeLog(log, o, &at).scans[10].odometry.x(), log.scans[25].odometry.x());
  o.kidnap_close_gap = false;
  const LidarLog kept = DegradeLog(log, o, &at);
  EXPECT_EQ(kept.scans[10].odometry.x(), log.scans[25].odometry.x());
  EXPECT_GT(kept.odometry.size(), 0u);
  // A cut past the last scan: none after it.
  o.kidnap_at = 100;
  EXPECT_EQ(DegradeLog(log, o, &at).scans.size(), 40u);
  EXPECT_EQ(at, 40u);
}

TEST_F(DegradeTest, PresetAndUnusableOptions) {
  DegradeOptions o;
  o.seed = 5;
  ASSERT_TRUE(DegradePreset("lds", &o));
  EXPECT_EQ(o.beams, 360);
  EXPECT_EQ(o.max_range, 6);
  EXPECT_EQ(o.noise_sigma, 0.02);
  EXPECT_EQ(o.drop_fraction, 0.05);
  EXPECT_EQ(o.keep_every, 2);
  EXPECT_EQ(o.seed, 5u);
  EXPECT_FALSE(DegradePreset("sick", &o));
  EXPECT_EQ(DegradePresetNames(), "lds");
  const LidarLog log = MakeLog(4);
  const auto error = [&](const DegradeOptions& bad) { return ErrorOf<InvalidArgument>([&] { DegradeLog(log, bad); }); };
  const struct {
    void (*set)(DegradeOptions*);
    const char* message;
  } cases[] = {
      {[](DegradeOptions* d) { d->beams = 1; }, "lidar degrade: beams must be 0"},
      {[](DegradeOptions* d) { d->beams = -4; }, "beams must be 0"},
      {[](DegradeOptions* d) { d->max_range = -1; }, "max_range must be finite"},
      {[](DegradeOptions* d) { d->max_range = INFINITY; }, "max_range must be finite"},
      {[](DegradeOptions* d) { d->noise_sigma = NAN; }, "noise_sigma must be finite"},
      {[](DegradeOptions* d) { d->drop_fraction = 1.5; }, "drop_fraction must be in [0, 1]"},
      {[](DegradeOptions* d) { d->error_share = -0.1; }, "error_share must be in [0, 1]"},
      {[](DegradeOptions* d) { d->keep_every = 0; }, "keep_every must be at least 1"},
      {[](DegradeOptions* d) { d->kidnap_seconds = -1; }, "kidnap_at and kidnap_seconds must be finite"},
      {[](DegradeOptions* d) { d->kidnap_at = NAN; }, "kidnap_at and kidnap_seconds must be finite"},
      {[](DegradeOptions* d) { d->kidnap_offset = SE2<double>(INFINITY, 0, 0); }, "kidnap_offset must be finite"},
      {[](DegradeOptions* d) { d->first_scan = 4; }, "the first scan kept (4) is beyond the log's 4 scans"},
  };
  for (const auto& c : cases) {
    DegradeOptions bad;
    c.set(&bad);
    EXPECT_NE(error(bad).find(c.message), std::string::npos) << c.message << ": " << error(bad);
  }
  std::string why;
  EXPECT_TRUE(DegradeOptions().IsValid(&why));
}

}  // namespace
}  // namespace lidar
}  // namespace tether
