// Landmark datasets (../shared/datasets/landmarks): victoria_park.txt and cityTrees10000.txt
// (iSAM's format), example.graph (TORO with BR lines), solved with Levenberg-Marquardt,
// Gauss-Newton and the Ceres adapter from the chordal start (as `tether optimize` does).
// Skipped where the folder is absent. The figures are in benchmarks/RESULTS.md ("Landmark files").
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/ceres_adapter.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

constexpr Key kOffset = 1000000000;  // ReadOptions::landmark_key_offset's default

// Final chi2 of Levenberg-Marquardt from the chordal start, as measured (benchmarks/RESULTS.md).
constexpr double kVictoriaChi2 = 503457.836702;  // victoria_park.txt read with IsamNoise::kCovariance
constexpr double kCityChi2 = 8668.92808669;      // cityTrees10000.txt
constexpr double kExampleChi2 = 559.046868813;   // example.graph

std::string Landmarks(const std::string& name) { return std::string(TETHER_DATASETS_DIR) + "/landmarks/" + name; }

#define SKIP_IF_ABSENT(path)                                                                          \
  if (!std::ifstream(path).good()) {                                                                  \
    GTEST_SKIP() << "dataset " << (path) << " absent (../shared/datasets not beside the repository)"; \
  }

void Print(const char* what, const SolverSummary& s) {
  std::printf("%s: %s, chi2 %.12g -> %.12g, %d iterations, %.3f s\n", what, ToString(s.status), s.initial_chi2,
              s.final_chi2, s.iterations, s.total_seconds);
}

GraphFile ReadChordal(const std::string& path, const ReadOptions& options = {}) {
  GraphFile f = ReadGraphFile(path, DefaultRegistry(), options);
  Initialize(f.graph, &f.values, InitMethod::kChordal);
  return f;
}

SolverOptions Gn() {
  SolverOptions o;
  o.algorithm = Algorithm::kGaussNewton;
  return o;
}

int Count(const GraphFile& f, VarType t) {
  int n = 0;
  for (Key k : f.values.keys()) n += f.values.TypeOf(k) == t ? 1 : 0;
  return n;
}

TEST(LandmarkDatasetTest, VictoriaParkReadsAsIsam) {
  const std::string path = Landmarks("victoria_park.txt");
  SKIP_IF_ABSENT(path);
  const GraphFile f = ReadGraphFile(path, DefaultRegistry());
  EXPECT_EQ(Count(f, VarType::kSE2), 6969);
  EXPECT_EQ(Count(f, VarType::kPoint2), 151);
  EXPECT_EQ(f.graph.size(), 10608u);
  EXPECT_EQ(f.loop_closures, 0) << "ODOMETRY lines are odometry";
  // Line 1: ODOMETRY 0 1 ... 0.0001 0 0 4e-06 0 4e-06, read as iSAM's square-root information.
  const Eigen::MatrixXd omega = f.graph.at(0).noise().Information();
  EXPECT_DOUBLE_EQ(omega(0, 0), 1e-8);
  EXPECT_DOUBLE_EQ(omega(2, 2), 1.6e-11);
  // Line 5: LANDMARK 4 5 11.5387 -3.2007 0.4 0 0.4: landmark 5 is key 1000000005, not pose 5.
  EXPECT_EQ(f.graph.at(4).keys(), (std::vector<Key>{4, kOffset + 5}));
  EXPECT_FALSE(f.values.Has(5));
}

// Read as iSAM reads it, the file's odometry information (1e-8 and 1.6e-11) is negligible beside
// the landmarks' (0.16): the normal equations are numerically singular (Gauss-Newton stops with
// rank-deficient at once) and the minimum lies in a flat valley (LM stops at chi2 2.29 after 2909
// iterations, Ceres at 0.80 after 4217; benchmarks/RESULTS.md). The numbers are the variances
// of round standard deviations (0.01^2, 0.002^2), which is how GTSAM reads this file; read so
// (IsamNoise::kCovariance) the problem is well posed, and that is the one solved here.
TEST(LandmarkDatasetTest, VictoriaParkAsCovarianceLmGnAndCeresAgree) {
  const std::string path = Landmarks("victoria_park.txt");
  SKIP_IF_ABSENT(path);
  ReadOptions cov;
  cov.isam_noise = IsamNoise::kCovariance;
  const GraphFile f = ReadChordal(path, cov);
  Values lm = f.values, ceres = f.values;
  const SolverSummary s_lm = Optimize(f.graph, &lm);
  Print("victoria_park (covariance) lm", s_lm);
  ASSERT_EQ(s_lm.status, SolverStatus::kConverged) << s_lm.FullReport();
  EXPECT_NEAR(s_lm.final_chi2, kVictoriaChi2, 1e-6 * kVictoriaChi2);
  // Gauss-Newton from the Levenberg-Marquardt optimum stays there.
  Values gn = lm;
  const SolverSummary s_gn = Optimize(f.graph, &gn, Gn());
  Print("victoria_park (covariance) gn from lm", s_gn);
  EXPECT_TRUE(s_gn.status == SolverStatus::kConverged) << s_gn.FullReport();
  EXPECT_NEAR(s_gn.final_chi2, s_lm.final_chi2, 1e-6 * s_lm.final_chi2);
  // Gauss-Newton from the chordal start does not settle (its steps overshoot; printed for
  // benchmarks/RESULTS.md, not asserted).
  Values gn_chordal = f.values;
  Print("victoria_park (covariance) gn from chordal", Optimize(f.graph, &gn_chordal, Gn()));
  const SolverSummary s_c = OptimizeWithCeres(f.graph, &ceres);
  Print("victoria_park (covariance) ceres", s_c);
  ASSERT_EQ(s_c.status, SolverStatus::kConverged) << s_c.FullReport();
  EXPECT_NEAR(s_c.final_chi2, s_lm.final_chi2, 1e-6 * s_lm.final_chi2);
}

// The rigid motion (rotation, translation) that best maps the positions of `keys` in a onto
// those in b (least squares, closed form in 2D).
SE2d Align(const Values& a, const Values& b, const std::vector<Key>& keys) {
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (Key k : keys) {
    ca += Eigen::Vector2d(a.Params(k)), cb += Eigen::Vector2d(b.Params(k));
  }
  ca /= static_cast<double>(keys.size()), cb /= static_cast<double>(keys.size());
  double dot = 0, cross = 0;
  for (Key k : keys) {
    const Eigen::Vector2d p = Eigen::Vector2d(a.Params(k)) - ca, q = Eigen::Vector2d(b.Params(k)) - cb;
    dot += p.dot(q), cross += p.x() * q.y() - p.y() * q.x();
  }
  const double th = std::atan2(cross, dot);
  const Eigen::Vector2d t = cb - Eigen::Rotation2Dd(th) * ca;
  return SE2d(t.x(), t.y(), th);
}

// Root mean square distance between the positions of `keys` in a, moved by m, and in b.
double Rmse(const Values& a, const Values& b, const std::vector<Key>& keys, const SE2d& m = SE2d()) {
  double sum = 0;
  for (Key k : keys) sum += (m * Eigen::Vector2d(a.Params(k)) - Eigen::Vector2d(b.Params(k))).squaredNorm();
  return std::sqrt(sum / static_cast<double>(keys.size()));
}

TEST(LandmarkDatasetTest, CityTreesSolvesCloseToItsGroundTruth) {
  const std::string path = Landmarks("cityTrees10000.txt");
  const std::string truth_path = Landmarks("cityTrees10000_groundtruth.txt");
  SKIP_IF_ABSENT(path);
  SKIP_IF_ABSENT(truth_path);
  const GraphFile f = ReadChordal(path);
  EXPECT_EQ(Count(f, VarType::kSE2), 10000);
  EXPECT_EQ(Count(f, VarType::kPoint2), 100);
  // The ground truth is the same graph with exact measurements: composed from pose 0 at the
  // origin, as the estimate is anchored.
  const GraphFile truth = ReadGraphFile(truth_path, DefaultRegistry());
  Values lm = f.values, ceres = f.values;
  const SolverSummary s_lm = Optimize(f.graph, &lm);
  Print("cityTrees10000 lm", s_lm);
  ASSERT_EQ(s_lm.status, SolverStatus::kConverged) << s_lm.FullReport();
  EXPECT_NEAR(s_lm.final_chi2, kCityChi2, 1e-6 * kCityChi2);
  Values gn = f.values;
  const SolverSummary s_gn = Optimize(f.graph, &gn, Gn());
  Print("cityTrees10000 gn", s_gn);
  ASSERT_EQ(s_gn.status, SolverStatus::kConverged) << s_gn.FullReport();
  EXPECT_NEAR(s_gn.final_chi2, s_lm.final_chi2, 1e-6 * s_lm.final_chi2);
  const SolverSummary s_c = OptimizeWithCeres(f.graph, &ceres);
  Print("cityTrees10000 ceres", s_c);
  EXPECT_NEAR(s_c.final_chi2, s_lm.final_chi2, 1e-6 * s_lm.final_chi2);
  std::vector<Key> poses, marks;
  for (Key k : lm.keys()) (lm.TypeOf(k) == VarType::kSE2 ? poses : marks).push_back(k);
  // Positions after the rigid alignment of the poses (as `tether optimize --ground-truth` does).
  const SE2d m0 = Align(f.values, truth.values, poses), m = Align(lm, truth.values, poses);
  const double start_poses = Rmse(f.values, truth.values, poses, m0);
  const double start_marks = Rmse(f.values, truth.values, marks, m0);
  const double poses_rmse = Rmse(lm, truth.values, poses, m), marks_rmse = Rmse(lm, truth.values, marks, m);
  std::printf(
      "cityTrees10000 RMSE against the ground truth (poses aligned rigidly): poses %.4f m (start %.4f), "
      "landmarks %.4f m (start %.4f); without alignment %.4f m and %.4f m\n",
      poses_rmse, start_poses, marks_rmse, start_marks, Rmse(lm, truth.values, poses), Rmse(lm, truth.values, marks));
  EXPECT_LT(poses_rmse, 0.12);
  EXPECT_LT(marks_rmse, 0.06);
}

TEST(LandmarkDatasetTest, ToroExampleWithBearingRangeLines) {
  const std::string path = Landmarks("example.graph");
  SKIP_IF_ABSENT(path);
  const GraphFile f = ReadChordal(path);
  EXPECT_EQ(Count(f, VarType::kSE2), 95);
  EXPECT_EQ(Count(f, VarType::kPoint2), 24);
  Values lm = f.values, gn = f.values;
  const SolverSummary s_lm = Optimize(f.graph, &lm);
  Print("example.graph lm", s_lm);
  ASSERT_EQ(s_lm.status, SolverStatus::kConverged) << s_lm.FullReport();
  EXPECT_NEAR(s_lm.final_chi2, kExampleChi2, 1e-6 * kExampleChi2);
  const SolverSummary s_gn = Optimize(f.graph, &gn, Gn());
  Print("example.graph gn", s_gn);
  EXPECT_NEAR(s_gn.final_chi2, s_lm.final_chi2, 1e-6 * s_lm.final_chi2);
}

}  // namespace
}  // namespace tether
