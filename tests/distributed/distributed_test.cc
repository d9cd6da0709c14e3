// The distributed linear solvers ("petsc", "petsc-iterative"; tether/solvers/distributed.h),
// run by ctest under mpirun with 1, 2 and 3 processes (tests/CMakeLists.txt). Every process
// runs every test; each checks its own result, and the results of all processes are checked
// to be one and the same.
//
// Tolerances: the exact solver ends at CHOLMOD's optimum to 1e-9 relative in chi2, with the same
// iterations (the figure): both factorise the same H exactly, and their steps differ
// only by rounding (1e-12 of the step), far below what changes a keep-or-reject decision.
// Positions are compared to 1e-6 m, angles to 1e-6 rad: at the optimum chi2 is flat, so 1e-9
// in chi2 allows the variables to differ by about sqrt(1e-9) of their spread, and they differ
// far less (the steps agree to rounding).
#include "tether/solvers/distributed.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

DistributedProcess Process() { return StartDistributed(""); }

// Every parameter of every variable, in key order.
std::vector<double> Flatten(const Values& v) {
  std::vector<double> out;
  for (Key k : v.keys()) {
    const double* p = v.Params(k);
    out.insert(out.end(), p, p + AmbientDim(v.TypeOf(k)));
  }
  return out;
}

// Whether every process holds exactly the values the first one holds.
bool SameOnEveryProcess(const Values& v) {
  std::vector<double> mine = Flatten(v), first = mine;
  int n = static_cast<int>(first.size());
  MPI_Bcast(&n, 1, MPI_INT, 0, MPI_COMM_WORLD);
  first.resize(n);
  MPI_Bcast(first.data(), n, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  int same = mine == first ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  return same == 1;
}

double LargestDifference(const Values& a, const Values& b) {
  const std::vector<double> x = Flatten(a), y = Flatten(b);
  double d = x.size() == y.size() ? 0.0 : INFINITY;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i) d = std::max(d, std::abs(x[i] - y[i]));
  return d;
}

struct Solved {
  Values values;
  SolverSummary summary;
};

Solved Solve(const FactorGraph& graph, const Values& start, const std::string& linear,
             const Algorithm& algorithm = Algorithm::kLevenbergMarquardt, double initial_lambda = 0, int threads = 1) {
  Solved s{start, {}};
  SolverOptions o;
  o.algorithm = algorithm;
  o.num_threads = threads;
  // Dog-leg from a small trust region: its first steps are Cauchy and blended steps, whose
  // model rests on H times the gradient.
  o.dogleg.initial_radius = 0.5;
  o.lm.initial_lambda = initial_lambda;
  o.linear_solver = LinearSolverType(linear);
  s.summary = Optimize(graph, &s.values, o);
  return s;
}

// The exact distributed solve against CHOLMOD in this process, from the same start.
void ExpectSameAsCholmod(const FactorGraph& graph, const Values& start, double initial_lambda = 0) {
  const Solved ref = Solve(graph, start, "cholmod", Algorithm::kLevenbergMarquardt, initial_lambda);
  const Solved got = Solve(graph, start, "petsc", Algorithm::kLevenbergMarquardt, initial_lambda);
  ASSERT_EQ(ref.summary.status, SolverStatus::kConverged) << ref.summary.FullReport();
  EXPECT_EQ(got.summary.status, ref.summary.status) << got.summary.FullReport();
  EXPECT_NEAR(got.summary.final_chi2, ref.summary.final_chi2, 1e-9 * ref.summary.final_chi2);
  EXPECT_EQ(got.summary.iterations, ref.summary.iterations);
  EXPECT_EQ(got.summary.accepted_iterations, ref.summary.accepted_iterations);
  EXPECT_LT(LargestDifference(got.values, ref.values), 1e-6);
  EXPECT_TRUE(SameOnEveryProcess(got.values));
  const std::string d = got.summary.FullReport();
  EXPECT_NE(d.find("mumps"), std::string::npos) << d;
  EXPECT_NE(d.find("on " + std::to_string(Process().size) + " process"), std::string::npos) << d;
  // With more than one process each linearises only the factors of the variables it owns.
  EXPECT_EQ(d.find("factors split by owner") != std::string::npos, Process().size > 1) << d;
  EXPECT_EQ(got.summary.num_residuals, ref.summary.num_residuals);
}

SimulatedGraph Sim(SimWorld world, int poses, std::uint64_t seed) {
  SimulateOptions o;
  o.world = world;
  o.poses = poses;
  o.seed = seed;
  o.landmarks = 80;
  return Simulate(o);
}

Values ChordalStart(const FactorGraph& graph, const Values& file) {
  Values v = file;
  Initialize(graph, &v, InitMethod::kChordal);
  return v;
}

TEST(Distributed, StartsOnceOnEveryProcess) {
  const DistributedProcess p = Process();
  EXPECT_TRUE(DistributedBuilt());
  int rank = -1, size = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  EXPECT_EQ(p.rank, rank);
  EXPECT_EQ(p.size, size);
  if (const char* n = std::getenv("OMPI_COMM_WORLD_SIZE")) {
    EXPECT_EQ(p.size, std::atoi(n));
  }
  const DistributedProcess again = StartDistributed("-these_options_come_too_late");
  EXPECT_EQ(again.rank, p.rank);
  EXPECT_EQ(CurrentProcess().size, p.size);
}

TEST(Distributed, SameOptimumAsCholmodOnAManhattanWorld) {
  const SimulatedGraph s = Sim(SimWorld::kManhattan, 1500, 3);
  ExpectSameAsCholmod(s.graph, s.initial);
}

TEST(Distributed, SameOptimumAsCholmodOnASphereWorld) {  // block size 6
  const SimulatedGraph s = Sim(SimWorld::kSphere, 600, 4);
  ExpectSameAsCholmod(s.graph, ChordalStart(s.graph, s.initial));
}

TEST(Distributed, SameOptimumAsCholmodWithLandmarks) {  // poses 3, points 2: PETSc's block size 1
  const SimulatedGraph s = Sim(SimWorld::kLandmarks, 300, 5);
  ExpectSameAsCholmod(s.graph, s.initial);
}

// Damped steps (Levenberg-Marquardt started with damping): the damping of each variable is in
// its owner's share, and the path is the same as in one process.
TEST(Distributed, DampedStepsAsInOneProcess) {
  const SimulatedGraph s = Sim(SimWorld::kManhattan, 1200, 9);
  const Solved ref = Solve(s.graph, s.initial, "cholmod", Algorithm::kLevenbergMarquardt, 1e-2);
  int damped = 0;
  for (const IterationSummary& it : ref.summary.log) damped += it.lambda > 0 ? 1 : 0;
  ASSERT_GE(damped, 3);
  ExpectSameAsCholmod(s.graph, s.initial, 1e-2);
}

// Gauss-Newton and dog-leg (whose model needs H times a vector: summed over the processes'
// shares), with two threads assembling each share: the same path as in one process.
TEST(Distributed, GaussNewtonAndDogLegAsInOneProcess) {
  const SimulatedGraph s = Sim(SimWorld::kManhattan, 800, 10);
  for (const Algorithm& a : {Algorithm::kGaussNewton, Algorithm::kDogLeg}) {
    SCOPED_TRACE(a.name());
    const Solved ref = Solve(s.graph, s.initial, "cholmod", a);
    const Solved got = Solve(s.graph, s.initial, "petsc", a, 0, 2);
    ASSERT_EQ(ref.summary.status, SolverStatus::kConverged) << ref.summary.FullReport();
    EXPECT_EQ(got.summary.status, ref.summary.status) << got.summary.FullReport();
    EXPECT_NEAR(got.summary.final_chi2, ref.summary.final_chi2, 1e-9 * ref.summary.final_chi2);
    EXPECT_EQ(got.summary.iterations, ref.summary.iterations);
    EXPECT_LT(LargestDifference(got.values, ref.values), 1e-6);
    EXPECT_TRUE(SameOnEveryProcess(got.values));
  }
}

TEST(Distributed, IterativeReachesTheOptimum) {
  const SimulatedGraph s = Sim(SimWorld::kManhattan, 800, 6);
  const Solved ref = Solve(s.graph, s.initial, "cholmod");
  const Solved got = Solve(s.graph, s.initial, "petsc-iterative");
  EXPECT_EQ(got.summary.status, SolverStatus::kConverged) << got.summary.FullReport();
  // Conjugate gradients to 1e-10 of |g| per step: the optimum to far better than 1e-6.
  EXPECT_NEAR(got.summary.final_chi2, ref.summary.final_chi2, 1e-6 * ref.summary.final_chi2);
  EXPECT_GT(got.summary.linear_solver_iterations, 0);
  EXPECT_TRUE(SameOnEveryProcess(got.values));
  EXPECT_NE(got.summary.FullReport().find("gamg"), std::string::npos) << got.summary.FullReport();
}

// The chordal start through the distributed solver: every process gets the same start, the
// one the single-process Cholesky gives (to rounding: 1e-9).
TEST(Distributed, ChordalStartThroughTheDistributedSolver) {
  const SimulatedGraph s = Sim(SimWorld::kSphere, 500, 8);
  Values local = s.initial, spread = s.initial;
  Initialize(s.graph, &local, InitMethod::kChordal);
  const InitSummary i = Initialize(s.graph, &spread, InitMethod::kChordal, LinearSolverType("petsc"));
  EXPECT_EQ(i.poses_set, 499);
  EXPECT_TRUE(SameOnEveryProcess(spread));
  EXPECT_LT(LargestDifference(spread, local), 1e-9);
  EXPECT_GT(LargestDifference(spread, s.initial), 1e-3);  // it did move the poses
}

// A singular system is reported by every process alike, and none waits for the others:
// Gauss-Newton (which does not damp) on a pose seen only from a landmark at its own place, whose
// heading no measurement depends on.
TEST(Distributed, SingularSystemReportedOnEveryProcess) {
  FactorGraph g;
  Values v;
  v.Insert(0, SE2d(0, 0, 0));
  v.Insert(1, SE2d(1, 0, 0.1));
  v.Insert(2, Eigen::Vector2d(1, 0));
  g.Add<PriorSE2>(0, SE2d(0, 0, 0), SqrtInformation::Isotropic(3, 0.1));
  g.Add<PosePoint2>(0, 2, Eigen::Vector2d(1.1, 0), SqrtInformation::Isotropic(2, 0.1));
  g.Add<PosePoint2>(1, 2, Eigen::Vector2d(0.05, 0), SqrtInformation::Isotropic(2, 0.1));
  const Solved ref = Solve(g, v, "cholmod", Algorithm::kGaussNewton);
  const Solved got = Solve(g, v, "petsc", Algorithm::kGaussNewton);
  EXPECT_EQ(ref.summary.status, SolverStatus::kRankDeficient) << ref.summary.FullReport();
  EXPECT_EQ(got.summary.status, ref.summary.status) << got.summary.FullReport();
  int status = static_cast<int>(got.summary.status), first = status;
  MPI_Bcast(&first, 1, MPI_INT, 0, MPI_COMM_WORLD);
  int same = first == status ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  EXPECT_EQ(same, 1);
}

// The public files the issue names (skipped where ../shared/datasets is absent).
class DistributedDataset : public ::testing::TestWithParam<const char*> {};

TEST_P(DistributedDataset, SameOptimumAsCholmod) {
  const std::string path = std::string(TETHER_DATASETS_DIR) + "/g2o/" + GetParam();
  if (!std::ifstream(path).good())
    GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  const GraphFile f = ReadGraphFile(path, DefaultRegistry());
  ExpectSameAsCholmod(f.graph, ChordalStart(f.graph, f.values));
}

INSTANTIATE_TEST_SUITE_P(G2o, DistributedDataset, ::testing::Values("intel.g2o", "sphere2500.g2o"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           std::string n = i.param;
                           return n.substr(0, n.find('.'));
                         });

}  // namespace
}  // namespace tether
