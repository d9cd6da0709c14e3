// SolverOptions::num_threads: any number of threads gives bit-identical results, because
// every entry of H, g and chi2 is summed in the same order; bad values are refused; a factor
// that throws on a worker thread ends the solve like one on the calling thread.
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <stdexcept>

#include "testing/simulated.h"
#include "tether/factors/between_se2.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

SimulatedGraph Sim(SimWorld world, int poses) { return testing::SimulateWorld(world, poses, 7, 60); }

// Every parameter of every variable, bit for bit.
void ExpectBitIdentical(const Values& a, const Values& b) {
  ASSERT_EQ(a.size(), b.size());
  for (Key k : a.keys()) {
    const int n = AmbientDim(a.TypeOf(k));
    ASSERT_EQ(std::memcmp(a.Params(k), b.Params(k), sizeof(double) * n), 0) << "key " << KeyToString(k);
  }
}

struct Result {
  SolverSummary summary;
  Values values;
};

Result Solve(const SimulatedGraph& sim, SolverOptions options, int threads) {
  options.num_threads = threads;
  Result r{SolverSummary(), sim.initial};
  r.summary = Optimize(sim.graph, &r.values, options);
  return r;
}

class ThreadsTest : public ::testing::TestWithParam<SimWorld> {};

TEST_P(ThreadsTest, AnyNumberOfThreadsGivesTheSameBits) {
  const SimulatedGraph sim = Sim(GetParam(), 600);
  for (Algorithm a : {Algorithm::kLevenbergMarquardt, Algorithm::kGaussNewton}) {
    for (LinearSolverType l : {LinearSolverType::kCholmod, LinearSolverType::kQR}) {
      SolverOptions o;
      o.algorithm = a;
      o.linear_solver = l;
      const Result one = Solve(sim, o, 1);
      ASSERT_EQ(one.summary.status, SolverStatus::kConverged) << one.summary.message;
      ASSERT_GT(one.summary.iterations, 1);
      for (int threads : {2, 3, 8}) {
        SCOPED_TRACE(std::string(ToString(a)) + "/" + ToString(l) + " threads " + std::to_string(threads));
        const Result many = Solve(sim, o, threads);
        EXPECT_EQ(many.summary.status, one.summary.status);
        ASSERT_EQ(many.summary.log.size(), one.summary.log.size());
        for (std::size_t i = 0; i < one.summary.log.size(); ++i) {
          EXPECT_EQ(many.summary.log[i].chi2, one.summary.log[i].chi2) << "iteration " << i;
          EXPECT_EQ(many.summary.log[i].step_norm, one.summary.log[i].step_norm) << "iteration " << i;
        }
        EXPECT_EQ(many.summary.final_chi2, one.summary.final_chi2);
        ExpectBitIdentical(many.values, one.values);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Worlds, ThreadsTest,
                         ::testing::Values(SimWorld::kManhattan, SimWorld::kSphere, SimWorld::kLandmarks),
                         [](const ::testing::TestParamInfo<SimWorld>& i) { return std::string(ToString(i.param)); });

TEST(ThreadsOptions, DefaultIsOneAndBoundsAreChecked) {
  SolverOptions o;
  EXPECT_EQ(o.num_threads, 1);
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.num_threads = 256;
  EXPECT_TRUE(o.IsValid(&why));
  for (int bad : {0, -1, 257}) {
    o.num_threads = bad;
    why.clear();
    EXPECT_FALSE(o.IsValid(&why)) << bad;
    EXPECT_NE(why.find("num_threads"), std::string::npos) << why;
  }
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 50);
  Values v = sim.initial;
  o.num_threads = 0;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("num_threads"), std::string::npos) << s.message;
}

TEST(ThreadsOptions, MoreThreadsThanFactorsWork) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 3);
  Values v = sim.initial;
  SolverOptions o;
  o.num_threads = 16;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  EXPECT_TRUE(s.IsSolutionUsable()) << s.message;
  EXPECT_LE(s.final_chi2, s.initial_chi2);
}

// A BetweenSE2 that throws once the solve has evaluated it `fuse` times.
class ThrowingBetween : public BetweenSE2 {
 public:
  ThrowingBetween(const BetweenSE2& b, std::atomic<int>* calls, int fuse) : BetweenSE2(b), calls_(calls), fuse_(fuse) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    if (calls_->fetch_add(1) >= fuse_) throw std::runtime_error("sensor model exploded");
    return BetweenSE2::Evaluate(params, error, jacobians);
  }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<ThrowingBetween>(*this); }

 private:
  std::atomic<int>* calls_;
  int fuse_;
};

TEST(ThreadsFailure, AFactorThrowingOnAWorkerEndsTheSolveWithTheLastGoodValues) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 300);
  // The last factor falls in the last thread's part; let it throw in the second linearisation.
  FactorGraph graph;
  std::atomic<int> calls{0};
  for (std::size_t i = 0; i + 1 < sim.graph.size(); ++i) graph.Add(sim.graph.at(i).Clone());
  const auto* last = dynamic_cast<const BetweenSE2*>(&sim.graph.at(sim.graph.size() - 1));
  ASSERT_NE(last, nullptr);
  graph.Add(std::make_unique<ThrowingBetween>(*last, &calls, 2));
  Values v = sim.initial;
  SolverOptions o;
  o.num_threads = 2;
  const SolverSummary s = Optimize(graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kDiverged);
  EXPECT_NE(s.message.find("sensor model exploded"), std::string::npos) << s.message;
  for (Key k : v.keys()) {
    for (int i = 0; i < AmbientDim(v.TypeOf(k)); ++i) EXPECT_TRUE(std::isfinite(v.Params(k)[i]));
  }
}

}  // namespace
}  // namespace tether
