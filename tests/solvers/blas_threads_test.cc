// The BLAS thread count: set for a scope and put back; the incremental smoother's updates run
// their BLAS kernels on one thread (the caller's) and leave the count as they found it.
#include "blas_threads.h"

#include <gtest/gtest.h>

#include "tether/core/autodiff_factor.h"
#include "tether/solvers/backends.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {
namespace {

using internal::ScopedBlasThreads;

// Pulls a point towards (1, 2) and records the BLAS thread count while it is evaluated.
class RecordingFactor : public AutoDiffFactor<RecordingFactor, 2, Eigen::Vector2d> {
 public:
  RecordingFactor(Key k, int* seen) : AutoDiffFactor({k}, SqrtInformation::Identity(2)), seen_(seen) {}
  static constexpr const char* kTypeName = "RecordingFactor";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    *seen_ = internal::BlasThreads();
    e[0] = p[0][0] - T(1);
    e[1] = p[0][1] - T(2);
    return true;
  }

 private:
  int* seen_;
};

// The BLAS comes with the solver back-ends, loaded at their first use; these tests use it
// directly, so they load them first.
class BlasThreads : public ::testing::Test {
 protected:
  void SetUp() override { LoadSolverBackends(); }
};

TEST_F(BlasThreads, AScopeSetsTheCountAndPutsItBack) {
  const int before = internal::BlasThreads();
  if (before == 0) GTEST_SKIP() << "the BLAS library in use has no thread count (reference BLAS)";
  {
    ScopedBlasThreads one(1);
    EXPECT_EQ(internal::BlasThreads(), 1);
    {
      ScopedBlasThreads two(2);
      EXPECT_EQ(internal::BlasThreads(), 2);
    }
    EXPECT_EQ(internal::BlasThreads(), 1);
  }
  EXPECT_EQ(internal::BlasThreads(), before);
}

TEST_F(BlasThreads, ACountBelowOneMeansOne) {
  if (internal::BlasThreads() == 0) GTEST_SKIP() << "the BLAS library in use has no thread count (reference BLAS)";
  ScopedBlasThreads none(0);
  EXPECT_EQ(internal::BlasThreads(), 1);
}

TEST_F(BlasThreads, ASmootherUpdateRunsOnOneBlasThreadAndPutsTheCountBack) {
  if (internal::BlasThreads() == 0) GTEST_SKIP() << "the BLAS library in use has no thread count (reference BLAS)";
  ScopedBlasThreads two(2);  // a threaded BLAS, whatever this machine's core count
  int seen = -1;
  FactorGraph f;
  f.Add(std::make_unique<RecordingFactor>(7, &seen));
  Values v;
  v.Insert(7, Eigen::Vector2d(0, 0));
  IncrementalSmoother smoother;
  const SmootherUpdate u = smoother.Update(std::move(f), std::move(v), {});
  ASSERT_TRUE(u.solved) << u.message;
  EXPECT_EQ(seen, 1);
  EXPECT_EQ(internal::BlasThreads(), 2);
  EXPECT_NEAR(smoother.Estimate().At<Eigen::Vector2d>(7).x(), 1.0, 1e-9);
}

}  // namespace
}  // namespace tether
