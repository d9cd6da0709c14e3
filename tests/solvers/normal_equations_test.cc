// NormalEquations: H and g against J^T J and J^T r formed densely from each factor's whitened
// Jacobians, the free variables (the graph's fixed set and the held keys left out), the same
// bits for any thread count, the refusals, and CHOLMOD (by name) solving the system it gives.
#include "tether/solvers/normal_equations.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>
#include <memory>
#include <vector>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

SqrtInformation Noise(int dim, double sigma) { return SqrtInformation::Isotropic(dim, sigma); }

// Five SE2 poses (odometry, two loop closures, a prior on the first), two Point2 landmarks;
// values off the optimum.
void SmallGraph(FactorGraph* g, Values* v) {
  for (int i = 0; i < 5; ++i) v->Insert(i, SE2d(1.0 * i + 0.05 * i * i, 0.1 * i, 0.2 * i - 0.1));
  v->Insert(10, Eigen::Vector2d(2.0, 1.5));
  v->Insert(11, Eigen::Vector2d(3.5, -1.0));
  v->Insert(12, Eigen::Vector2d(9.0, 9.0));  // no factor uses it
  for (int i = 0; i + 1 < 5; ++i) g->Add<BetweenSE2>(i, i + 1, SE2d(1.0, 0.05, 0.15), Noise(3, 0.1 + 0.02 * i));
  g->Add<BetweenSE2>(0, 3, SE2d(3.0, 0.2, 0.5), Noise(3, 0.3));
  g->Add<BetweenSE2>(1, 4, SE2d(2.9, 0.1, 0.4), Noise(3, 0.25));
  g->Add<PosePoint2>(1, 10, Eigen::Vector2d(1.0, 1.4), Noise(2, 0.05));
  g->Add<PosePoint2>(2, 10, Eigen::Vector2d(0.1, 1.5), Noise(2, 0.07));
  g->Add<PosePoint2>(3, 11, Eigen::Vector2d(0.4, -1.3), Noise(2, 0.05));
  g->Add<PriorSE2>(0, SE2d(0, 0, -0.1), Noise(3, 0.01));
}

// Dense J^T J and J^T r over the free keys (columns in the order given).
struct Dense {
  Eigen::MatrixXd h;
  Eigen::VectorXd g;
};

Dense DenseSystem(const FactorGraph& graph, const Values& values, const std::vector<Key>& free) {
  std::map<Key, int> offset;
  int n = 0;
  for (Key k : free) {
    offset[k] = n;
    n += TangentDim(values.TypeOf(k));
  }
  Dense d{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n)};
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  for (const auto& f : graph.factors()) {
    const std::vector<const double*> params = f->GatherParams(values);
    const std::vector<VarType> types = f->variable_types();
    const int m = f->dim();
    std::vector<std::vector<double>> jac(types.size());
    std::vector<double*> jp;
    for (std::size_t i = 0; i < types.size(); ++i) {
      jac[i].assign(static_cast<std::size_t>(m * TangentDim(types[i])), 0.0);
      jp.push_back(jac[i].data());
    }
    Eigen::VectorXd r(m);
    EXPECT_TRUE(f->Linearize(params.data(), r.data(), jp.data()));
    for (std::size_t a = 0; a < types.size(); ++a) {
      const auto ia = offset.find(f->keys()[a]);
      if (ia == offset.end()) continue;
      const Eigen::Map<const RowMajor> ja(jac[a].data(), m, TangentDim(types[a]));
      d.g.segment(ia->second, ja.cols()) += ja.transpose() * r;
      for (std::size_t b = 0; b < types.size(); ++b) {
        const auto ib = offset.find(f->keys()[b]);
        if (ib == offset.end()) continue;
        const Eigen::Map<const RowMajor> jb(jac[b].data(), m, TangentDim(types[b]));
        d.h.block(ia->second, ib->second, ja.cols(), jb.cols()) += ja.transpose() * jb;
      }
    }
  }
  return d;
}

// The symmetric matrix whose upper triangle the view holds (entries below the diagonal in it
// are ignored, as a linear solver ignores them).
Eigen::MatrixXd FromUpper(const SparseMatrixView& a) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(a.rows, a.cols);
  for (int c = 0; c < a.cols; ++c) {
    for (int p = a.colptr[c]; p < a.colptr[c + 1]; ++p) {
      const int r = a.rowind[p];
      if (r > c) continue;
      m(r, c) = a.values[p];
      m(c, r) = a.values[p];
    }
  }
  return m;
}

TEST(NormalEquationsTest, HAndGAreJTJAndJTrOverTheFreeVariables) {
  FactorGraph g;
  Values v;
  SmallGraph(&g, &v);
  g.Fix(2);
  NormalEquations ne(g, v, {11});
  // Key 2 is fixed in the graph, 11 held, 12 used by no factor: none has a column.
  EXPECT_EQ(ne.FreeKeys(), (std::vector<Key>{0, 1, 3, 4, 10}));
  EXPECT_EQ(ne.BlockSizes(), (std::vector<int>{3, 3, 3, 3, 2}));
  EXPECT_EQ(ne.size(), 14);
  const SparseMatrixView h = ne.H();
  EXPECT_EQ(h.rows, 14);
  EXPECT_EQ(h.cols, 14);

  EXPECT_DOUBLE_EQ(ne.Linearize(), g.Chi2(v));
  EXPECT_DOUBLE_EQ(ne.Chi2(), g.Chi2(v));
  ne.Assemble();
  const Dense d = DenseSystem(g, v, ne.FreeKeys());
  EXPECT_LE((FromUpper(ne.H()) - d.h).norm(), 1e-9 * d.h.norm());
  const Eigen::Map<const Eigen::VectorXd> grad(ne.g().data(), static_cast<Eigen::Index>(ne.g().size()));
  EXPECT_LE((grad - d.g).norm(), 1e-9 * d.g.norm());
}

TEST(NormalEquationsTest, TheValuesAreACopyAndBeforeLinearizeTheSystemIsZero) {
  FactorGraph g;
  Values v;
  SmallGraph(&g, &v);
  NormalEquations ne(g, v);
  v.Update(1, SE2d(50, 50, 1));  // the caller's values: not the system's
  EXPECT_DOUBLE_EQ(ne.values().At<SE2d>(1).x(), 1.05);
  ne.Assemble();
  const SparseMatrixView h = ne.H();
  for (int p = 0; p < h.colptr[h.cols]; ++p) EXPECT_EQ(h.values[p], 0.0);
  for (double x : ne.g()) EXPECT_EQ(x, 0.0);
}

TEST(NormalEquationsTest, EveryThreadCountGivesTheSameBits) {
  FactorGraph g;
  Values v;
  SmallGraph(&g, &v);
  NormalEquations one(g, v, {}, 1);
  const double chi2 = one.Linearize();
  one.Assemble();
  const SparseMatrixView a = one.H();
  for (int threads : {2, 3, 7}) {
    SCOPED_TRACE(threads);
    NormalEquations many(g, v, {}, threads);
    EXPECT_EQ(many.Linearize(), chi2);
    many.Assemble();
    const SparseMatrixView b = many.H();
    ASSERT_EQ(b.colptr[b.cols], a.colptr[a.cols]);
    EXPECT_TRUE(std::equal(a.colptr, a.colptr + a.cols + 1, b.colptr));
    EXPECT_TRUE(std::equal(a.rowind, a.rowind + a.colptr[a.cols], b.rowind));
    EXPECT_TRUE(std::equal(a.values, a.values + a.colptr[a.cols], b.values));
    EXPECT_EQ(many.g(), one.g());
  }
}

TEST(NormalEquationsTest, RefusesMissingKeysAndNoThreads) {
  FactorGraph g;
  Values v;
  SmallGraph(&g, &v);
  Values missing = v;
  missing.Erase(10);
  try {
    NormalEquations ne(g, missing);
    ADD_FAILURE() << "a graph with a missing key was taken";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("PosePoint2 factor refers to key"), std::string::npos) << e.what();
  }
  EXPECT_THROW(NormalEquations(g, v, {}, 0), InvalidArgument);
}

TEST(NormalEquationsTest, CholmodByNameSolvesTheSystem) {
  FactorGraph g;
  Values v;
  SmallGraph(&g, &v);
  NormalEquations ne(g, v);
  ne.Linearize();
  ne.Assemble();
  LinearSolverEntry entry;
  ASSERT_TRUE(DefaultLinearSolverRegistry().Get("cholmod", &entry));
  const std::unique_ptr<LinearSolver> solver = entry.make(LinearSolverOptions{});
  solver->Analyze(ne.H(), ne.BlockSizes());
  ASSERT_EQ(solver->Factorize(ne.H()), LinearSolverStatus::kOk);
  std::vector<double> minus_g(ne.g().size()), dx(ne.g().size());
  for (std::size_t i = 0; i < minus_g.size(); ++i) minus_g[i] = -ne.g()[i];
  ASSERT_EQ(solver->Solve(minus_g.data(), dx.data()), LinearSolverStatus::kOk);
  const Eigen::MatrixXd h = FromUpper(ne.H());
  const Eigen::VectorXd want = h.ldlt().solve(-Eigen::Map<const Eigen::VectorXd>(ne.g().data(), ne.size()));
  EXPECT_LE((Eigen::Map<const Eigen::VectorXd>(dx.data(), ne.size()) - want).norm(), 1e-9 * want.norm());
}

}  // namespace
}  // namespace tether
