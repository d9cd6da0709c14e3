// The solver's per-iteration loop (linearise, assemble, factorise, solve, evaluate the
// candidate) allocates nothing through operator new. This executable replaces the global
// operator new and counts every call, so it must stay apart from the other test programs.
//
// What it cannot see: CHOLMOD and SuiteSparseQR allocate their own work space with malloc
// (CHOLMOD, for one, builds a permuted copy of H inside every numeric factorisation). The ldlt
// path is Eigen's SimplicialLDLT, which allocates inside factorize (a test below bounds it).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "problem.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/optimizer.h"

namespace {
std::atomic<long> g_news{0};

void* Allocate(std::size_t n) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* AllocateAligned(std::size_t n, std::align_val_t a) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) { return Allocate(n); }
void* operator new[](std::size_t n) { return Allocate(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_news.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  g_news.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t a) { return AllocateAligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return AllocateAligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace tether {
namespace {

SimulatedGraph Sim(SimWorld world) {
  SimulateOptions o;
  o.world = world;
  o.poses = 400;
  o.seed = 3;
  o.landmarks = 40;
  return Simulate(o);
}

TEST(CountingNew, CountsAllocations) {
  const long before = g_news.load();
  std::vector<double>* v = new std::vector<double>(100);
  delete v;
  EXPECT_EQ(g_news.load() - before, 2);  // the vector and its buffer
}

struct Case {
  SimWorld world;
  Algorithm algorithm;
  LinearSolverType linear;
  int threads;
};

class HotLoopTest : public ::testing::TestWithParam<Case> {};

// Allocations between the callback of iteration i and that of i + 1: everything one iteration
// does after the first (the first may size solver work space, CHOLMOD's solve buffers).
// Per-iteration allocation counts (operator new) of a solve with six iterations; steps reuse
// an earlier factorisation as by default unless max_reuse_iterations says otherwise.
std::vector<long> AllocationsPerIteration(const Case& c,
                                          int max_reuse_iterations = SolverOptions().linear.max_reuse_iterations) {
  const SimulatedGraph sim = Sim(c.world);
  Values values = sim.initial;
  SolverOptions o;
  o.algorithm = c.algorithm;
  o.linear_solver = c.linear;
  o.num_threads = c.threads;
  o.linear.max_reuse_iterations = max_reuse_iterations;
  o.function_tolerance = 0;  // run all iterations
  o.gradient_tolerance = 0;
  o.parameter_tolerance = 0;
  o.max_iterations = 6;
  std::vector<long> at;
  at.reserve(64);
  o.callback = [&at](const IterationSummary&) { at.push_back(g_news.load()); };
  const SolverSummary s = Optimize(sim.graph, &values, o);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.message;
  std::vector<long> per_iteration;
  for (std::size_t i = 2; i < at.size(); ++i) per_iteration.push_back(at[i] - at[i - 1]);
  return per_iteration;
}

TEST_P(HotLoopTest, IterationsAfterTheFirstAllocateNothing) {
  const std::vector<long> n = AllocationsPerIteration(GetParam());
  ASSERT_GE(n.size(), 3u);
  for (std::size_t i = 0; i < n.size(); ++i) EXPECT_EQ(n[i], 0) << "iteration " << i + 2 << " allocated";
}

// Eigen's SimplicialLDLT copies the matrix and sizes its work space inside every factorize:
// a fixed number of allocations per factorisation, none of them tether's, that must not
// grow (every step factorises here; a step that reuses the factorisation allocates nothing,
// checked below).
TEST(HotLoopLdlt, EigenLdltAllocatesTheSameFewBlocksEveryFactorisation) {
  const std::vector<long> n =
      AllocationsPerIteration(Case{SimWorld::kLandmarks, Algorithm::kGaussNewton, LinearSolverType::kEigenLDLT, 2}, 0);
  ASSERT_GE(n.size(), 3u);
  for (std::size_t i = 1; i < n.size(); ++i) EXPECT_EQ(n[i], n[0]);
  EXPECT_LE(n[0], 16);
}

// Steps solved with an earlier factorisation (conjugate gradients) allocate nothing, with
// either Cholesky back-end; the run has such steps.
TEST(HotLoopReuse, StepsThatReuseAFactorisationAllocateNothing) {
  for (LinearSolverType linear : {LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT}) {
    const SimulatedGraph sim = Sim(SimWorld::kManhattan);
    Values values = sim.initial;
    SolverOptions o;
    o.linear_solver = linear;
    o.function_tolerance = o.gradient_tolerance = o.parameter_tolerance = 0;
    o.max_iterations = 6;
    std::vector<long> at;
    std::vector<char> reused;
    at.reserve(64);
    reused.reserve(64);
    o.callback = [&](const IterationSummary& it) {
      at.push_back(g_news.load());
      reused.push_back(it.reused_factorization ? 1 : 0);
    };
    const SolverSummary s = Optimize(sim.graph, &values, o);
    EXPECT_TRUE(s.IsSolutionUsable()) << s.message;
    int checked = 0;
    for (std::size_t i = 2; i < at.size(); ++i) {
      if (!reused[i]) continue;
      EXPECT_EQ(at[i] - at[i - 1], 0) << ToString(linear) << ": iteration " << i << " reused and allocated";
      ++checked;
    }
    EXPECT_GE(checked, 1) << ToString(linear) << ": no step after the first two reused a factorisation";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Solvers, HotLoopTest,
    ::testing::Values(Case{SimWorld::kManhattan, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod, 1},
                      Case{SimWorld::kManhattan, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod, 2},
                      Case{SimWorld::kSphere, Algorithm::kGaussNewton, LinearSolverType::kCholmod, 2},
                      Case{SimWorld::kLandmarks, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod, 2},
                      Case{SimWorld::kManhattan, Algorithm::kGaussNewton, LinearSolverType::kQR, 2},
                      Case{SimWorld::kManhattan, Algorithm::kDogLeg, LinearSolverType::kCholmod, 1},
                      Case{SimWorld::kSphere, Algorithm::kDogLeg, LinearSolverType::kQR, 2}),
    [](const ::testing::TestParamInfo<Case>& i) {
      return std::string(ToString(i.param.world)) + "_" + ToString(i.param.algorithm) + "_" + ToString(i.param.linear) +
             "_" + std::to_string(i.param.threads) + "t";
    });

// The Problem's own steps, called directly: not one allocation, on one thread or several.
TEST(HotLoopProblem, LineariseAssembleEvaluateRetractAllocateNothing) {
  const SimulatedGraph sim = Sim(SimWorld::kLandmarks);
  for (int threads : {1, 2, 3}) {
    Values values = sim.initial;
    internal::Problem p(sim.graph, &values, {0}, threads);
    internal::Csc h;
    std::vector<int> diag;
    p.BuildNormalStructure(&h, &diag);
    std::vector<double> g(p.tangent_dim()), delta(p.tangent_dim(), 1e-4);
    const long before = g_news.load();
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
      sum += p.Linearize();
      p.AssembleNormal(&h, g.data());
      p.Save();
      p.Retract(delta.data());
      sum += p.Chi2();
      p.Restore();
    }
    EXPECT_EQ(g_news.load() - before, 0) << threads << " threads";
    EXPECT_TRUE(std::isfinite(sum));
    EXPECT_TRUE(p.jacobian_finite());
  }
}

}  // namespace
}  // namespace tether
