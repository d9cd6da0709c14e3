// The incremental smoother's linear algebra (solvers/src/incremental_cholesky.h) against a
// dense solve of the same normal equations: after every change (factors added, removed and
// re-linearised, variables added, removed and made constant), the step of every variable must
// be the dense Gauss-Newton step H^-1 (-J^T r), to 1e-9 relative.
//
// Block widths 1, 2, 3, 4 and 6 so that every kernel runs: the fixed-size ones (3 and 6 wide,
// 2 x 3 and 3 x 2) and the generic one (1 and 4 wide, and mixes such as 4 x 6).
#include "incremental_cholesky.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace tether {
namespace internal {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The engine beside a plain copy of every live factor, from which the dense system is built.
class Harness {
 public:
  explicit Harness(unsigned seed, IncrementalCholesky::Method method = IncrementalCholesky::Method::kMultifrontal)
      : rng_(seed) {
    engine_.SetMethod(method);
  }

  int AddVariable(int dim) {
    const int v = engine_.AddVariable(dim);
    dims_[v] = dim;
    return v;
  }

  // A factor over `vars` with random Jacobians and residual; `rows` 0: the sum of their sizes.
  int AddFactor(const std::vector<int>& vars, int rows = 0) {
    if (rows == 0) {
      for (int v : vars) rows += dims_.at(v);
    }
    const int f = engine_.AddFactor(vars, rows);
    factors_[f] = {vars, rows, {}, {}};
    Relinearize(f);
    return f;
  }

  // New random numbers for the factor's Jacobians and residual (a re-linearisation).
  void Relinearize(int f) {
    Copy& c = factors_.at(f);
    c.J.clear();
    for (std::size_t k = 0; k < c.vars.size(); ++k) {
      RowMajor J = RowMajor::NullaryExpr(c.rows, dims_.at(c.vars[k]), [&] { return normal_(rng_); });
      std::copy(J.data(), J.data() + J.size(), engine_.JacobianBlock(f, static_cast<int>(k)));
      c.J.push_back(J);
    }
    c.r = Eigen::VectorXd::NullaryExpr(c.rows, [&] { return normal_(rng_); });
    std::copy(c.r.data(), c.r.data() + c.rows, engine_.Residual(f));
    engine_.Touch(f);
  }

  void RemoveFactor(int f) {
    engine_.RemoveFactor(f);
    factors_.erase(f);
  }
  void RemoveVariable(int v) {
    engine_.RemoveVariable(v);
    dims_.erase(v);
    constant_.erase(v);
  }
  void SetConstant(int v, bool constant) {
    engine_.SetConstant(v, constant);
    if (constant) {
      constant_.insert({v, true});
    } else {
      constant_.erase(v);
    }
  }

  // Solves incrementally (exactly: wildfire 0) and compares every step with the dense one.
  // Also checks that every variable whose step changed is reported as changed.
  void SolveAndCompare(const std::string& where) {
    std::map<int, Eigen::VectorXd> before;
    for (const auto& [v, dim] : dims_) before[v] = engine_.delta(v);
    std::vector<int> changed;
    std::string why;
    ASSERT_TRUE(engine_.Solve(0.0, &changed, &why)) << where << ": " << why;
    const std::map<int, Eigen::VectorXd> dense = DenseSteps();
    double scale = 1;
    for (const auto& [v, d] : dense) scale = std::max(scale, d.lpNorm<Eigen::Infinity>());
    for (const auto& [v, dim] : dims_) {
      const Eigen::VectorXd& got = engine_.delta(v);
      auto it = dense.find(v);
      const Eigen::VectorXd want = it == dense.end() ? Eigen::VectorXd::Zero(dim) : it->second;
      EXPECT_LE((got - want).lpNorm<Eigen::Infinity>(), 1e-9 * scale)
          << where << ", variable " << v << ": incremental " << got.transpose() << ", dense " << want.transpose();
      if (it != dense.end()) {
        // scale(): sqrt of the diagonal of the variable's block of H from its own factors.
        const Eigen::VectorXd want_scale = OwnDiagonal(v).cwiseSqrt();
        EXPECT_LE((engine_.scale(v) - want_scale).lpNorm<Eigen::Infinity>(), 1e-12 * (1 + want_scale.maxCoeff()))
            << where << ", variable " << v;
      }
      if (before.count(v) && before[v].size() == got.size() && (before[v] - got).lpNorm<Eigen::Infinity>() > 0) {
        EXPECT_NE(std::find(changed.begin(), changed.end(), v), changed.end())
            << where << ": the step of variable " << v << " changed but was not reported";
      }
    }
  }

  IncrementalCholesky& engine() { return engine_; }
  const std::map<int, int>& dims() const { return dims_; }
  std::vector<int> factor_ids() const {
    std::vector<int> ids;
    for (const auto& [f, c] : factors_) ids.push_back(f);
    return ids;
  }
  const std::vector<int>& vars_of(int f) const { return factors_.at(f).vars; }
  std::mt19937& rng() { return rng_; }

 private:
  struct Copy {
    std::vector<int> vars;
    int rows = 0;
    std::vector<RowMajor> J;
    Eigen::VectorXd r;
  };

  // The diagonal of H's block of v (J_v^T J_v summed over v's factors).
  Eigen::VectorXd OwnDiagonal(int v) const {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(dims_.at(v));
    for (const auto& [f, c] : factors_) {
      for (std::size_t k = 0; k < c.vars.size(); ++k) {
        if (c.vars[k] == v) d += c.J[k].colwise().squaredNorm().transpose();
      }
    }
    return d;
  }

  // H delta = -J^T r over the variables that have a factor and are not constant.
  std::map<int, Eigen::VectorXd> DenseSteps() const {
    std::map<int, int> offset;
    int n = 0;
    for (const auto& [f, c] : factors_) {
      for (int v : c.vars) {
        if (!constant_.count(v) && !offset.count(v)) offset[v] = 0;
      }
    }
    for (auto& [v, o] : offset) {
      o = n;
      n += dims_.at(v);
    }
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
    for (const auto& [f, c] : factors_) {
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(c.rows, n);
      for (std::size_t k = 0; k < c.vars.size(); ++k) {
        auto it = offset.find(c.vars[k]);
        if (it != offset.end()) J.middleCols(it->second, c.J[k].cols()) = c.J[k];
      }
      H += J.transpose() * J;
      g -= J.transpose() * c.r;
    }
    const Eigen::VectorXd x = H.llt().solve(g);
    std::map<int, Eigen::VectorXd> steps;
    for (const auto& [v, o] : offset) steps[v] = x.segment(o, dims_.at(v));
    return steps;
  }

  IncrementalCholesky engine_;
  std::map<int, int> dims_;
  std::map<int, Copy> factors_;
  std::map<int, bool> constant_;
  std::mt19937 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

constexpr int kWidths[] = {1, 2, 3, 4, 6};

void RandomChanges(unsigned seed, IncrementalCholesky::Method method);

constexpr IncrementalCholesky::Method kMethods[] = {IncrementalCholesky::Method::kLeftLooking,
                                                    IncrementalCholesky::Method::kMultifrontal};

TEST(IncrementalCholesky, EqualsTheDenseSolveThroughRandomChanges) {
  for (const auto method : kMethods) {
    for (unsigned seed = 1; seed <= 6; ++seed) {
      RandomChanges(seed, method);
    }
  }
}

TEST(IncrementalCholesky, AutoChoosesByTheVariablesWidth) {
  for (const int width : {3, 6}) {
    Harness h(3, IncrementalCholesky::Method::kAuto);
    int previous = -1;
    for (int i = 0; i < 10; ++i) {
      const int v = h.AddVariable(width);
      h.AddFactor({v});
      if (previous >= 0) h.AddFactor({previous, v});
      previous = v;
    }
    h.SolveAndCompare("width " + std::to_string(width));
    EXPECT_EQ(h.engine().multifrontal(), width == 6) << "width " << width;
  }
}

void RandomChanges(unsigned seed, IncrementalCholesky::Method method) {
  {
    Harness h(seed, method);
    std::uniform_int_distribution<int> width(0, 4), coin(0, 99);
    // Even seeds: pose graphs of one width (3: SE2, 6: SE3) with between factors of that many
    // rows, the shapes of the fixed-size kernels; odd seeds: every width mixed.
    const int pose_width = seed % 4 == 0 ? 6 : 3;
    auto new_width = [&] { return seed % 2 == 0 ? pose_width : kWidths[width(h.rng())]; };
    std::vector<int> vars;
    std::map<int, int> prior_of;  // variable -> its prior
    std::map<int, bool> kept;     // factors the random removals leave alone (odometry)
    auto add_pose = [&] {
      const int v = h.AddVariable(new_width());
      prior_of[v] = h.AddFactor({v});
      if (!vars.empty()) kept[h.AddFactor({vars.back(), v})] = true;
      h.engine().MarkRecent(v);
      vars.push_back(v);
    };
    // A chain, each variable with a prior of full rank (so H stays positive definite).
    for (int i = 0; i < 12; ++i) add_pose();
    const std::string method_name =
        method == IncrementalCholesky::Method::kLeftLooking ? "left-looking" : "multifrontal";
    h.SolveAndCompare(method_name + ", seed " + std::to_string(seed) + ", the first solve");
    int constant = -1;
    for (int step = 0; step < 80; ++step) {
      const std::string where = method_name + ", seed " + std::to_string(seed) + ", step " + std::to_string(step);
      const int what = coin(h.rng());
      std::uniform_int_distribution<std::size_t> pick(0, vars.size() - 1);
      const int a = vars[pick(h.rng())], b = vars[pick(h.rng())], c = vars[pick(h.rng())];
      if (what < 25) {  // a new variable, its prior and odometry
        add_pose();
      } else if (what < 45) {  // a loop closure: a between factor where the widths match, else random rows
        if (a != b) h.AddFactor({a, b}, h.dims().at(a) == h.dims().at(b) ? h.dims().at(a) : 1 + coin(h.rng()) % 6);
      } else if (what < 55) {  // a factor of three variables
        if (a != b && b != c && a != c) h.AddFactor({a, b, c}, 3);
      } else if (what < 65) {  // remove a loop closure or a three-variable factor
        std::vector<int> ids = h.factor_ids();
        ids.erase(
            std::remove_if(ids.begin(), ids.end(), [&](int f) { return h.vars_of(f).size() < 2 || kept.count(f); }),
            ids.end());
        if (!ids.empty()) h.RemoveFactor(ids[coin(h.rng()) % ids.size()]);
      } else if (what < 70) {  // remove a prior (odometry still determines the variable)
        if (prior_of.count(a) && a != vars.front()) {
          h.RemoveFactor(prior_of[a]);
          prior_of.erase(a);
        }
      } else if (what < 75 && vars.size() > 4 && a != constant) {  // remove a variable and its factors
        for (int f : h.factor_ids()) {
          const std::vector<int>& vf = h.vars_of(f);
          if (std::find(vf.begin(), vf.end(), a) != vf.end()) {
            h.RemoveFactor(f);
            kept.erase(f);
          }
        }
        h.RemoveVariable(a);
        prior_of.erase(a);
        vars.erase(std::find(vars.begin(), vars.end(), a));
        // Its neighbours along the chain may have lost their only link to a prior.
        for (int v : vars) {
          if (!prior_of.count(v)) prior_of[v] = h.AddFactor({v});
        }
      } else if (what < 90) {  // re-linearise a few factors
        const std::vector<int> ids = h.factor_ids();
        for (int i = 0; i < 3; ++i) h.Relinearize(ids[coin(h.rng()) % ids.size()]);
      } else if (constant < 0) {  // make a variable constant (a gauge or a fixed variable)
        constant = a;
        h.SetConstant(constant, true);
      } else {
        h.SetConstant(constant, false);
        constant = -1;
      }
      h.SolveAndCompare(where);
    }
  }
}

TEST(IncrementalCholesky, ANewVariableAtTheEndRefactorsOnlyItsPath) {
  // A chain of 200 three-wide variables given in one batch; one more variable with odometry
  // to the last touches the last column and the new one, and nothing deep in the chain is
  // refactored. Also where the batch's last factor is a prior on the first variable (so the
  // first variable is the one marked recent last): the variable added last still goes last.
  for (const auto method : kMethods) {
    for (const bool prior_last : {false, true}) {
      Harness h(7, method);
      std::vector<int> vars;
      for (int i = 0; i < 200; ++i) {
        const int v = h.AddVariable(3);
        h.AddFactor({v});
        if (!vars.empty()) h.AddFactor({vars.back(), v});
        h.engine().MarkRecent(v);
        vars.push_back(v);
      }
      if (prior_last) {
        h.AddFactor({vars.front()});
        h.engine().MarkRecent(vars.front());
      }
      h.SolveAndCompare("the chain");
      const int v = h.AddVariable(3);
      h.AddFactor({vars.back(), v});
      h.engine().MarkRecent(v);
      h.SolveAndCompare("one more variable");
      EXPECT_FALSE(h.engine().stats().full);
      EXPECT_LE(h.engine().stats().affected, 3)
          << "a new variable at the end of a chain refactors its own column and the columns above it in the tree, "
             "not the chain (prior_last "
          << prior_last << ")";
    }
  }
}

TEST(IncrementalCholesky, SupernodesSplitByTouchesInTheirMiddleStayExact) {
  // A ladder of SE3-wide variables with rungs to the variable two back: its factor has dense
  // runs of columns (supernodes, some of them relaxed with stored zeros). Touching a variable
  // in the middle of the ladder refactors only the top of the tree; the unchanged subtrees
  // below give their update matrices, including columns that were inside a supernode and so
  // compute theirs on demand. Every step is compared with the dense solve.
  for (unsigned seed = 21; seed <= 23; ++seed) {
    Harness h(seed);
    std::vector<int> vars;
    std::vector<int> odometry;
    for (int i = 0; i < 40; ++i) {
      const int v = h.AddVariable(6);
      h.AddFactor({v});
      if (!vars.empty()) odometry.push_back(h.AddFactor({vars.back(), v}));
      if (vars.size() >= 3) h.AddFactor({vars[vars.size() - 3], v});
      h.engine().MarkRecent(v);
      vars.push_back(v);
    }
    h.SolveAndCompare("seed " + std::to_string(seed) + ", the ladder");
    EXPECT_LT(h.engine().stats().supernodes, h.engine().stats().affected) << "no columns were grouped";
    std::mt19937 rng(seed);
    for (int step = 0; step < 25; ++step) {
      const std::string where = "seed " + std::to_string(seed) + ", step " + std::to_string(step);
      const int i = std::uniform_int_distribution<int>(5, 34)(rng);
      switch (step % 3) {
        case 0:  // re-linearise the odometry into a middle variable
          h.Relinearize(odometry[i - 1]);
          break;
        case 1:  // a loop closure from the middle to the newest variable
          h.AddFactor({vars[i], vars.back()});
          break;
        default: {  // a new variable at the end
          const int v = h.AddVariable(6);
          h.AddFactor({vars.back(), v});
          h.AddFactor({vars[vars.size() - 3], v});
          h.engine().MarkRecent(v);
          vars.push_back(v);
        }
      }
      h.SolveAndCompare(where);
      EXPECT_FALSE(h.engine().stats().full) << where;
      EXPECT_LT(h.engine().stats().affected, static_cast<int>(vars.size())) << where;
    }
  }
}

TEST(IncrementalCholesky, LargeFrontsRunOnTheBlasAndStayExact) {
  // SE3-wide variables, each tied to the eight before it: fronts 6 to 48 scalars wide with up
  // to 48 rows below, most of them past the flops from which the BLAS takes over (the small
  // ones at the ends stay on Eigen's kernels). Loop closures and re-linearisations into the
  // middle then refactor the top and compute on-demand updates of unchanged columns.
  for (unsigned seed = 31; seed <= 32; ++seed) {
    Harness h(seed);
    std::vector<int> vars;
    std::vector<int> factors;
    for (int i = 0; i < 40; ++i) {
      const int v = h.AddVariable(6);
      h.AddFactor({v});
      for (int back = 1; back <= 8 && back <= static_cast<int>(vars.size()); ++back) {
        factors.push_back(h.AddFactor({vars[vars.size() - back], v}));
      }
      h.engine().MarkRecent(v);
      vars.push_back(v);
    }
    h.SolveAndCompare("seed " + std::to_string(seed) + ", the band");
    EXPECT_GT(h.engine().stats().blas_fronts, 0) << "no front was large enough for the BLAS";
    std::mt19937 rng(seed);
    int blas = 0;
    for (int step = 0; step < 12; ++step) {
      const std::string where = "seed " + std::to_string(seed) + ", step " + std::to_string(step);
      const int i = std::uniform_int_distribution<int>(2, 30)(rng);
      if (step % 2 == 0) {
        h.AddFactor({vars[i], vars.back()});
      } else {
        h.Relinearize(factors[static_cast<std::size_t>(8 * i)]);
      }
      h.SolveAndCompare(where);
      blas += h.engine().stats().blas_fronts;
    }
    EXPECT_GT(blas, 0) << "seed " << seed << ": no update refactored a large front";
  }
}

TEST(IncrementalCholesky, AnUndeterminedVariableIsRefusedAndAPriorRecovers) {
  for (const auto method : kMethods) {
    Harness h(11, method);
    const int a = h.AddVariable(3);
    h.AddFactor({a});
    h.SolveAndCompare("one variable");
    // A second variable that only a one-row factor sees: its 3 x 3 block of H has rank 1.
    const int b = h.AddVariable(3);
    h.AddFactor({a, b}, 1);
    std::vector<int> changed;
    std::string why;
    EXPECT_FALSE(h.engine().Solve(0.0, &changed, &why));
    EXPECT_NE(why.find("not positive definite"), std::string::npos) << why;
    h.AddFactor({b});
    h.SolveAndCompare("after a prior on the second variable");
  }
}

}  // namespace
}  // namespace internal
}  // namespace tether
