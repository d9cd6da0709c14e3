#pragma once
// Shared test helper: marginal covariances computed densely, H^-1 with H = J^T J built from
// each factor's whitened Jacobians, to check tether::Marginals against
// (tests/solvers/covariance_test.cc, tests/frontends/covariance_simulated_test.cc).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {
namespace testing {

// The dense covariance of the free variables: H^-1 with H = J^T J over every factor, and
// each free key's first column.
struct Dense {
  Eigen::MatrixXd sigma;
  std::map<Key, int> offset;
  std::map<Key, int> dim;
  Eigen::MatrixXd Block(Key a, Key b) const { return sigma.block(offset.at(a), offset.at(b), dim.at(a), dim.at(b)); }
};

inline Dense DenseCovariance(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed) {
  Dense d;
  std::set<Key> used;
  for (const auto& f : graph.factors()) used.insert(f->keys().begin(), f->keys().end());
  int n = 0;
  for (Key k : values.keys()) {
    if (fixed.count(k) || !used.count(k)) continue;
    d.offset[k] = n;
    d.dim[k] = TangentDim(values.TypeOf(k));
    n += d.dim[k];
  }
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
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
    std::vector<double> r(static_cast<std::size_t>(m));
    EXPECT_TRUE(f->Linearize(params.data(), r.data(), jp.data()));
    // H += J^T J, one pair of the factor's keys at a time.
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    for (std::size_t a = 0; a < types.size(); ++a) {
      for (std::size_t b = 0; b < types.size(); ++b) {
        const Key ka = f->keys()[a], kb = f->keys()[b];
        if (!d.offset.count(ka) || !d.offset.count(kb)) continue;
        const Eigen::Map<const RowMajor> ja(jac[a].data(), m, TangentDim(types[a]));
        const Eigen::Map<const RowMajor> jb(jac[b].data(), m, TangentDim(types[b]));
        h.block(d.offset[ka], d.offset[kb], ja.cols(), jb.cols()) += ja.transpose() * jb;
      }
    }
  }
  d.sigma = h.inverse();
  return d;
}

inline void ExpectNear(const Eigen::MatrixXd& got, const Eigen::MatrixXd& want, const std::string& what) {
  ASSERT_EQ(got.rows(), want.rows()) << what;
  ASSERT_EQ(got.cols(), want.cols()) << what;
  EXPECT_LE((got - want).norm(), 1e-9 * want.norm()) << what << "\ngot\n" << got << "\nwant\n" << want;
}

}  // namespace testing
}  // namespace tether
