// Monte Carlo localisation: the map and its distance field, the motion and measurement models,
// resampling, the recovery filters, KLD sampling, the costmap, and whole runs on a simulated
// robot in a hand-made map.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>

#include "tether/core/error.h"
#include "tether/frontends/lidar/io/occupancy_map.h"
#include "tether/frontends/localization/measurement_model.h"
#include "tether/frontends/localization/monte_carlo_localizer_2d.h"
#include "tether/frontends/localization/motion_model.h"
#include "tether/frontends/localization/occupancy_map_2d.h"
#include "tether/frontends/simulation/random_stream.h"

namespace tether {
namespace localization {
namespace {

constexpr double kPi = 3.14159265358979323846;

// An image of width x height free pixels (254) with an unknown (205) border of `border`
// pixels, 0.1 m a pixel, origin at (0, 0).
lidar::OccupancyImage FreeImage(int width, int height, int border = 0) {
  lidar::OccupancyImage image;
  image.width = width;
  image.height = height;
  image.resolution = 0.1;
  image.pixels.assign(static_cast<std::size_t>(width * height), 254);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c)
      if (r < border || c < border || r >= height - border || c >= width - border) {
        image.pixels[static_cast<std::size_t>(r * width + c)] = lidar::kUnknownPixel;
      }
  return image;
}

// Marks the cells (i, j) (i from the left, j from the bottom) of a rectangle occupied.
void Block(lidar::OccupancyImage* image, int i0, int j0, int i1, int j1) {
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
      image->pixels[static_cast<std::size_t>((image->height - 1 - j) * image->width + i)] = 0;
}

// An 8 m x 6 m room (walls one cell thick), with a wall stub and two boxes that break its
// symmetry: the pose is recognisable from a scan.
lidar::OccupancyImage Room() {
  lidar::OccupancyImage image = FreeImage(84, 64, 1);
  Block(&image, 1, 1, 82, 1);
  Block(&image, 1, 62, 82, 62);
  Block(&image, 1, 1, 1, 62);
  Block(&image, 82, 1, 82, 62);
  Block(&image, 30, 1, 30, 25);   // a wall stub from the bottom
  Block(&image, 60, 40, 66, 46);  // a box
  Block(&image, 10, 48, 13, 51);  // a small box
  return image;
}

std::shared_ptr<const OccupancyMap2D> RoomMap() { return std::make_shared<const OccupancyMap2D>(Room()); }

// A scan of `beams` beams over 360 degrees from `truth` in `map` (ranges cast in the map, with
// Gaussian noise), its odometry `odometry`.
lidar::LaserScan Scan(const OccupancyMap2D& map, const SE2d& truth, const SE2d& odometry, int beams,
                      RandomStream* noise) {
  const BeamModel caster(map, {});
  lidar::LaserScan s;
  s.angle_min = -kPi;
  s.angle_increment = 2 * kPi / beams;
  s.range_min = 0.05;
  s.range_max = 20;
  for (int b = 0; b < beams; ++b) {
    const double r = caster.CastRay(truth.translation(), truth.theta() + s.Angle(static_cast<std::size_t>(b)), 20);
    s.ranges.push_back(static_cast<float>(r + 0.01 * noise->Normal()));
  }
  s.odometry = odometry;
  s.odometry_origin = lidar::OdometryOrigin::kScanLine;
  return s;
}

// A route round the room: (x, y) waypoints; the robot drives between them at `step` a scan.
std::vector<SE2d> Route(double step) {
  const std::vector<Eigen::Vector2d> points = {{1.5, 1.2}, {1.5, 4.2}, {5.0, 5.5}, {7.4, 5.5},
                                               {7.4, 1.2}, {4.5, 1.2}, {4.5, 3.3}, {1.5, 3.3}};
  std::vector<SE2d> route;
  for (int lap = 0; lap < 2; ++lap) {
    for (std::size_t k = 0; k + 1 < points.size(); ++k) {
      const Eigen::Vector2d d = points[k + 1] - points[k];
      const int n = static_cast<int>(std::ceil(d.norm() / step));
      for (int s = 0; s < n; ++s) {
        const Eigen::Vector2d p = points[k] + d * (static_cast<double>(s) / n);
        route.emplace_back(p.x(), p.y(), std::atan2(d.y(), d.x()));
      }
    }
  }
  return route;
}

// Odometry that drifts: each true step with noise of `sigma` per metre.
std::vector<SE2d> Odometry(const std::vector<SE2d>& truth, double sigma, std::uint64_t seed) {
  RandomStream noise(seed, 5);
  std::vector<SE2d> odometry = {SE2d(10, -3, 1)};  // its own frame
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const SE2d step = truth[k - 1].Inverse() * truth[k];
    const double d = step.translation().norm() + std::abs(step.theta());
    odometry.push_back(odometry.back() * SE2d(step.x() + sigma * d * noise.Normal(),
                                              step.y() + sigma * d * noise.Normal(),
                                              step.theta() + sigma * d * noise.Normal()));
  }
  return odometry;
}

// --- the map ---------------------------------------------------------------------------

TEST(LocalizationMapTest, DistanceTransformIsTheBruteForceNearestObstacle) {
  RandomStream random(3, 1);
  const int w = 37, h = 23;
  std::vector<bool> seed(static_cast<std::size_t>(w * h), false);
  for (int k = 0; k < 25; ++k) seed[static_cast<std::size_t>(random.Uniform() * w * h)] = true;
  const std::vector<float> d = SquaredDistanceTransform(w, h, seed);
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (int q = 0; q < w * h; ++q)
        if (seed[static_cast<std::size_t>(q)])
          best = std::min(best, std::pow(q % w - i, 2.0) + std::pow(q / w - j, 2.0));
      ASSERT_EQ(d[static_cast<std::size_t>(j * w + i)], static_cast<float>(best)) << i << ", " << j;
    }
  // No seed at all: every distance infinite.
  const std::vector<float> none = SquaredDistanceTransform(5, 4, std::vector<bool>(20, false));
  for (const float v : none) EXPECT_TRUE(std::isinf(v));
}

TEST(LocalizationMapTest, CellsByThresholdAndRowsFromTheBottom) {
  lidar::OccupancyImage image = FreeImage(4, 3);
  image.origin = Eigen::Vector2d(-1, 2);
  image.pixels[0] = 0;     // top-left pixel: cell (0, 2)
  image.pixels[5] = 205;   // row 1, column 1: cell (1, 1)
  image.pixels[11] = 100;  // p = 0.61: between the thresholds, unknown
  const OccupancyMap2D map(image);
  EXPECT_EQ(map.State(0, 2), CellState::kOccupied);
  EXPECT_EQ(map.State(1, 1), CellState::kUnknown);
  EXPECT_EQ(map.State(3, 0), CellState::kUnknown);
  EXPECT_EQ(map.State(0, 0), CellState::kFree);
  EXPECT_EQ(map.free_cells().size(), 9u);
  int i = -1, j = -1;
  ASSERT_TRUE(map.CellOf(Eigen::Vector2d(-0.95, 2.25), &i, &j));
  EXPECT_EQ(i, 0);
  EXPECT_EQ(j, 2);
  EXPECT_FALSE(map.CellOf(Eigen::Vector2d(-1.01, 2.05), &i, &j));
  EXPECT_FALSE(map.CellOf(Eigen::Vector2d(-0.5, 2.3), &i, &j));  // above the top
  EXPECT_NEAR(map.Distance(3, 0), 0.1 * std::sqrt(9.0 + 4.0), 1e-6);
  // negate: dark is free.
  const OccupancyMap2D negated(image, 0.65, 0.196, true);
  EXPECT_EQ(negated.State(0, 2), CellState::kFree);
  EXPECT_THROW(OccupancyMap2D(FreeImage(0, 0)), InvalidArgument);
}

TEST(LocalizationMapTest, ReadsWhatTheMapperWrites) {
  lidar::OccupancyImage image = Room();
  image.origin = Eigen::Vector2d(-3.25, 7.5);
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "/room.pgm", std::ios::binary) << lidar::PgmBytes(image);
  std::ofstream(dir + "/room.yaml") << lidar::MapYaml(image, "room.pgm");
  const lidar::MapFile file = lidar::ReadMapYaml(dir + "/room.yaml");
  EXPECT_EQ(file.image.pixels, image.pixels);
  EXPECT_EQ(file.image.width, image.width);
  EXPECT_DOUBLE_EQ(file.image.resolution, 0.1);
  EXPECT_DOUBLE_EQ(file.image.origin.x(), -3.25);
  EXPECT_DOUBLE_EQ(file.image.origin.y(), 7.5);
  EXPECT_DOUBLE_EQ(file.occupied_thresh, 0.65);
  const OccupancyMap2D map = OccupancyMap2D::Read(dir + "/room.yaml");
  EXPECT_EQ(map.occupied_count(), OccupancyMap2D(image).occupied_count());
  // A plain (P2) PGM with comments and another maxval reads as the same pixels.
  const lidar::OccupancyImage plain = lidar::ParsePgm("P2\n# a comment\n2 1\n# another\n15\n0 15\n", "x.pgm");
  ASSERT_EQ(plain.pixels.size(), 2u);
  EXPECT_EQ(plain.pixels[0], 0);
  EXPECT_EQ(plain.pixels[1], 255);
}

TEST(LocalizationMapTest, BadMapFilesAreRefusedNamingTheFileAndLine) {
  const std::string dir = ::testing::TempDir();
  const auto yaml_error = [&](const std::string& text) {
    std::ofstream(dir + "/bad.yaml") << text;
    try {
      lidar::ReadMapYaml(dir + "/bad.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::ofstream(dir + "/ok.pgm", std::ios::binary) << "P5 2 2 255\n" << std::string(4, '\xfe');
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").find("no error"), std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: -1\norigin: [0, 0, 0]\n").find("bad.yaml:2: resolution"),
            std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: nan\norigin: [0, 0, 0]\n").find("bad.yaml:2:"), std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 0.05\norigin: [0, 0]\n").find("bad.yaml:3: origin"),
            std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 0.05\norigin: [0, 0, 0.5]\n").find("rotated"), std::string::npos);
  EXPECT_NE(yaml_error("resolution: 0.05\norigin: [0, 0, 0]\n").find("no 'image:'"), std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\norigin: [0, 0, 0]\n").find("no 'resolution:'"), std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.9\n").find("thresholds"),
            std::string::npos);
  EXPECT_NE(yaml_error("image: missing.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n").find("missing.pgm: cannot open"),
            std::string::npos);
  EXPECT_NE(yaml_error("just a line\n").find("bad.yaml:1:"), std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 1e-300\norigin: [0, 0, 0]\n").find("bad.yaml:2: resolution"),
            std::string::npos);
  EXPECT_NE(yaml_error("image: ok.pgm\nresolution: 0.05\norigin: [1e308, 0, 0]\n").find("bad.yaml:3: origin lies"),
            std::string::npos);
  EXPECT_NE(yaml_error("image: /dev/zero\nresolution: 0.05\norigin: [0, 0, 0]\n").find("larger than"),
            std::string::npos);
  EXPECT_THROW(lidar::ParsePgm("P6 1 1 255\n\x01\x02\x03", "c.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("P5 2 2 255\n\x01", "cut.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("P5 2 2 65535\n", "deep.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("P5 100000 100000 255\n", "huge.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("P5 1000000000000000000 1000000000000000000 255\n", "huger.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("P2 1 1 10 11", "above.pgm"), ParseError);
  EXPECT_THROW(lidar::ParsePgm("", "empty.pgm"), ParseError);
}

TEST(LocalizationMapTest, TheCostmapInflatesObstaclesAndChecksWholeMotions) {
  lidar::OccupancyImage image = FreeImage(40, 20, 1);
  Block(&image, 20, 0, 20, 12);  // a wall from the bottom, x 2.0 to 2.1, up to y 1.3
  const OccupancyMap2D map(image);
  const Costmap2D costmap(map, 0.3);
  EXPECT_TRUE(costmap.Valid({1.0, 0.75}));
  EXPECT_FALSE(costmap.Valid({2.05, 0.75}));  // in the wall
  EXPECT_FALSE(costmap.Valid({1.8, 0.75}));   // within the robot's radius of it
  EXPECT_TRUE(costmap.Valid({1.6, 0.75}));    // 0.4 m from it
  EXPECT_FALSE(costmap.Valid({0.05, 0.75}));  // the unknown border
  EXPECT_FALSE(costmap.Valid({-1.0, 0.75}));  // off the map
  // Both ends valid, the motion through the wall not; round its end it is.
  EXPECT_TRUE(costmap.Valid({3.0, 0.75}));
  EXPECT_FALSE(costmap.PathValid({1.0, 0.75}, {3.0, 0.75}));
  EXPECT_TRUE(costmap.PathValid({1.0, 1.75}, {3.0, 1.75}));
  // A thin crossing: a motion that clips the inflated corner.
  EXPECT_FALSE(costmap.PathValid({1.5, 1.3}, {2.6, 1.7}));
  EXPECT_TRUE(costmap.PathValid({1.0, 0.75}, {1.0, 0.75}));
  EXPECT_THROW(Costmap2D(map, -0.1), InvalidArgument);
}

// --- the models ------------------------------------------------------------------------

TEST(MotionModelTest, DecomposesForwardsBackwardsAndTurnsInPlace) {
  const SE2d from(1, 2, 0.5);
  const OdometryMotion f = DecomposeOdometry(from, from * SE2d(1, 0.2, 0.3));
  EXPECT_NEAR(f.rot1, std::atan2(0.2, 1.0), 1e-12);
  EXPECT_NEAR(f.trans, std::hypot(1.0, 0.2), 1e-12);
  EXPECT_NEAR(f.rot1 + f.rot2, 0.3, 1e-12);
  const OdometryMotion b = DecomposeOdometry(from, from * SE2d(-0.5, 0, 0));
  EXPECT_NEAR(b.rot1, 0, 1e-12);
  EXPECT_NEAR(b.trans, -0.5, 1e-12);
  EXPECT_NEAR(b.rot2, 0, 1e-12);
  const OdometryMotion t = DecomposeOdometry(from, from * SE2d(0, 0, -1.2));
  EXPECT_EQ(t.trans, 0);
  EXPECT_NEAR(t.rot2, -1.2, 1e-12);
}

TEST(MotionModelTest, SampleMomentsMatchTheClosedForm) {
  // With rot1, trans, rot2 each Gaussian and independent: the end heading's mean and variance
  // add; x = x0 + trans cos(theta0 + rot1) has mean trans cos(theta0 + rot1) e^(-s1^2 / 2).
  OdometryMotionModel model;
  model.alpha1 = 0.05;
  model.alpha2 = 0.1;
  model.alpha3 = 0.08;
  model.alpha4 = 0.02;
  const SE2d start(2, -1, 0.3);
  const OdometryMotion m{0.4, 1.5, -0.2};
  const Eigen::Vector3d s = model.Sigmas(m);
  EXPECT_NEAR(s[0], std::sqrt(0.05 * 0.16 + 0.1 * 2.25), 1e-12);
  EXPECT_NEAR(s[1], std::sqrt(0.08 * 2.25 + 0.02 * (0.16 + 0.04)), 1e-12);
  RandomStream random(11, 2);
  const int n = 200000;
  double sum_x = 0, sum_y = 0, sum_t = 0, sum_t2 = 0, sum_d = 0, sum_d2 = 0;
  for (int k = 0; k < n; ++k) {
    const SE2d p = model.Sample(start, m, &random);
    sum_x += p.x();
    sum_y += p.y();
    const double dt = std::remainder(p.theta() - start.theta() - (m.rot1 + m.rot2), 2 * kPi);
    sum_t += dt;
    sum_t2 += dt * dt;
    const double d = (p.translation() - start.translation()).norm();
    sum_d += d;
    sum_d2 += d * d;
  }
  const double decay = std::exp(-0.5 * s[0] * s[0]);
  const double se = std::sqrt(s[1] * s[1] + m.trans * m.trans) / std::sqrt(n);  // standard error of a coordinate
  EXPECT_NEAR(sum_x / n, start.x() + m.trans * std::cos(start.theta() + m.rot1) * decay, 5 * se);
  EXPECT_NEAR(sum_y / n, start.y() + m.trans * std::sin(start.theta() + m.rot1) * decay, 5 * se);
  EXPECT_NEAR(sum_t / n, 0, 5 * std::sqrt(s[0] * s[0] + s[2] * s[2]) / std::sqrt(n));
  EXPECT_NEAR(sum_t2 / n, s[0] * s[0] + s[2] * s[2], 0.02 * (s[0] * s[0] + s[2] * s[2]));
  // The distance moved is |trans|: mean 1.5, variance s1^2 (trans stays positive here).
  EXPECT_NEAR(sum_d / n, m.trans, 5 * s[1] / std::sqrt(n));
  EXPECT_NEAR(sum_d2 / n - std::pow(sum_d / n, 2), s[1] * s[1], 0.02 * s[1] * s[1]);
  OdometryMotionModel bad;
  bad.alpha3 = -1;
  EXPECT_FALSE(bad.IsValid(nullptr));
}

TEST(MeasurementModelTest, LikelihoodFieldScoresByTheNearestObstacle) {
  const std::shared_ptr<const OccupancyMap2D> map = RoomMap();
  LikelihoodFieldOptions o;
  o.sigma_hit = 0.2;
  const LikelihoodField field(*map, o, 10.0);
  // One beam from (4, 3) straight ahead 2.2 m: its end (6.2, 3) lies 0.45 m from the box's
  // left face (cells from x 6.0; the distance runs between cell centres: 6.05 - 6.25 ... ).
  lidar::LaserScan scan;
  scan.angle_min = 0;
  scan.angle_increment = 0.01;
  scan.range_max = 10;
  scan.ranges = {2.2f};
  const ScanBeams beams = SelectBeams(scan, 60);
  ASSERT_EQ(beams.angles.size(), 1u);
  const SE2d pose(4.0, 3.0, 0.0);
  int i, j;
  ASSERT_TRUE(map->CellOf(Eigen::Vector2d(6.2, 3.0), &i, &j));
  // The brute-force nearest occupied cell from the end point's cell.
  double best = 1e9;
  for (int q = 0; q < map->height(); ++q)
    for (int r = 0; r < map->width(); ++r)
      if (map->State(r, q) == CellState::kOccupied)
        best = std::min(best, (map->CellCentre(r, q) - map->CellCentre(i, j)).norm());
  const double expected = std::log(0.95 * std::exp(-best * best / (2 * 0.04)) + 0.05 / 10.0);
  EXPECT_NEAR(field.LogLikelihood(pose, beams), expected, 1e-5);
  EXPECT_NEAR(field.BeamScore(best), expected, 1e-12);
  // Beyond max_distance every end point scores the same; outside the map too.
  EXPECT_DOUBLE_EQ(field.BeamScore(5.0), field.BeamScore(2.0));
  EXPECT_NEAR(field.LogLikelihood(SE2d(-50, -50, 0), beams), field.BeamScore(2.0), 1e-6);
  // Many poses at once give what one at a time gives.
  const double poses[6] = {4.0, 3.0, 0.0, 2.0, 2.5, 1.0};
  double out[2];
  field.LogLikelihoods(poses, 2, beams, out);
  EXPECT_EQ(out[0], field.LogLikelihood(pose, beams));
  EXPECT_EQ(out[1], field.LogLikelihood(SE2d(2.0, 2.5, 1.0), beams));
}

TEST(MeasurementModelTest, TheTruePoseScoresBestWithBothModels) {
  const std::shared_ptr<const OccupancyMap2D> map = RoomMap();
  RandomStream noise(4, 4);
  const SE2d truth(2.3, 3.7, 0.6);
  const lidar::LaserScan scan = Scan(*map, truth, SE2d(), 180, &noise);
  const LikelihoodField field(*map, {}, scan.range_max);
  const BeamModel beam(*map, {});
  const ScanBeams hits = SelectBeams(scan, 60), all = SelectBeams(scan, 60, true);
  for (const SE2d& off : {SE2d(0.2, 0, 0), SE2d(0, -0.2, 0), SE2d(0, 0, 0.1), SE2d(1.0, 0.5, -0.4)}) {
    EXPECT_GT(field.LogLikelihood(truth, hits), field.LogLikelihood(truth * off, hits));
    EXPECT_GT(beam.LogLikelihood(truth, all), beam.LogLikelihood(truth * off, all));
  }
  // The ray caster finds the wall: from (2, 3) heading 0 the stub at x 3.0 (cells 30) lies
  // below y 2.6, so the ray reaches the right wall at x 8.2.
  EXPECT_NEAR(beam.CastRay({2.0, 3.05}, 0.0, 20), 8.2 - 2.0, 0.11);
  EXPECT_NEAR(beam.CastRay({2.0, 1.55}, 0.0, 20), 3.0 - 2.0, 0.11);
  EXPECT_NEAR(beam.CastRay({2.0, 1.55}, 0.0, 0.5), 0.5, 1e-12);
}

// --- resampling and the filters --------------------------------------------------------

TEST(ResamplingTest, LowVarianceResamplingIsUnbiased) {
  const std::vector<double> w = {0.1, 0.05, 0.3, 0.0, 0.55};
  RandomStream random(9, 9);
  std::vector<double> counts(w.size(), 0);
  const int draws = 20000, count = 7;
  for (int d = 0; d < draws; ++d)
    for (const int i : LowVarianceResample(w, count, random.Uniform())) counts[static_cast<std::size_t>(i)] += 1;
  for (std::size_t i = 0; i < w.size(); ++i) EXPECT_NEAR(counts[i] / (draws * count), w[i], 0.005) << i;
  // Systematic: each index is drawn floor(count w) or ceil(count w) times.
  for (int d = 0; d < 100; ++d) {
    std::vector<int> c(w.size(), 0);
    for (const int i : LowVarianceResample(w, count, random.Uniform())) ++c[static_cast<std::size_t>(i)];
    for (std::size_t i = 0; i < w.size(); ++i) {
      EXPECT_GE(c[i], static_cast<int>(std::floor(count * w[i])));
      EXPECT_LE(c[i], static_cast<int>(std::ceil(count * w[i])));
    }
  }
}

TEST(RecoveryTest, SlowAndFastFiltersAndTheInjectionProbability) {
  MclOptions o;
  o.method = MclMethod::kAugmented;
  o.particles = 10;
  o.alpha_slow = 0.05;
  o.alpha_fast = 0.5;
  MonteCarloLocalizer2D mcl(RoomMap(), o);
  EXPECT_EQ(mcl.InjectionProbability(), 0);  // before any update
  // By hand: w_slow, w_fast start at the first average (0.8), then w_avg = 1 for 20 steps,
  // then 0.1, 0.1.
  double slow = 0.8, fast = 0.8;
  std::vector<double> averages = {0.8};
  averages.insert(averages.end(), 20, 1.0);
  averages.insert(averages.end(), {0.1, 0.1});
  for (std::size_t k = 0; k < averages.size(); ++k) {
    const double avg = averages[k];
    mcl.UpdateRecoveryFilters(std::log(avg));
    if (k > 0) {
      slow += 0.05 * (avg - slow);
      fast += 0.5 * (avg - fast);
    }
    EXPECT_NEAR(std::exp(mcl.log_w_slow()), slow, 1e-12);
    EXPECT_NEAR(std::exp(mcl.log_w_fast()), fast, 1e-12);
    EXPECT_NEAR(mcl.InjectionProbability(), std::max(0.0, 1 - fast / slow), 1e-12);
  }
  EXPECT_GT(mcl.InjectionProbability(), 0.3);  // the last two steps fell: particles are injected
  // Far below any double: the logs keep the ratio.
  mcl.SetRecoveryFilters(-2000, -2000 + std::log(0.25));
  EXPECT_NEAR(mcl.InjectionProbability(), 0.75, 1e-12);
  // Plain MCL never injects.
  o.method = MclMethod::kMcl;
  MonteCarloLocalizer2D plain(RoomMap(), o);
  plain.SetRecoveryFilters(0, -5);
  EXPECT_EQ(plain.InjectionProbability(), 0);
}

TEST(RecoveryTest, KldCountFollowsTheChiSquareQuantile) {
  EXPECT_NEAR(NormalQuantile(0.99), 2.326348, 1e-6);
  EXPECT_NEAR(NormalQuantile(0.5), 0, 1e-12);
  EXPECT_NEAR(NormalQuantile(0.025), -1.959964, 1e-6);
  EXPECT_EQ(KldSampleCount(1, 0.05, 0.01), 1);
  // Tables of the chi-square distribution: the 0.99 quantile with 9 degrees of freedom is
  // 21.666, with 99 it is 134.642; the count is that over 2 epsilon (Wilson-Hilferty within 0.5%).
  EXPECT_NEAR(KldSampleCount(10, 0.05, 0.01), 21.666 / 0.1, 0.005 * 216.66);
  EXPECT_NEAR(KldSampleCount(100, 0.05, 0.01), 134.642 / 0.1, 0.005 * 1346.42);
  // The formula itself.
  const double a = 2.0 / 81, z = NormalQuantile(0.99);
  EXPECT_NEAR(KldSampleCount(10, 0.05, 0.01), 9 / 0.1 * std::pow(1 - a + std::sqrt(a) * z, 3), 1e-9);
}

TEST(RecoveryTest, KldSamplingShrinksTheSetOnceItConverges) {
  const std::shared_ptr<const OccupancyMap2D> map = RoomMap();
  MclOptions o;
  o.particles = 3000;
  o.kld.enabled = true;
  o.kld.min_particles = 50;
  o.kld.max_particles = 3000;
  MonteCarloLocalizer2D spread(map, o);
  spread.InitializeGlobal();
  spread.Resample();
  EXPECT_EQ(spread.particles().size(), 3000u);  // spread over the room: the maximum
  MonteCarloLocalizer2D tight(map, o);
  tight.InitializeGaussian(SE2d(3, 3, 0), Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal());
  tight.Resample();
  EXPECT_LT(tight.particles().size(), 200u);
  EXPECT_GE(tight.particles().size(), 50u);
}

// --- whole runs ------------------------------------------------------------------------

struct RunResult {
  double mean_error = 0, final_error = 0, final_heading_error = 0;
  int redrawn = 0, injected = 0;
  std::vector<Particle> particles;
};

RunResult RunRoom(MclOptions o, bool global, int kidnap_at = -1, int threads = 1) {
  const std::shared_ptr<const OccupancyMap2D> map = RoomMap();
  std::vector<SE2d> truth = Route(0.1);
  if (kidnap_at >= 0) {  // carried across the room: the truth jumps, the odometry does not
    const std::vector<SE2d> before(truth.begin(), truth.begin() + kidnap_at);
    std::vector<SE2d> after(truth.begin() + kidnap_at + 60, truth.end());
    truth = before;
    truth.insert(truth.end(), after.begin(), after.end());
  }
  std::vector<SE2d> odometry = Odometry(truth, 0.05, 2);
  if (kidnap_at >= 0) {  // the odometry's step across the jump is the step before it
    const std::size_t at = static_cast<std::size_t>(kidnap_at);
    const SE2d step = odometry[at - 2].Inverse() * odometry[at - 1];
    const SE2d jumped = odometry[at];
    for (std::size_t k = at; k < odometry.size(); ++k)
      odometry[k] = odometry[at - 1] * step * (jumped.Inverse() * odometry[k]);
  }
  o.threads = threads;
  MonteCarloLocalizer2D mcl(map, o);
  if (!global) mcl.InitializeGaussian(truth[0], Eigen::Vector3d(0.01, 0.01, 0.003).asDiagonal());
  RandomStream noise(7, 7);
  RunResult r;
  int counted = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const MclStep step = mcl.AddScan(Scan(*map, truth[k], odometry[k], 180, &noise));
    const double e = (step.estimate.pose.translation() - truth[k].translation()).norm();
    if (k >= truth.size() / 2) {
      r.mean_error += e;
      ++counted;
    }
    r.final_error = e;
    if (getenv("MCL_DEBUG") && k % 10 == 0)
      printf("%zu err %.3f inj %d upd %d temp %.4f slow %.3f fast %.3f\n", k, e, step.injected, step.updated,
             step.tempering, step.w_slow, step.w_fast);
    r.final_heading_error = std::abs(std::remainder(step.estimate.pose.theta() - truth[k].theta(), 2 * kPi));
    r.redrawn += step.redrawn;
    r.injected += step.injected;
  }
  r.mean_error /= counted;
  r.particles = mcl.particles();
  return r;
}

TEST(MonteCarloLocalizerTest, TracksFromAKnownStart) {
  MclOptions o;
  o.method = MclMethod::kMcl;
  o.particles = 300;
  const RunResult r = RunRoom(o, false);
  EXPECT_LT(r.mean_error, 0.07);  // the map's cells are 0.1 m
  EXPECT_LT(r.final_error, 0.1);
}

TEST(MonteCarloLocalizerTest, LocalisesFromAUniformStart) {
  for (const MclMethod method : {MclMethod::kMcl, MclMethod::kAugmented, MclMethod::kAcmcl}) {
    MclOptions o;
    o.method = method;
    o.particles = 2000;
    const RunResult r = RunRoom(o, true);
    EXPECT_LT(r.final_error, 0.15) << ToString(method);
    EXPECT_LT(r.final_heading_error, 0.1) << ToString(method);
    EXPECT_LT(r.mean_error, 0.1) << ToString(method);
  }
}

TEST(MonteCarloLocalizerTest, BeamModelLocalisesToo) {
  MclOptions o;
  o.method = MclMethod::kMcl;
  o.model = MeasurementModelType::kBeam;
  o.particles = 300;
  o.max_beams = 30;
  const RunResult r = RunRoom(o, false);
  EXPECT_LT(r.mean_error, 0.1);  // ray casting snaps to the 0.1 m cells' edges
}

TEST(MonteCarloLocalizerTest, RecoversFromAKidnapWhereMclCannot) {
  MclOptions o;
  o.particles = 1000;
  o.method = MclMethod::kMcl;
  o.motion = {0.05, 0.05, 0.05, 0.05};  // a cloud too tight to drift to the new place
  const RunResult plain = RunRoom(o, false, 200);
  EXPECT_GT(plain.final_error, 0.5);  // carried away, it never finds out where
  EXPECT_EQ(plain.injected, 0);
  o.method = MclMethod::kAugmented;
  const RunResult augmented = RunRoom(o, false, 200);
  EXPECT_LT(augmented.final_error, 0.15);
  EXPECT_GT(augmented.injected, 0);
  o.method = MclMethod::kAcmcl;
  const RunResult acmcl = RunRoom(o, false, 200);
  EXPECT_LT(acmcl.final_error, 0.15);
  EXPECT_GT(acmcl.redrawn, 0);
}

TEST(MonteCarloLocalizerTest, AutoUsesTheCostmapOnlyUntilLocalised) {
  MclOptions o;
  o.method = MclMethod::kAuto;
  o.particles = 1000;
  const RunResult tracked = RunRoom(o, false);
  o.method = MclMethod::kAcmcl;
  const RunResult always = RunRoom(o, false);
  // Localised from the first scan: Augmented MCL, but for the rare update whose weighted set
  // spreads out.
  EXPECT_LT(tracked.redrawn * 10, always.redrawn);
  EXPECT_LT(tracked.mean_error, 0.07);
  o.method = MclMethod::kAuto;
  o.particles = 2000;
  const RunResult found = RunRoom(o, true);
  EXPECT_GT(found.redrawn, 0);  // spread over the room: ACMCL
  EXPECT_LT(found.final_error, 0.15);
  // The rule itself: a tight set is localised, a spread one not.
  MonteCarloLocalizer2D mcl(RoomMap(), o);
  mcl.InitializeGaussian(SE2d(3, 3, 0), Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal());
  EXPECT_TRUE(mcl.Localised());
  mcl.InitializeGlobal();
  EXPECT_FALSE(mcl.Localised());
}

TEST(MonteCarloLocalizerTest, TheSameForASeedAndAnyThreadCount) {
  MclOptions o;
  o.particles = 800;
  o.method = MclMethod::kAcmcl;
  const RunResult one = RunRoom(o, true, -1, 1), two = RunRoom(o, true, -1, 2), four = RunRoom(o, true, -1, 4);
  ASSERT_EQ(one.particles.size(), two.particles.size());
  ASSERT_EQ(one.particles.size(), four.particles.size());
  for (std::size_t i = 0; i < one.particles.size(); ++i) {
    EXPECT_EQ(one.particles[i].x, two.particles[i].x);
    EXPECT_EQ(one.particles[i].theta, four.particles[i].theta);
  }
  o.seed = 2;
  const RunResult other = RunRoom(o, true, -1, 1);
  EXPECT_NE(other.particles[0].x, one.particles[0].x);
}

TEST(MonteCarloLocalizerTest, OptionsAreCheckedWithReasons) {
  std::string why;
  MclOptions o;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.particles = 0;
  EXPECT_FALSE(o.IsValid(&why));
  o.particles = kMaxParticles + 1;
  EXPECT_FALSE(o.IsValid(&why));
  o = MclOptions();
  o.alpha_slow = 0.2;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("alpha_slow"), std::string::npos);
  o = MclOptions();
  o.kld.enabled = true;
  o.kld.max_particles = 500;
  EXPECT_FALSE(o.IsValid(&why));
  o = MclOptions();
  o.likelihood_field.sigma_hit = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(MonteCarloLocalizer2D(RoomMap(), o), InvalidArgument);
  o = MclOptions();
  o.method = MclMethod::kAcmcl;
  o.robot_radius = 10;  // no cell is 10 m from every wall
  EXPECT_THROW(MonteCarloLocalizer2D(RoomMap(), o), InvalidArgument);
  EXPECT_THROW(MonteCarloLocalizer2D(nullptr, MclOptions()), InvalidArgument);
}

}  // namespace
}  // namespace localization
}  // namespace tether
