// The example plugins (plugins/examples/range_2d and position_prior), loaded the way a user
// loads them: registration, Jacobians against central differences, g2o round trips, solving
// synthetic problems back to their ground truth, loading twice, and the lifetime rule.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "testing/jacobian_check.h"
#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }

// A fresh registry with the built-in types (EDGE_SE2, ...) and a loader for it.
class ExamplePluginsTest : public ::testing::Test {
 protected:
  ExamplePluginsTest() { RegisterBuiltinFactors(registry_); }

  // Loads a plugin and returns its type for `tag`.
  const FactorType& LoadType(const std::string& plugin, const std::string& tag) {
    loader_.Load(PluginPath(plugin));
    const FactorType* t = registry_.FindByTag(tag);
    if (t == nullptr) throw Error("plugin " + plugin + " did not register " + tag);
    return *t;
  }

  Registry registry_;
  PluginLoader loader_{registry_};
};

// ---- random inputs ----

// An angle anywhere in (-pi, pi], or within 1e-4 of +-pi.
double RandomAngle(std::mt19937& rng, bool near_pi) {
  std::uniform_real_distribution<double> u(-1, 1);
  if (!near_pi) return kPi * u(rng);
  return (kPi - 1e-4 * std::abs(u(rng))) * (u(rng) > 0 ? 1 : -1);
}

SE2d RandomSE2(std::mt19937& rng, bool near_pi) {
  std::uniform_real_distribution<double> u(-5, 5);
  return SE2d(u(rng), u(rng), RandomAngle(rng, near_pi));
}

// A rotation about a random axis by a random angle (near pi when asked).
SE3d RandomSE3(std::mt19937& rng, bool near_pi) {
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  const Eigen::Vector3d t(5 * u(rng), 5 * u(rng), 5 * u(rng));
  return SE3d(SO3d::Exp(axis * std::abs(RandomAngle(rng, near_pi))), t);
}

// A random symmetric positive definite information matrix.
SqrtInformation RandomInformation(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(n, n, [&]() { return u(rng); });
  return SqrtInformation::FromInformation(a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n));
}

// ---- registration ----

TEST_F(ExamplePluginsTest, Range2DRegistersItsType) {
  const std::size_t builtin = registry_.types().size();
  const LoadedPlugin p = loader_.Load(PluginPath("range_2d"));
  EXPECT_EQ(p.name, "range_2d");
  EXPECT_EQ(p.version, "1.0.0");
  EXPECT_EQ(p.type_names, std::vector<std::string>{"Range2D"});
  EXPECT_EQ(registry_.types().size(), builtin + 1);
  const FactorType* t = registry_.FindByTag("EDGE_RANGE_SE2_XY");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->name, "Range2D");
  EXPECT_EQ(t->owner, "range_2d");
  EXPECT_EQ(t->dim, 1);
  EXPECT_EQ(t->variable_types, (std::vector<VarType>{VarType::kSE2, VarType::kPoint2}));
  EXPECT_EQ(t->measurement_size, 1);
  EXPECT_EQ(t->StandardFieldCount(), 4u);  // id_pose id_landmark range I11
  EXPECT_EQ(registry_.FindByName("Range2D"), t);
  ASSERT_NE(registry_.FindByTag("EDGE_SE2"), nullptr);  // the built-ins are still there
}

TEST_F(ExamplePluginsTest, PositionPriorRegistersSE2AndSE3Types) {
  const std::size_t builtin = registry_.types().size();
  const LoadedPlugin p = loader_.Load(PluginPath("position_prior"));
  EXPECT_EQ(p.name, "position_prior");
  EXPECT_EQ(p.type_names, (std::vector<std::string>{"PositionPriorSE2", "PositionPriorSE3"}));
  EXPECT_EQ(registry_.types().size(), builtin + 2);
  const FactorType* se2 = registry_.FindByTag("EDGE_POSITION_PRIOR_SE2");
  const FactorType* se3 = registry_.FindByTag("EDGE_POSITION_PRIOR_SE3");
  ASSERT_NE(se2, nullptr);
  ASSERT_NE(se3, nullptr);
  EXPECT_EQ(se2->name, "PositionPriorSE2");
  EXPECT_EQ(se3->name, "PositionPriorSE3");
  EXPECT_EQ(se2->owner, "position_prior");
  EXPECT_EQ(se3->owner, "position_prior");
  EXPECT_EQ(se2->dim, 2);
  EXPECT_EQ(se3->dim, 3);
  EXPECT_EQ(se2->variable_types, std::vector<VarType>{VarType::kSE2});
  EXPECT_EQ(se3->variable_types, std::vector<VarType>{VarType::kSE3});
  EXPECT_EQ(se2->StandardFieldCount(), 6u);   // id x y + 3 information numbers
  EXPECT_EQ(se3->StandardFieldCount(), 10u);  // id x y z + 6 information numbers
}

// ---- Range2D: error, Jacobians, refusals ----

TEST_F(ExamplePluginsTest, Range2DErrorAndJacobians) {
  const FactorType& type = LoadType("range_2d", "EDGE_RANGE_SE2_XY");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5, 5), range(0, 10);
  double worst = 0;
  for (int i = 0; i < 200; ++i) {
    const SE2d x = RandomSE2(rng, i % 2 == 1);
    Eigen::Vector2d l;
    do {
      l = Eigen::Vector2d(u(rng), u(rng));
    } while ((l - x.translation()).norm() < 0.1);  // at least 0.1 away (the curvature is 1/distance)
    const double r = range(rng);
    const std::unique_ptr<Factor> f = type.make({1, 2}, &r, RandomInformation(rng, 1));
    EXPECT_EQ(f->type_name(), "Range2D");
    EXPECT_EQ(f->dim(), 1);
    Values v;
    v.Insert(1, x);
    v.Insert(2, l);
    const std::vector<const double*> p = f->GatherParams(v);
    double e = 0, jx[3], jl[2];
    double* jac[] = {jx, jl};
    ASSERT_TRUE(f->Evaluate(p.data(), &e, jac));
    EXPECT_NEAR(e, (l - x.translation()).norm() - r, 1e-12);
    EXPECT_EQ(jx[2], 0.0);  // a distance does not depend on the heading
    worst = std::max(worst, testing::CheckJacobians(*f, v, 1e-6));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST_F(ExamplePluginsTest, Range2DRefusesZeroDistance) {
  const FactorType& type = LoadType("range_2d", "EDGE_RANGE_SE2_XY");
  const double r = 1.0;
  const std::unique_ptr<Factor> f = type.make({1, 2}, &r, SqrtInformation::Identity(1));
  Values v;
  v.Insert(1, SE2d(1.5, -2.0, 0.3));
  v.Insert(2, Eigen::Vector2d(1.5, -2.0));  // the pose sits on the landmark
  const std::vector<const double*> p = f->GatherParams(v);
  double e = 0, jx[3], jl[2];
  double* jac[] = {jx, jl};
  EXPECT_FALSE(f->Evaluate(p.data(), &e, jac));
  EXPECT_FALSE(f->Evaluate(p.data(), &e, nullptr));
  EXPECT_TRUE(std::isinf(f->Chi2(v)));
  // A solve that starts there is refused, not run on a made-up Jacobian.
  FactorGraph graph;
  graph.Add(f->Clone());
  graph.Fix(2);
  const SolverSummary s = Optimize(graph, &v);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput) << s.message;
  EXPECT_EQ(v.At<SE2d>(1).x(), 1.5);  // values untouched
}

TEST_F(ExamplePluginsTest, Range2DRefusesNegativeRangeNamingTheLine) {
  const FactorType& type = LoadType("range_2d", "EDGE_RANGE_SE2_XY");
  const double r = -0.5;
  EXPECT_THROW(type.make({1, 2}, &r, SqrtInformation::Identity(1)), InvalidArgument);
  // Thrown inside the plugin, caught by the reader in libtether_core, reported with file:line.
  std::istringstream in(
      "VERTEX_SE2 1 0 0 0\n"
      "VERTEX_XY 2 3 4\n"
      "EDGE_RANGE_SE2_XY 1 2 -0.5 1\n");
  try {
    ReadGraph(in, "beacons.g2o", registry_);
    FAIL() << "a negative range was accepted";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("beacons.g2o:3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("negative"), std::string::npos) << e.what();
  }
}

// ---- position priors: error, Jacobians ----

TEST_F(ExamplePluginsTest, PositionPriorSE2ErrorAndJacobians) {
  const FactorType& type = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE2");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int i = 0; i < 100; ++i) {
    const SE2d x = RandomSE2(rng, i % 2 == 1);
    const double z[2] = {u(rng), u(rng)};
    const std::unique_ptr<Factor> f = type.make({3}, z, RandomInformation(rng, 2));
    EXPECT_EQ(f->type_name(), "PositionPriorSE2");
    EXPECT_EQ(f->Measurement(), std::vector<double>(z, z + 2));
    Values v;
    v.Insert(3, x);
    const std::vector<const double*> p = f->GatherParams(v);
    double e[2], j[6];
    double* jac[] = {j};
    ASSERT_TRUE(f->Evaluate(p.data(), e, jac));
    EXPECT_NEAR(e[0], x.x() - z[0], 1e-12);
    EXPECT_NEAR(e[1], x.y() - z[1], 1e-12);
    // Box-plus moves the position in the body frame, so d e / d delta = [R 0].
    const Eigen::Matrix2d R = x.rotation().matrix();
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 2; ++c) EXPECT_NEAR(j[r * 3 + c], R(r, c), 1e-12);
      EXPECT_EQ(j[r * 3 + 2], 0.0);
    }
    testing::CheckJacobians(*f, v, 1e-7);
  }
}

TEST_F(ExamplePluginsTest, PositionPriorSE3ErrorAndJacobians) {
  const FactorType& type = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE3");
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int i = 0; i < 100; ++i) {
    const SE3d x = RandomSE3(rng, i % 2 == 1);
    const double z[3] = {u(rng), u(rng), u(rng)};
    const std::unique_ptr<Factor> f = type.make({4}, z, RandomInformation(rng, 3));
    EXPECT_EQ(f->type_name(), "PositionPriorSE3");
    Values v;
    v.Insert(4, x);
    const std::vector<const double*> p = f->GatherParams(v);
    double e[3], j[18];
    double* jac[] = {j};
    ASSERT_TRUE(f->Evaluate(p.data(), e, jac));
    const Eigen::Matrix3d R = x.rotation().matrix();
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(e[r], x.translation()[r] - z[r], 1e-12);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(j[r * 6 + c], R(r, c), 1e-12);
      for (int c = 3; c < 6; ++c) EXPECT_EQ(j[r * 6 + c], 0.0);
    }
    testing::CheckJacobians(*f, v, 1e-7);
  }
}

// ---- g2o files ----

// Reads `text`, writes it, reads that back: the graphs must agree, and writing again must
// give the same text. Returns the written text.
std::string RoundTrip(const std::string& text, const Registry& registry) {
  std::istringstream in(text);
  const GraphFile file = ReadGraph(in, "in.g2o", registry);
  std::ostringstream out;
  WriteG2o(out, file.values, file.graph, registry);
  std::istringstream again(out.str());
  const GraphFile reread = ReadGraph(again, "written.g2o", registry);
  EXPECT_EQ(reread.graph.size(), file.graph.size());
  for (std::size_t i = 0; i < std::min(file.graph.size(), reread.graph.size()); ++i) {
    const Factor& a = file.graph.at(i);
    const Factor& b = reread.graph.at(i);
    EXPECT_EQ(a.type_name(), b.type_name());
    EXPECT_EQ(a.keys(), b.keys());
    EXPECT_EQ(a.Measurement(), b.Measurement());
    EXPECT_LT((a.noise().Information() - b.noise().Information()).norm(), 1e-12);
  }
  EXPECT_EQ(reread.graph.fixed(), file.graph.fixed());
  std::ostringstream out2;
  WriteG2o(out2, reread.values, reread.graph, registry);
  EXPECT_EQ(out2.str(), out.str());
  return out.str();
}

TEST_F(ExamplePluginsTest, G2oRoundTripSE2WithRangesAndPositionPriors) {
  loader_.Load(PluginPath("range_2d"));
  loader_.Load(PluginPath("position_prior"));
  const std::string text =
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_SE2 1 1.5 0.25 0.5\n"
      "VERTEX_XY 10 3 4\n"
      "FIX 0\n"
      "EDGE_SE2 0 1 1.5 0.25 0.5 100 0 0 100 0 400\n"
      "EDGE_RANGE_SE2_XY 0 10 5.01 25\n"
      "EDGE_RANGE_SE2_XY 1 10 3.8125 16\n"
      "EDGE_POSITION_PRIOR_SE2 1 1.625 0.1875 4 0.5 2\n";
  std::istringstream in(text);
  const GraphFile file = ReadGraph(in, "plane.g2o", registry_);
  ASSERT_EQ(file.graph.size(), 4u);
  EXPECT_EQ(file.graph.at(1).type_name(), "Range2D");
  EXPECT_EQ(file.graph.at(1).keys(), (std::vector<Key>{0, 10}));
  EXPECT_EQ(file.graph.at(1).Measurement(), std::vector<double>{5.01});
  EXPECT_DOUBLE_EQ(file.graph.at(2).noise().Information()(0, 0), 16.0);
  EXPECT_EQ(file.graph.at(3).type_name(), "PositionPriorSE2");
  EXPECT_EQ(file.graph.at(3).Measurement(), (std::vector<double>{1.625, 0.1875}));
  Eigen::Matrix2d omega;
  omega << 4, 0.5, 0.5, 2;
  EXPECT_LT((file.graph.at(3).noise().Information() - omega).norm(), 1e-12);

  const std::string written = RoundTrip(text, registry_);
  // The plugin edges come back with the numbers they had.
  for (const char* line : {"EDGE_RANGE_SE2_XY 0 10 5.01 25\n", "EDGE_RANGE_SE2_XY 1 10 3.8125 16\n",
                           "EDGE_POSITION_PRIOR_SE2 1 1.625 0.1875 4 0.5 2\n"}) {
    EXPECT_NE(written.find(line), std::string::npos) << "missing: " << line << "in:\n" << written;
  }
}

TEST_F(ExamplePluginsTest, G2oRoundTripSE3WithPositionPriors) {
  loader_.Load(PluginPath("position_prior"));
  const std::string text =
      "VERTEX_SE3:QUAT 20 1 2 3 0 0 0 1\n"
      "VERTEX_SE3:QUAT 21 2 2 3 0 0 0.6 0.8\n"
      "EDGE_SE3:QUAT 20 21 1 0 0 0 0 0.6 0.8 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n"
      "EDGE_POSITION_PRIOR_SE3 20 1.25 2 3.5 9 0.25 0 9 0 1\n"
      "EDGE_POSITION_PRIOR_SE3 21 2 2.5 3 1 0 0 1 0 1\n";
  std::istringstream in(text);
  const GraphFile file = ReadGraph(in, "space.g2o", registry_);
  ASSERT_EQ(file.graph.size(), 3u);
  EXPECT_EQ(file.graph.at(1).type_name(), "PositionPriorSE3");
  EXPECT_EQ(file.graph.at(1).keys(), std::vector<Key>{20});
  EXPECT_EQ(file.graph.at(1).Measurement(), (std::vector<double>{1.25, 2, 3.5}));
  Eigen::Matrix3d omega;
  omega << 9, 0.25, 0, 0.25, 9, 0, 0, 0, 1;
  EXPECT_LT((file.graph.at(1).noise().Information() - omega).norm(), 1e-12);

  const std::string written = RoundTrip(text, registry_);
  for (const char* line :
       {"EDGE_POSITION_PRIOR_SE3 20 1.25 2 3.5 9 0.25 0 9 0 1\n", "EDGE_POSITION_PRIOR_SE3 21 2 2.5 3 1 0 0 1 0 1\n"}) {
    EXPECT_NE(written.find(line), std::string::npos) << "missing: " << line << "in:\n" << written;
  }
}

TEST_F(ExamplePluginsTest, MalformedPluginLineIsAParseError) {
  loader_.Load(PluginPath("position_prior"));
  std::istringstream in(
      "VERTEX_SE2 1 0 0 0\n"
      "EDGE_POSITION_PRIOR_SE2 1 0.5 0.5 1 0\n");  // one information number short
  try {
    ReadGraph(in, "short.g2o", registry_);
    FAIL() << "a short line was accepted";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("short.g2o:2:"), std::string::npos) << e.what();
  }
}

// ---- solving synthetic problems back to their ground truth ----

// Gaussian noise; scale 0 gives exact measurements.
struct Noise {
  std::mt19937 rng;
  double scale;
  double operator()(double sigma) { return scale * sigma * std::normal_distribution<double>(0, 1)(rng); }
};

// The covariance of the estimate predicted by the problem itself: (J^T J)^-1, with J the
// whitened Jacobian at `values` over the variables that are not fixed. Dense: small
// problems only. `offsets` receives each free variable's first column.
Eigen::MatrixXd PredictedCovariance(const FactorGraph& graph, const Values& values, std::map<Key, int>* offsets) {
  int n = 0;
  for (Key k : values.keys()) {
    if (graph.IsFixed(k)) continue;
    (*offsets)[k] = n;
    n += TangentDim(values.TypeOf(k));
  }
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  for (const auto& f : graph.factors()) {
    const std::vector<const double*> p = f->GatherParams(values);
    const std::vector<VarType> types = f->variable_types();
    std::vector<std::vector<double>> blocks(types.size());
    std::vector<double*> jac(types.size());
    for (std::size_t i = 0; i < types.size(); ++i) {
      blocks[i].resize(f->dim() * TangentDim(types[i]));
      jac[i] = blocks[i].data();
    }
    std::vector<double> r(f->dim());
    EXPECT_TRUE(f->Linearize(p.data(), r.data(), jac.data()));
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(f->dim(), n);
    for (std::size_t i = 0; i < types.size(); ++i) {
      if (graph.IsFixed(f->keys()[i])) continue;
      using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      J.middleCols(offsets->at(f->keys()[i]), TangentDim(types[i])) =
          Eigen::Map<const RowMajor>(blocks[i].data(), f->dim(), TangentDim(types[i]));
    }
    H += J.transpose() * J;
  }
  return H.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
}

// Checks a solve of `graph` from any start against the ground truth `truth`:
// - it converged, and chi2 at the solution is no higher than at the truth;
// - with noise, chi2 is within 5 standard deviations of its expected value (a least-squares
//   optimum is close to chi-square distributed with residuals - unknowns degrees of freedom);
// - every pose's position and rotation error is within 4 standard deviations predicted by the
//   problem's own covariance (sigma = sqrt of the trace of the block), or below 1e-6 without noise.
void ExpectBackToTruth(const char* what, const FactorGraph& graph, const Values& truth, const Values& solution,
                       const SolverSummary& s, double noise_scale) {
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  const double truth_chi2 = graph.Chi2(truth);
  EXPECT_LE(s.final_chi2, truth_chi2 * (1 + 1e-9) + 1e-12);  // slack for rounding only
  const double dof = s.num_residuals - s.tangent_dim;
  if (noise_scale > 0) {
    EXPECT_LT(std::abs(s.final_chi2 - dof), 5 * std::sqrt(2 * dof)) << "dof " << dof;
  }

  std::map<Key, int> offsets;
  const Eigen::MatrixXd covariance = PredictedCovariance(graph, truth, &offsets);
  double max_position = 0, max_angle = 0, max_ratio = 0;
  for (Key k : truth.keys()) {
    const VarType type = truth.TypeOf(k);
    if (!IsPose(type) || graph.IsFixed(k)) continue;
    double position, angle;
    if (type == VarType::kSE2) {
      const SE2d a = truth.At<SE2d>(k), b = solution.At<SE2d>(k);
      position = (b.translation() - a.translation()).norm();
      angle = std::abs(WrapAngle(b.theta() - a.theta()));
    } else {
      const SE3d a = truth.At<SE3d>(k), b = solution.At<SE3d>(k);
      position = (b.translation() - a.translation()).norm();
      angle = (a.rotation().Inverse() * b.rotation()).Log().norm();
    }
    // Tangent order: translation (2 or 3), then rotation (1 or 3). Box-plus moves the
    // translation in the body frame; the trace does not depend on the frame.
    const int o = offsets.at(k), nt = type == VarType::kSE2 ? 2 : 3, nr = type == VarType::kSE2 ? 1 : 3;
    const double sigma_position = std::sqrt(covariance.block(o, o, nt, nt).trace());
    const double sigma_angle = std::sqrt(covariance.block(o + nt, o + nt, nr, nr).trace());
    max_position = std::max(max_position, position);
    max_angle = std::max(max_angle, angle);
    max_ratio = std::max({max_ratio, position / sigma_position, angle / sigma_angle});
    if (noise_scale == 0) {
      EXPECT_LT(position, 1e-6) << KeyToString(k);
      EXPECT_LT(angle, 1e-6) << KeyToString(k);
    } else {
      EXPECT_LT(position, 4 * sigma_position) << KeyToString(k);
      EXPECT_LT(angle, 4 * sigma_angle) << KeyToString(k);
    }
  }
  std::printf("%s: chi2 %.4g -> %.4g (ground truth %.4g, dof %g); error max %.3g m, %.3g rad; max error/sigma %.2f\n",
              what, s.initial_chi2, s.final_chi2, truth_chi2, dof, max_position, max_angle, max_ratio);
}

// A robot drives 0.95 of a circle of radius 8 m (its heading passes through +-pi) with
// odometry sigma 5 cm / 0.01 rad. Returns the true poses x0..x(n-1); adds the odometry
// factors, and initial values composed from the noisy odometry from `start`.
std::vector<SE2d> DriveCircle(int n, Noise& noise, const SE2d& start, FactorGraph* graph, Values* initial) {
  std::vector<SE2d> truth;
  for (int k = 0; k < n; ++k) {
    const double a = 0.95 * 2 * kPi * k / n;
    truth.emplace_back(8 * std::cos(a), 8 * std::sin(a), a + kPi / 2);
  }
  const double sigma_xy = 0.05, sigma_theta = 0.01;
  const Eigen::Vector3d information(1 / (sigma_xy * sigma_xy), 1 / (sigma_xy * sigma_xy),
                                    1 / (sigma_theta * sigma_theta));
  const SqrtInformation odometry_noise = SqrtInformation::FromInformation(information.asDiagonal().toDenseMatrix());
  SE2d x = start;
  initial->Insert(Symbol('x', 0), x);
  for (int k = 0; k + 1 < n; ++k) {
    // The error at the truth is toVector(N^-1): exactly Gaussian, as the translation noise is isotropic.
    const SE2d z = truth[k].Inverse() * truth[k + 1] * SE2d(noise(sigma_xy), noise(sigma_xy), noise(sigma_theta));
    graph->Add(std::make_unique<BetweenSE2>(Symbol('x', k), Symbol('x', k + 1), z, odometry_noise));
    x = x * z;
    initial->Insert(Symbol('x', k + 1), x);
  }
  return truth;
}

// `values` with poses x0..x(n-1) replaced by the truth.
template <class Pose>
Values WithTruth(Values values, const std::vector<Pose>& truth) {
  for (std::size_t k = 0; k < truth.size(); ++k) values.Update(Symbol('x', k), truth[k]);
  return values;
}

// Parameter: the noise scale (0: exact measurements, 1: the sigmas stated in each test).
class ExamplePluginsSolveTest : public ExamplePluginsTest, public ::testing::WithParamInterface<double> {};

// Odometry plus ranges from every pose to four radio beacons at known positions (fixed
// landmarks), range sigma 0.1 m. Starts from dead reckoning that begins 0.5 m / 0.1 rad off.
TEST_P(ExamplePluginsSolveTest, OdometryAndRangesToFixedBeacons) {
  const FactorType& range = LoadType("range_2d", "EDGE_RANGE_SE2_XY");
  Noise noise{std::mt19937(17), GetParam()};
  FactorGraph graph;
  Values values;
  const int n = 40;
  const std::vector<SE2d> truth = DriveCircle(n, noise, SE2d(8.5, -0.3, kPi / 2 + 0.1), &graph, &values);
  const Eigen::Vector2d beacons[] = {{12, 12}, {-12, 12}, {-12, -12}, {12, -13}};
  const double sigma_r = 0.1;
  for (int j = 0; j < 4; ++j) {
    values.Insert(Symbol('l', j), beacons[j]);
    graph.Fix(Symbol('l', j));
    for (int k = 0; k < n; ++k) {
      const double r = (beacons[j] - truth[k].translation()).norm() + noise(sigma_r);
      graph.Add(range.make({Symbol('x', k), Symbol('l', j)}, &r, SqrtInformation::Isotropic(1, sigma_r)));
    }
  }
  const Values ground_truth = WithTruth(values, truth);
  const SolverSummary s = Optimize(graph, &values);
  ExpectBackToTruth("odometry + ranges", graph, ground_truth, values, s, GetParam());
}

// Odometry plus GPS fixes with a correlated covariance (sigma 0.5 m / 0.4 m, correlation 0.25)
// on every 4th pose, and nothing fixed: the priors hold the frame. Starts from dead reckoning
// that begins 3.6 m and 0.6 rad off the truth.
TEST_P(ExamplePluginsSolveTest, OdometryAndGpsPriorsSE2) {
  const FactorType& gps = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE2");
  Noise noise{std::mt19937(19), GetParam()};
  FactorGraph graph;
  Values values;
  const int n = 40;
  const std::vector<SE2d> truth = DriveCircle(n, noise, SE2d(11, -2, kPi / 2 + 0.6), &graph, &values);
  Eigen::Matrix2d covariance;
  covariance << 0.25, 0.05, 0.05, 0.16;
  const Eigen::Matrix2d L = covariance.llt().matrixL();
  const SqrtInformation gps_noise = SqrtInformation::FromInformation(covariance.inverse());
  for (int k = 0; k < n; k += 4) {
    const Eigen::Vector2d z = truth[k].translation() + L * Eigen::Vector2d(noise(1), noise(1));
    graph.Add(gps.make({Symbol('x', k)}, z.data(), gps_noise));
  }
  const Values ground_truth = WithTruth(values, truth);
  const SolverSummary s = Optimize(graph, &values);
  EXPECT_FALSE(s.gauge_fixed_automatically);  // the priors are unary factors
  ExpectBackToTruth("odometry + gps 2d", graph, ground_truth, values, s, GetParam());
}

// A 3D helix with SE3 odometry (sigma 3 cm; quaternion vector part 0.0025, about 0.005 rad)
// and GPS fixes (sigma 0.3 m) on every 3rd pose. Starts from dead reckoning that begins
// about 1.2 m and 0.2 rad off the truth.
TEST_P(ExamplePluginsSolveTest, OdometryAndGpsPriorsSE3) {
  const FactorType& gps = LoadType("position_prior", "EDGE_POSITION_PRIOR_SE3");
  Noise noise{std::mt19937(23), GetParam()};
  const int n = 40;
  std::vector<SE3d> truth;
  for (int k = 0; k < n; ++k) {
    const double a = 0.2 * k;
    const Eigen::Vector3d w(0.1 * std::sin(a), 0.05 * std::cos(a), a + kPi / 2);
    truth.emplace_back(SO3d::Exp(w), Eigen::Vector3d(6 * std::cos(a), 6 * std::sin(a), 0.1 * k));
  }
  const double sigma_t = 0.03, sigma_q = 0.0025, sigma_gps = 0.3;
  Eigen::Matrix<double, 6, 1> information;
  information << Eigen::Vector3d::Constant(1 / (sigma_t * sigma_t)), Eigen::Vector3d::Constant(1 / (sigma_q * sigma_q));
  const SqrtInformation odometry_noise = SqrtInformation::FromInformation(information.asDiagonal().toDenseMatrix());
  FactorGraph graph;
  Values values;
  Eigen::Matrix<double, 6, 1> offset;
  offset << 1.0, -0.5, 0.3, 0.05, -0.05, 0.2;
  SE3d x = truth[0] * SE3d::Exp(offset);
  values.Insert(Symbol('x', 0), x);
  for (int k = 0; k + 1 < n; ++k) {
    // N with quaternion vector part v and translation u: the error at the truth is
    // (-(R_N^T u), -v), exactly Gaussian with the information above.
    const Eigen::Vector3d v(noise(sigma_q), noise(sigma_q), noise(sigma_q));
    const Eigen::Quaterniond q(std::sqrt(1 - v.squaredNorm()), v.x(), v.y(), v.z());
    const SE3d z =
        truth[k].Inverse() * truth[k + 1] * SE3d(q, Eigen::Vector3d(noise(sigma_t), noise(sigma_t), noise(sigma_t)));
    graph.Add(std::make_unique<BetweenSE3>(Symbol('x', k), Symbol('x', k + 1), z, odometry_noise));
    x = x * z;
    values.Insert(Symbol('x', k + 1), x);
  }
  for (int k = 0; k < n; k += 3) {
    const Eigen::Vector3d z =
        truth[k].translation() + Eigen::Vector3d(noise(sigma_gps), noise(sigma_gps), noise(sigma_gps));
    graph.Add(gps.make({Symbol('x', k)}, z.data(), SqrtInformation::Isotropic(3, sigma_gps)));
  }
  const Values ground_truth = WithTruth(values, truth);
  const SolverSummary s = Optimize(graph, &values);
  ExpectBackToTruth("odometry + gps 3d", graph, ground_truth, values, s, GetParam());
}

INSTANTIATE_TEST_SUITE_P(NoiseScale, ExamplePluginsSolveTest, ::testing::Values(0.0, 1.0),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return info.param == 0 ? std::string("Exact") : std::string("Noisy");
                         });

// ---- loading twice, lifetime ----

TEST_F(ExamplePluginsTest, LoadingTheSameFileTwiceIsHarmless) {
  const LoadedPlugin first = loader_.Load(PluginPath("range_2d"));
  const std::size_t types = registry_.types().size();
  const LoadedPlugin second = loader_.Load(PluginPath("range_2d"));
  // The same file under another spelling of its path, and by bare name through TETHER_PLUGIN_PATH.
  const LoadedPlugin third = loader_.Load(std::string(TETHER_PLUGIN_BUILD_DIR) + "/./range_2d.so");
  const char* old_path = std::getenv("TETHER_PLUGIN_PATH");
  const std::string saved = old_path ? old_path : "";
  setenv("TETHER_PLUGIN_PATH", TETHER_PLUGIN_BUILD_DIR, 1);
  const LoadedPlugin fourth = loader_.Load("range_2d.so");
  if (old_path) {
    setenv("TETHER_PLUGIN_PATH", saved.c_str(), 1);
  } else {
    unsetenv("TETHER_PLUGIN_PATH");
  }
  for (const LoadedPlugin* p : {&second, &third, &fourth}) {
    EXPECT_EQ(p->name, first.name);
    EXPECT_EQ(p->path, first.path);
    EXPECT_EQ(p->type_names, first.type_names);
  }
  EXPECT_EQ(registry_.types().size(), types);
  EXPECT_EQ(loader_.loaded().size(), 1u);
  EXPECT_NE(registry_.FindByTag("EDGE_RANGE_SE2_XY"), nullptr);
}

// The lifetime rule (plugin_loader.h): a plugin stays loaded for the process, so factors it
// made outlive the loader, and even the registry, that brought it in.
TEST(ExamplePluginsLifetimeTest, FactorsOutliveTheLoaderAndTheRegistry) {
  std::unique_ptr<Factor> range, gps;
  {
    Registry registry;
    PluginLoader loader(registry);
    loader.Load(PluginPath("range_2d"));
    loader.Load(PluginPath("position_prior"));
    const double r = 5.0, z[2] = {1.0, 2.0};
    range = registry.FindByTag("EDGE_RANGE_SE2_XY")->make({1, 2}, &r, SqrtInformation::Identity(1));
    gps = registry.FindByTag("EDGE_POSITION_PRIOR_SE2")->make({1}, z, SqrtInformation::Identity(2));
  }
  // Loader and registry are gone; the factors' code (in the .so files) is still mapped.
  Values v;
  v.Insert(1, SE2d(0, 0, 0.3));
  v.Insert(2, Eigen::Vector2d(3, 4));
  EXPECT_NEAR(range->Chi2(v), 0.0, 1e-24);  // |(3, 4)| = 5
  EXPECT_NEAR(gps->Chi2(v), 1.0 + 4.0, 1e-12);
  std::unique_ptr<Factor> copy = range->Clone();
  EXPECT_EQ(copy->type_name(), "Range2D");
  copy.reset();
  testing::CheckJacobians(*range, v, 1e-6);
  testing::CheckJacobians(*gps, v, 1e-7);

  // The same files load again into a new registry (the process still holds them), and the
  // old factors can be written through it.
  Registry registry;
  RegisterBuiltinFactors(registry);
  PluginLoader loader(registry);
  loader.Load(PluginPath("range_2d"));
  loader.Load(PluginPath("position_prior"));
  EXPECT_EQ(registry.Write(*range), "EDGE_RANGE_SE2_XY 1 2 5 1");
  EXPECT_EQ(registry.Write(*gps), "EDGE_POSITION_PRIOR_SE2 1 1 2 1 0 1");
  // Removing a plugin's types unloads no code: its factors still evaluate, but can no longer
  // be written.
  EXPECT_EQ(registry.RemoveOwner("range_2d"), 1);
  EXPECT_EQ(registry.FindByTag("EDGE_RANGE_SE2_XY"), nullptr);
  EXPECT_NEAR(range->Chi2(v), 0.0, 1e-24);
  EXPECT_THROW(registry.Write(*range), InvalidArgument);
  range.reset();
  gps.reset();
}

}  // namespace
}  // namespace tether
