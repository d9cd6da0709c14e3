// The block Cholesky (solvers/src/block_cholesky.h) against a dense factorisation of the same
// matrix: blocks of one size (the fixed-size kernels 1, 2, 3 and 6, and the general one) and of
// several sizes, graphs in one piece or several, refactorisation with new values, a matrix
// that is not positive definite, the lower triangle of the diagonal blocks ignored, the
// ordering keeping a star free of fill; and the "auto" solver's choice between it and CHOLMOD.
#include "block_cholesky.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "builtin_linear_solvers.h"
#include "tether/core/error.h"

namespace tether {
namespace internal {
namespace {

// A symmetric positive definite matrix with the block pattern of a pose graph: a chain (a path
// through the blocks in a shuffled order) and `loops` more links, each a random J^T J term.
struct BlockProblem {
  std::vector<int> sizes;
  Eigen::MatrixXd dense;
  Csc upper;  // the upper triangle, diagonal blocks whole (their lower part holds garbage)
};

// The pattern depends on the seed and the block count only (not on the sizes): the values come
// from a generator of their own.
BlockProblem MakeProblem(const std::vector<int>& sizes, int loops, unsigned seed, int pieces = 1) {
  std::mt19937 rng(seed), values(seed + 1000);
  std::normal_distribution<double> g(0.0, 1.0);
  const int nb = static_cast<int>(sizes.size());
  std::vector<int> off(nb + 1, 0);
  for (int b = 0; b < nb; ++b) off[b + 1] = off[b] + sizes[b];
  const int n = off[nb];
  BlockProblem p;
  p.sizes = sizes;
  p.dense = Eigen::MatrixXd::Zero(n, n);
  std::vector<std::vector<bool>> linked(nb, std::vector<bool>(nb, false));
  const auto link = [&](int a, int b) {
    // A factor of da + db residuals on blocks a and b: J^T J added to their four blocks.
    const int da = sizes[a], db = sizes[b];
    Eigen::MatrixXd J(da + db, da + db);
    for (int r = 0; r < da + db; ++r) {
      for (int c = 0; c < da + db; ++c) J(r, c) = g(values);
    }
    const Eigen::MatrixXd h = J.transpose() * J;
    p.dense.block(off[a], off[a], da, da) += h.topLeftCorner(da, da);
    p.dense.block(off[b], off[b], db, db) += h.bottomRightCorner(db, db);
    p.dense.block(off[a], off[b], da, db) += h.topRightCorner(da, db);
    p.dense.block(off[b], off[a], db, da) += h.bottomLeftCorner(db, da);
    linked[a][b] = linked[b][a] = true;
  };
  std::vector<int> order(nb);
  for (int i = 0; i < nb; ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  const int per_piece = (nb + pieces - 1) / pieces;
  for (int i = 1; i < nb; ++i) {
    if (i % per_piece != 0) link(order[i - 1], order[i]);
  }
  std::uniform_int_distribution<int> pick(0, nb - 1);
  for (int l = 0; l < loops; ++l) {
    const int a = pick(rng), b = pick(rng);
    if (a != b && a / per_piece == b / per_piece) link(a, b);
  }
  for (int b = 0; b < nb; ++b) {  // each block a prior: positive definite in every piece
    p.dense.block(off[b], off[b], sizes[b], sizes[b]) += 0.5 * Eigen::MatrixXd::Identity(sizes[b], sizes[b]);
  }
  p.upper.rows = p.upper.cols = n;
  p.upper.colptr.assign(1, 0);
  for (int B = 0; B < nb; ++B) {
    for (int c = off[B]; c < off[B + 1]; ++c) {
      for (int A = 0; A <= B; ++A) {
        if (A != B && !linked[A][B]) continue;
        const int rows = A == B ? off[B + 1] : off[A + 1];
        for (int r = off[A]; r < rows; ++r) {
          p.upper.rowind.push_back(r);
          // Below the diagonal in a diagonal block: garbage the solver must ignore.
          p.upper.values.push_back(r > c ? 1e6 : p.dense(r, c));
        }
      }
      p.upper.colptr.push_back(static_cast<int>(p.upper.rowind.size()));
    }
  }
  return p;
}

Eigen::VectorXd RandomVector(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = g(rng);
  return v;
}

// Factorises, solves and compares with the dense solution.
void ExpectSolves(BlockCholesky* chol, const BlockProblem& p, unsigned seed) {
  ASSERT_TRUE(chol->Factorize(View(p.upper)));
  const Eigen::VectorXd b = RandomVector(p.upper.cols, seed);
  Eigen::VectorXd x(p.upper.cols);
  chol->Solve(b.data(), x.data());
  const Eigen::VectorXd expected = p.dense.llt().solve(b);
  EXPECT_LT((x - expected).norm(), 1e-9 * expected.norm()) << "n " << p.upper.cols;
  // In place too.
  Eigen::VectorXd y = b;
  chol->Solve(y.data(), y.data());
  EXPECT_LT((y - expected).norm(), 1e-9 * expected.norm());
}

struct SizesCase {
  const char* name;
  std::vector<int> sizes;
  int loops;
  int pieces;
};

class BlockCholeskySizes : public ::testing::TestWithParam<SizesCase> {};

TEST_P(BlockCholeskySizes, SolvesLikeTheDenseFactorisation) {
  const SizesCase& c = GetParam();
  const BlockProblem p = MakeProblem(c.sizes, c.loops, 11, c.pieces);
  BlockCholesky chol;
  chol.Analyze(View(p.upper), p.sizes);
  EXPECT_EQ(chol.num_blocks(), static_cast<int>(c.sizes.size()));
  const bool uniform = std::all_of(c.sizes.begin(), c.sizes.end(), [&](int s) { return s == c.sizes[0]; });
  EXPECT_EQ(chol.uniform_size(), uniform ? c.sizes[0] : 0);
  ExpectSolves(&chol, p, 3);
  // The same pattern with other values: the analysis is reused.
  BlockProblem q = MakeProblem(c.sizes, c.loops, 11, c.pieces);
  q.dense *= 2.5;
  for (double& v : q.upper.values) v *= 2.5;
  q.dense += Eigen::MatrixXd::Identity(q.dense.rows(), q.dense.cols());
  for (int col = 0; col < q.upper.cols; ++col) {
    for (int k = q.upper.colptr[col]; k < q.upper.colptr[col + 1]; ++k) {
      if (q.upper.rowind[k] == col) q.upper.values[k] += 1;
    }
  }
  ExpectSolves(&chol, q, 4);
}

std::vector<int> Repeat(int size, int count) { return std::vector<int>(count, size); }

std::vector<int> Mixed(int count) {
  std::vector<int> s;
  for (int i = 0; i < count; ++i) s.push_back(i % 3 == 0 ? 6 : i % 3 == 1 ? 2 : 3);
  return s;
}

INSTANTIATE_TEST_SUITE_P(
    All, BlockCholeskySizes,
    ::testing::Values(SizesCase{"SE2", Repeat(3, 60), 25, 1}, SizesCase{"SE3", Repeat(6, 40), 20, 1},
                      SizesCase{"Point2", Repeat(2, 50), 30, 1}, SizesCase{"Scalar", Repeat(1, 80), 60, 1},
                      SizesCase{"FourWide", Repeat(4, 30), 15, 1}, SizesCase{"Mixed", Mixed(45), 25, 1},
                      SizesCase{"ThreePieces", Repeat(3, 60), 40, 3}, SizesCase{"OneBlock", Repeat(3, 1), 0, 1},
                      SizesCase{"Dense", Repeat(3, 12), 200, 1}),
    [](const ::testing::TestParamInfo<SizesCase>& i) { return std::string(i.param.name); });

// The interface promises sorted rows; a column whose rows come in another order is still read
// right.
TEST(BlockCholesky, RowsOutOfOrderWithinAColumnAreStillPlaced) {
  BlockProblem p = MakeProblem(Repeat(3, 30), 20, 12);
  std::mt19937 rng(3);
  for (int c = 0; c < p.upper.cols; ++c) {
    std::vector<std::pair<int, double>> entries;
    for (int k = p.upper.colptr[c]; k < p.upper.colptr[c + 1]; ++k)
      entries.emplace_back(p.upper.rowind[k], p.upper.values[k]);
    std::shuffle(entries.begin(), entries.end(), rng);
    for (int k = p.upper.colptr[c], e = 0; k < p.upper.colptr[c + 1]; ++k, ++e) {
      p.upper.rowind[k] = entries[e].first;
      p.upper.values[k] = entries[e].second;
    }
  }
  BlockCholesky chol;
  chol.Analyze(View(p.upper), p.sizes);
  ExpectSolves(&chol, p, 13);
}

// An analysis without the numeric storage (what "auto" does before it chooses) gives the same
// figures, and the first factorisation allocates what it needs.
TEST(BlockCholesky, TheStorageCanComeAfterTheAnalysis) {
  const BlockProblem p = MakeProblem(Repeat(3, 40), 30, 21);
  BlockCholesky full, lazy;
  full.Analyze(View(p.upper), p.sizes);
  lazy.Analyze(View(p.upper), p.sizes, /*allocate=*/false);
  EXPECT_EQ(lazy.off_diagonal_blocks(), full.off_diagonal_blocks());
  EXPECT_DOUBLE_EQ(lazy.UpdatesPerBlock(), full.UpdatesPerBlock());
  ExpectSolves(&lazy, p, 22);
}

// The analysis stops as soon as the caller's rule says no: blocks of several sizes where one
// size is required, a factor denser than the limit; the figures it got to are kept and a
// factorisation is refused.
TEST(BlockCholesky, TheAnalysisStopsWhereTheRuleSaysNo) {
  const BlockProblem mixed = MakeProblem(Mixed(30), 10, 31);
  BlockCholesky chol;
  EXPECT_FALSE(chol.Analyze(View(mixed.upper), mixed.sizes, true, 1e9, /*require_uniform=*/true));
  EXPECT_EQ(chol.uniform_size(), 0);
  EXPECT_TRUE(chol.ScalarOrdering().empty());
  EXPECT_THROW(chol.Factorize(View(mixed.upper)), Error);
  const BlockProblem p = MakeProblem(Repeat(3, 60), 400, 32);
  ASSERT_TRUE(chol.Analyze(View(p.upper), p.sizes));
  const double updates = chol.UpdatesPerBlock();
  EXPECT_FALSE(chol.Analyze(View(p.upper), p.sizes, true, updates - 0.5));
  EXPECT_DOUBLE_EQ(chol.UpdatesPerBlock(), updates);
  // The ordering was found before the stop ("auto" hands it to CHOLMOD): a permutation of the
  // scalar columns that keeps each block's columns together and in order.
  std::vector<int> order = chol.ScalarOrdering();
  ASSERT_EQ(order.size(), static_cast<std::size_t>(p.upper.cols));
  for (std::size_t k = 0; k < order.size(); k += 3) {
    EXPECT_EQ(order[k] % 3, 0);
    EXPECT_EQ(order[k + 1], order[k] + 1);
    EXPECT_EQ(order[k + 2], order[k] + 2);
  }
  std::sort(order.begin(), order.end());
  for (int k = 0; k < p.upper.cols; ++k) EXPECT_EQ(order[k], k);
  EXPECT_THROW(chol.Factorize(View(p.upper)), Error);
  EXPECT_TRUE(chol.Analyze(View(p.upper), p.sizes, true, updates + 0.5));
  ExpectSolves(&chol, p, 33);
}

// The chordal start and the solve after it analyse one pose graph with blocks of different
// sizes: the second analysis finds the first's ordering and factor pattern (whatever the sizes),
// and both solve. An analysis that stopped after counting is completed by the next one.
TEST(BlockCholesky, OnePatternIsAnalysedOnceWhateverTheBlockSizes) {
  const BlockProblem rotations = MakeProblem(Repeat(2, 80), 40, 41);
  const BlockProblem poses = MakeProblem(Repeat(3, 80), 40, 41);
  BlockCholesky a, b;
  ASSERT_TRUE(a.Analyze(View(rotations.upper), rotations.sizes));
  EXPECT_FALSE(a.reused_analysis());
  ASSERT_TRUE(b.Analyze(View(poses.upper), poses.sizes));
  EXPECT_TRUE(b.reused_analysis());
  EXPECT_EQ(a.off_diagonal_blocks(), b.off_diagonal_blocks());
  const std::vector<int> oa = a.ScalarOrdering(), ob = b.ScalarOrdering();
  for (int k = 0; k < 80; ++k) EXPECT_EQ(oa[2 * k] / 2, ob[3 * k] / 3) << "block " << k;
  ExpectSolves(&a, rotations, 1);
  ExpectSolves(&b, poses, 2);
  // Another pattern: not reused.
  const BlockProblem other = MakeProblem(Repeat(3, 80), 40, 42);
  BlockCholesky c;
  const double updates = (c.Analyze(View(other.upper), other.sizes), c.UpdatesPerBlock());
  EXPECT_FALSE(c.reused_analysis());
  // Stopped after counting, then completed from the counts.
  const BlockProblem third = MakeProblem(Repeat(3, 80), 40, 43);
  EXPECT_FALSE(c.Analyze(View(third.upper), third.sizes, true, 0.5));
  EXPECT_FALSE(c.reused_analysis());
  ASSERT_TRUE(c.Analyze(View(third.upper), third.sizes));
  EXPECT_TRUE(c.reused_analysis());
  ExpectSolves(&c, third, 3);
  EXPECT_GT(updates, 0);
}

// A matrix with no columns factorises and solves (to nothing).
TEST(BlockCholesky, AnEmptyMatrixIsFine) {
  Csc empty;
  empty.colptr.assign(1, 0);
  BlockCholesky chol;
  EXPECT_TRUE(chol.Analyze(View(empty), {}));
  EXPECT_TRUE(chol.Factorize(View(empty)));
  chol.Solve(nullptr, nullptr);
  EXPECT_EQ(chol.num_blocks(), 0);
}

TEST(BlockCholesky, EmptyBlockSizesMeanScalars) {
  const BlockProblem p = MakeProblem(Repeat(1, 30), 20, 5);
  BlockCholesky chol;
  chol.Analyze(View(p.upper), {});
  EXPECT_EQ(chol.num_blocks(), 30);
  ExpectSolves(&chol, p, 6);
}

// A pivot that is not positive definite fails the factorisation; a later good matrix of the
// same pattern factorises and solves correctly (nothing of the failed attempt is left behind).
TEST(BlockCholesky, NotPositiveDefiniteIsReportedAndRecoveredFrom) {
  const BlockProblem good = MakeProblem(Repeat(3, 40), 20, 8);
  BlockProblem bad = good;
  for (int col = 0; col < bad.upper.cols; ++col) {
    for (int k = bad.upper.colptr[col]; k < bad.upper.colptr[col + 1]; ++k) {
      if (bad.upper.rowind[k] == col && col >= 60 && col < 63) bad.upper.values[k] = -5;
    }
  }
  BlockCholesky chol;
  chol.Analyze(View(good.upper), good.sizes);
  EXPECT_FALSE(chol.Factorize(View(bad.upper)));
  std::vector<double> ones(good.upper.cols, 1.0), out(good.upper.cols);
  EXPECT_THROW(chol.Solve(ones.data(), out.data()), Error);
  ExpectSolves(&chol, good, 9);
  // A NaN is not positive definite either.
  BlockProblem nan = good;
  nan.upper.values[0] = std::nan("");
  EXPECT_FALSE(chol.Factorize(View(nan.upper)));
}

TEST(BlockCholesky, SizesThatDoNotPartitionTheColumnsAreRefused) {
  const BlockProblem p = MakeProblem(Repeat(3, 5), 2, 1);
  BlockCholesky chol;
  EXPECT_THROW(chol.Analyze(View(p.upper), {3, 3, 3, 3}), InvalidArgument);
  EXPECT_THROW(chol.Analyze(View(p.upper), {3, 3, 3, 3, 0, 3}), InvalidArgument);
  SparseMatrixView rect = View(p.upper);
  rect.rows += 1;
  EXPECT_THROW(chol.Analyze(rect, p.sizes), InvalidArgument);
}

// A star (one block linked to every other) factorises with no fill once the hub is ordered
// last; in the given order, hub first, every pair of the others would fill in.
TEST(BlockCholesky, TheOrderingKeepsAStarFreeOfFill) {
  const int nb = 50;
  std::vector<int> sizes(nb, 3);
  Csc upper;
  upper.rows = upper.cols = 3 * nb;
  upper.colptr.assign(1, 0);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * nb, 3 * nb);
  for (int B = 0; B < nb; ++B) {
    dense.block(3 * B, 3 * B, 3, 3) = (B == 0 ? 4.0 * nb : 4.0) * Eigen::Matrix3d::Identity();
    if (B > 0) dense.block(0, 3 * B, 3, 3) = dense.block(3 * B, 0, 3, 3) = -Eigen::Matrix3d::Identity();
  }
  for (int c = 0; c < 3 * nb; ++c) {
    const int B = c / 3;
    for (int r = 0; r < 3 * (B + 1); ++r) {
      if (B > 0 && r >= 3 && r < 3 * B) continue;
      upper.rowind.push_back(r);
      upper.values.push_back(dense(r, c));
    }
    upper.colptr.push_back(static_cast<int>(upper.rowind.size()));
  }
  BlockCholesky chol;
  chol.Analyze(View(upper), sizes);
  EXPECT_EQ(chol.off_diagonal_blocks(), nb - 1);
  ASSERT_TRUE(chol.Factorize(View(upper)));
  const Eigen::VectorXd b = RandomVector(3 * nb, 2);
  Eigen::VectorXd x(3 * nb);
  chol.Solve(b.data(), x.data());
  EXPECT_LT((dense * x - b).norm(), 1e-10 * b.norm());
}

// "auto" takes the block Cholesky on sparse factors of one block size and CHOLMOD on blocks of
// several sizes or a dense factor, and solves alike either way.
TEST(AutoCholesky, ChoosesByTheFactorsDensityAndTheBlockSizes) {
  const LinearSolverEntry* entry = LinearSolvers().Find("auto");
  ASSERT_NE(entry, nullptr);
  EXPECT_TRUE(entry->direct);
  struct Case {
    BlockProblem p;
    const char* expected;
  };
  const Case cases[] = {{MakeProblem(Repeat(3, 200), 40, 1), "block Cholesky"},
                        {MakeProblem(Mixed(60), 20, 2), "CHOLMOD"},
                        {MakeProblem(Repeat(6, 150), 6000, 3), "CHOLMOD"}};
  for (const Case& c : cases) {
    std::unique_ptr<LinearSolver> s = entry->make(LinearSolverOptions());
    s->Analyze(View(c.p.upper), c.p.sizes);
    const std::string d = s->Description();
    EXPECT_EQ(d.rfind(c.expected, 0), 0u) << d;
    ASSERT_EQ(s->Factorize(View(c.p.upper)), LinearSolverStatus::kOk);
    const Eigen::VectorXd b = RandomVector(c.p.upper.cols, 4);
    Eigen::VectorXd x(c.p.upper.cols);
    ASSERT_EQ(s->Solve(b.data(), x.data()), LinearSolverStatus::kOk);
    const Eigen::VectorXd expected = c.p.dense.llt().solve(b);
    EXPECT_LT((x - expected).norm(), 1e-9 * expected.norm()) << d;
  }
  // Dense: the analysis says so, with the figure the rule compares.
  BlockCholesky chol;
  chol.Analyze(View(cases[2].p.upper), cases[2].p.sizes);
  EXPECT_GT(chol.UpdatesPerBlock(), kMaxBlockUpdatesPerBlock);
  chol.Analyze(View(cases[0].p.upper), cases[0].p.sizes);
  EXPECT_LT(chol.UpdatesPerBlock(), kMaxBlockUpdatesPerBlock);
}

}  // namespace
}  // namespace internal
}  // namespace tether

namespace tether {
namespace internal {
namespace {

// The operation counts on a path of blocks of 3 (no fill): every column but the last has one
// block below the diagonal; the factorisation takes 2 products per such block and an inversion
// per diagonal block, the solve one product per block each way.
TEST(BlockCholesky, TheOperationCountsOfAPath) {
  const int nb = 50;
  const BlockProblem p = MakeProblem(Repeat(3, nb), 0, 51);
  BlockCholesky chol;
  EXPECT_EQ(chol.FactorizeFlops(), 0);  // not analysed
  ASSERT_TRUE(chol.Analyze(View(p.upper), p.sizes));
  ASSERT_EQ(chol.off_diagonal_blocks(), nb - 1);
  EXPECT_DOUBLE_EQ(chol.FactorizeFlops(), 2 * 27.0 * 2 * (nb - 1) + 27.0 * nb);
  EXPECT_DOUBLE_EQ(chol.SolveFlops(), 4 * 9.0 * (nb + nb - 1));
  // A denser pattern costs more per solve, and more still per factorisation.
  const BlockProblem dense = MakeProblem(Repeat(3, nb), 300, 52);
  BlockCholesky d;
  ASSERT_TRUE(d.Analyze(View(dense.upper), dense.sizes));
  EXPECT_GT(d.FactorizeFlops() / d.SolveFlops(), chol.FactorizeFlops() / chol.SolveFlops());
  // "auto" reports the block solver's counts where it picks it.
  std::unique_ptr<LinearSolver> a = MakeAutoCholesky();
  a->Analyze(View(p.upper), p.sizes);
  EXPECT_DOUBLE_EQ(a->factorize_flops(), chol.FactorizeFlops());
  EXPECT_DOUBLE_EQ(a->solve_flops(), chol.SolveFlops());
}

}  // namespace
}  // namespace internal
}  // namespace tether
