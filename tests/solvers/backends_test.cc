// The back-end module (libtether_backends.so: CHOLMOD, SuiteSparseQR, Ceres, BLAS, LAPACK),
// loaded at its first use: each way a file can fail to be that module is refused with the
// file and the reason, and the module itself hands over a table whose solvers work.
#include "backends.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tether/solvers/backends.h"

namespace tether {
namespace {

using internal::LoadBackendsFrom;

#ifdef TETHER_BACKENDS_MODULE

std::string TestModule(const std::string& name) { return std::string(TETHER_TEST_PLUGIN_DIR) + "/" + name; }

TEST(Backends, AFileThatDoesNotExistIsNamedWithTheLoadersReason) {
  std::string why;
  EXPECT_EQ(LoadBackendsFrom("/nonexistent/libtether_backends.so", &why), nullptr);
  EXPECT_NE(why.find("/nonexistent/libtether_backends.so could not be loaded ("), std::string::npos) << why;
  EXPECT_NE(why.find("No such file"), std::string::npos) << why;
}

TEST(Backends, AFileThatIsNotALibraryIsRefused) {
  std::string why;
  EXPECT_EQ(LoadBackendsFrom(TestModule("test_not_a_library.so"), &why), nullptr);
  EXPECT_NE(why.find("test_not_a_library.so could not be loaded"), std::string::npos) << why;
}

TEST(Backends, ALibraryWithoutTheEntryPointIsRefused) {
  std::string why;
  EXPECT_EQ(LoadBackendsFrom(TestModule("test_good.so"), &why), nullptr);
  EXPECT_NE(why.find("test_good.so has no entry point tether_backends_v1"), std::string::npos) << why;
}

TEST(Backends, AModuleFromAnotherBuildIsRefused) {
  std::string why;
  EXPECT_EQ(LoadBackendsFrom(TestModule("test_backends_wrong_version.so"), &why), nullptr);
  EXPECT_NE(why.find("its table is version " + std::to_string(internal::kBackendTableVersion + 1)), std::string::npos)
      << why;
  EXPECT_NE(why.find("different builds"), std::string::npos) << why;
}

TEST(Backends, AModuleWhoseTableMissesAFunctionIsRefused) {
  std::string why;
  EXPECT_EQ(LoadBackendsFrom(TestModule("test_backends_missing_function.so"), &why), nullptr);
  EXPECT_NE(why.find("its table misses a function"), std::string::npos) << why;
}

TEST(Backends, TheModuleSolvesWithCholmodAndTheBlas) {
  std::string why;
  const internal::BackendTable* t = LoadBackendsFrom(TETHER_BACKENDS_MODULE, &why);
  ASSERT_NE(t, nullptr) << why;
  EXPECT_EQ(t->version, internal::kBackendTableVersion);
  // H = [4 1; 1 3] (upper triangle, CSC), b = (1, 2): x = (1/11, 7/11).
  const std::vector<int> colptr = {0, 1, 3}, rowind = {0, 0, 1};
  const std::vector<double> values = {4, 1, 3};
  const SparseMatrixView h{2, 2, colptr.data(), rowind.data(), values.data()};
  std::unique_ptr<LinearSolver> s = t->make_cholmod({});
  ASSERT_NE(s, nullptr);
  s->Analyze(h, {2});
  ASSERT_EQ(s->Factorize(h), LinearSolverStatus::kOk);
  double x[2] = {0, 0};
  const double b[2] = {1, 2};
  ASSERT_EQ(s->Solve(b, x), LinearSolverStatus::kOk);
  EXPECT_NEAR(x[0], 1.0 / 11, 1e-12);
  EXPECT_NEAR(x[1], 7.0 / 11, 1e-12);
  // The LAPACK Cholesky through the table: [4 2; 2 5] = L L^T with L = [2 0; 1 2].
  double a[4] = {4, 2, 2, 5};
  const int n = 2;
  int info = -1;
  t->dpotrf("L", &n, a, &n, &info);
  EXPECT_EQ(info, 0);
  EXPECT_DOUBLE_EQ(a[0], 2);
  EXPECT_DOUBLE_EQ(a[1], 1);
  EXPECT_DOUBLE_EQ(a[3], 2);
}

#endif

TEST(Backends, LoadingIsIdempotentAndReported) {
  LoadSolverBackends();
  EXPECT_TRUE(SolverBackendsLoaded());
  const internal::BackendTable* first = &internal::Backends();
  LoadSolverBackends();
  EXPECT_EQ(&internal::Backends(), first);
}

}  // namespace
}  // namespace tether
