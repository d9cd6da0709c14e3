// Absolute trajectory error on cases whose answer is known, and the ground truth in the plot
// and in `tether optimize --ground-truth`.
#include "tether/core/trajectory_error.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tether/core/graph_io.h"
#include "tether/core/svg_plot.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

// The four corners of a 2 m square, and the same moved by a rotation `angle` about the origin
// and a translation (tx, ty).
Values Square(double angle = 0, double tx = 0, double ty = 0, double grow = 0) {
  Values v;
  const double c = std::cos(angle), s = std::sin(angle);
  const double corners[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
  for (int i = 0; i < 4; ++i) {
    // Moved outward along the diagonal by `grow` metres.
    const double k = 1.0 + grow / std::sqrt(2.0);
    const double x = corners[i][0] * k, y = corners[i][1] * k;
    v.Insert(static_cast<Key>(i), SE2d(c * x - s * y + tx, s * x + c * y + ty, 0.3 * i));
  }
  return v;
}

TEST(TrajectoryErrorTest, RigidMotionOfTheTruthIsZeroAfterAlignment) {
  const Values truth = Square();
  const Values moved = Square(0.7, 3.0, -2.0);
  const TrajectoryError rigid = AbsoluteTrajectoryError(moved, truth);
  EXPECT_EQ(rigid.poses, 4);
  EXPECT_NEAR(rigid.rmse, 0.0, 1e-12);
  EXPECT_NEAR(rigid.max, 0.0, 1e-12);
  // Unaligned: a shift of (3, -2) alone is sqrt(13) everywhere.
  const TrajectoryError shifted = AbsoluteTrajectoryError(Square(0, 3.0, -2.0), truth, AteAlignment::kNone);
  EXPECT_NEAR(shifted.rmse, std::sqrt(13.0), 1e-12);
  EXPECT_NEAR(shifted.mean, std::sqrt(13.0), 1e-12);
}

TEST(TrajectoryErrorTest, KnownErrorThatNoRigidMotionRemoves) {
  // Every corner 0.1 m further out: by symmetry the best alignment is the identity (no scale),
  // so the RMSE is 0.1 with or without it, also after moving the estimate rigidly.
  const Values truth = Square();
  EXPECT_NEAR(AbsoluteTrajectoryError(Square(0, 0, 0, 0.1), truth, AteAlignment::kNone).rmse, 0.1, 1e-12);
  EXPECT_NEAR(AbsoluteTrajectoryError(Square(0, 0, 0, 0.1), truth).rmse, 0.1, 1e-12);
  EXPECT_NEAR(AbsoluteTrajectoryError(Square(-2.0, 5, 1, 0.1), truth).rmse, 0.1, 1e-12);
  // One corner off by 0.4 m alone: sqrt(0.16 / 4) = 0.2 without alignment.
  Values one = Square();
  one.Params(2)[0] -= 0.4;
  EXPECT_NEAR(AbsoluteTrajectoryError(one, truth, AteAlignment::kNone).rmse, 0.2, 1e-12);
  EXPECT_NEAR(AbsoluteTrajectoryError(one, truth, AteAlignment::kNone).max, 0.4, 1e-12);
  EXPECT_LT(AbsoluteTrajectoryError(one, truth).rmse, 0.2);  // alignment spreads it
}

TEST(TrajectoryErrorTest, ThreeDimensionsAndOnlyCommonPoses) {
  Values truth, est;
  // A helix; the estimate is it turned about z and about x and shifted, plus a landmark and a
  // pose the truth does not have, both ignored.
  const Eigen::Quaterniond q =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX());
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d p(std::cos(0.5 * i), std::sin(0.5 * i), 0.1 * i);
    truth.Insert(static_cast<Key>(i), SE3d(Eigen::Quaterniond::Identity(), p));
    est.Insert(static_cast<Key>(i), SE3d(q, q * p + Eigen::Vector3d(1, 2, 3)));
  }
  est.Insert(100, Eigen::Vector3d(50, 50, 50));
  est.Insert(200, SE3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(90, 0, 0)));
  const TrajectoryError e = AbsoluteTrajectoryError(est, truth);
  EXPECT_EQ(e.poses, 20);
  EXPECT_NEAR(e.rmse, 0.0, 1e-9);
  EXPECT_GT(AbsoluteTrajectoryError(est, truth, AteAlignment::kNone).rmse, 1.0);
}

TEST(TrajectoryErrorTest, NothingInCommon) {
  Values a, b;
  a.Insert(0, SE2d(0, 0, 0));
  b.Insert(1, SE2d(0, 0, 0));
  const TrajectoryError e = AbsoluteTrajectoryError(a, b);
  EXPECT_EQ(e.poses, 0);
  EXPECT_TRUE(std::isnan(e.rmse));
  EXPECT_EQ(FormatMetres(e.rmse), "n/a");
  EXPECT_EQ(FormatMetres(7.0312), "7.03 m");
  EXPECT_EQ(FormatMetres(0.21849), "0.218 m");
}

TEST(SvgGroundTruthTest, ThreeLayersAndTheAteOfEachInTheLegend) {
  SimulateOptions so;
  so.poses = 300;
  so.seed = 2;
  const SimulatedGraph sim = Simulate(so);
  // The "result" here: the truth moved 0.5 m in x, whose ATE after alignment is 0.
  Values result = sim.ground_truth;
  for (Key k : result.keys()) result.Params(k)[0] += 0.5;
  PlotOptions po;
  po.before_label = "start";
  po.after_label = "result";
  const std::string svg = RenderSvg(sim.graph, &sim.initial, &result, &sim.ground_truth, po);
  for (const char* cls : {"class=\"ground-truth\"", "class=\"before\"", "class=\"after\""}) {
    EXPECT_NE(svg.find(cls), std::string::npos) << cls;
  }
  // The truth is drawn first, under the others.
  EXPECT_LT(svg.find("class=\"ground-truth\""), svg.find("class=\"before\""));
  const std::string start_ate = FormatMetres(AbsoluteTrajectoryError(sim.initial, sim.ground_truth).rmse);
  EXPECT_GT(AbsoluteTrajectoryError(sim.initial, sim.ground_truth).rmse, 0.5);
  EXPECT_NE(svg.find(">start (ATE " + start_ate + ")<"), std::string::npos) << svg.substr(svg.find("legend"));
  EXPECT_NE(svg.find(">result (ATE 0 m)<"), std::string::npos) << svg.substr(svg.find("legend"));
  EXPECT_NE(svg.find(">ground truth<"), std::string::npos);
  // Without numbers on request, and without a truth nothing of it.
  po.show_ate = false;
  EXPECT_EQ(RenderSvg(sim.graph, &sim.initial, &result, &sim.ground_truth, po).find("ATE"), std::string::npos);
  const std::string plain = RenderSvg(sim.graph, &sim.initial, &result, po);
  EXPECT_EQ(plain.find("ground-truth"), std::string::npos);
  EXPECT_EQ(plain.find(">ground truth<"), std::string::npos);
}

#ifdef TETHER_CLI
std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// `tether optimize --ground-truth`: the ATE line, the picture's three layers, the start drawn
// as the file has it (not the chordal start), and a bad truth file refused before anything.
TEST(OptimizeGroundTruthTest, ReportsAndDrawsTheAteOfStartAndResult) {
  const fs::path dir = fs::temp_directory_path() / ("tether_gt_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string in = (dir / "m.g2o").string(), gt = (dir / "gt.g2o").string(), svg = (dir / "m.svg").string(),
                    log = (dir / "log.txt").string();
  const std::string cli(TETHER_CLI);
  ASSERT_EQ(std::system((cli + " simulate manhattan --poses 500 --seed 4 -o " + in + " --ground-truth " + gt + " > " +
                         log + " 2>&1")
                            .c_str()),
            0);
  const int status = std::system(
      (cli + " optimize -q " + in + " --plot " + svg + " --ground-truth " + gt + " > " + log + " 2>&1").c_str());
  const std::string output = ReadAll(log);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << output;
  const GraphFile file = ReadGraphFile(in, DefaultRegistry()), truth = ReadGraphFile(gt, DefaultRegistry());
  const std::string start = FormatMetres(AbsoluteTrajectoryError(file.values, truth.values).rmse);
  EXPECT_NE(output.find("absolute trajectory error against " + gt + " (500 poses, after a rigid alignment): start " +
                        start + ", result "),
            std::string::npos)
      << output;
  const std::string picture = ReadAll(svg);
  for (const char* cls : {"class=\"ground-truth\"", "class=\"before\"", "class=\"after\""}) {
    EXPECT_NE(picture.find(cls), std::string::npos) << cls;
  }
  EXPECT_NE(picture.find(">file&apos;s start (ATE " + start + ")<"), std::string::npos);
  EXPECT_NE(picture.find(">result (ATE "), std::string::npos);

  // A truth file that cannot be read: exit 1, nothing written.
  fs::remove(svg);
  const int bad = std::system((cli + " optimize -q " + in + " --plot " + svg + " --ground-truth " +
                               (dir / "none.g2o").string() + " > " + log + " 2>&1")
                                  .c_str());
  EXPECT_TRUE(WIFEXITED(bad) && WEXITSTATUS(bad) == 1) << ReadAll(log);
  EXPECT_NE(ReadAll(log).find("none.g2o"), std::string::npos);
  EXPECT_FALSE(fs::exists(svg));
  fs::remove_all(dir);
}
#endif

}  // namespace
}  // namespace tether
