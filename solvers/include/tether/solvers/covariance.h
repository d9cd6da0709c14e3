#pragma once
// Marginal covariances of a graph's variables at given values: blocks of H^-1, where
// H = J^T J is the Gauss-Newton matrix of the whitened factors linearised there.
//
//   Marginals m(graph, values);                       // linearise and factorise once
//   Eigen::MatrixXd c = m.Marginal(X(3));             // 3 x 3 for an SE2 pose
//   Eigen::MatrixXd j = m.JointMarginal({X(3), L(1)});  // 5 x 5, blocks in that order
//   std::vector<Eigen::MatrixXd> all = m.MarginalsOf(m.free_keys());
//
// Each covariance is in the variable's tangent coordinates: those of the box-plus delta,
// x (+) delta (for SE2 (dx, dy, dtheta) in the body frame; SE3 as its Retract orders them).
// The variables held constant are those Optimize holds: the graph's fixed set or, where it
// fixes nothing and no prior anchors the graph, the lowest-key pose (gauge_key() says which).
// A held variable has no covariance: asking for it throws InvalidArgument naming the key.
// docs/solvers.md ("Marginal covariances") describes the methods and their cost.
#include <Eigen/Core>
#include <iosfwd>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {

/// H is singular at the given values: some direction is not determined by the factors
/// (a gauge left free, a landmark seen too few times, a part of the graph not connected to
/// the held variables). The message names the variable where the factorisation broke down,
/// where the solver can tell.
class RankDeficientError : public Error {
 public:
  using Error::Error;
};

struct CovarianceOptions {
  /// "cholmod" (the default): CHOLMOD's Cholesky factor; the blocks of many variables come
  /// from the sparse inverse subset (Takahashi's recursion over the supernodes).
  /// "ldlt": Eigen's SimplicialLDLT, solves against columns of the identity.
  /// "qr": SuiteSparseQR's R of the Jacobian, Sigma = (R^T R)^-1 by solves with R^T and R.
  std::string linear_solver = "cholmod";
  /// Threads for the linearisation (as SolverOptions::num_threads). Default 1.
  int num_threads = 1;

  /// True when the options can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

class Marginals {
 public:
  /// Linearises `graph` at `values` (copied) and factorises H once. Throws InvalidArgument
  /// for invalid options or a graph the solver cannot take (missing keys, non-finite
  /// Jacobians: the message names the factor), RankDeficientError where H is singular.
  Marginals(const FactorGraph& graph, const Values& values, const CovarianceOptions& options = {});
  ~Marginals();
  Marginals(const Marginals&) = delete;
  Marginals& operator=(const Marginals&) = delete;

  /// The tangent_dim x tangent_dim covariance of `key`. Throws InvalidArgument where the key
  /// is unknown, held fixed, or used by no factor.
  Eigen::MatrixXd Marginal(Key key) const;
  /// The joint covariance of `keys` (distinct), blocks in the given order: block (i, j) is
  /// the cross-covariance of keys[i] and keys[j].
  Eigen::MatrixXd JointMarginal(const std::vector<Key>& keys) const;
  /// The marginal of every key of `keys`, in that order: for many keys far cheaper than one
  /// Marginal call each (with cholmod, one pass of the sparse inverse subset for all).
  std::vector<Eigen::MatrixXd> MarginalsOf(const std::vector<Key>& keys) const;

  /// The variables that have a covariance, in the values' order.
  const std::vector<Key>& free_keys() const;
  /// The variables held constant (the graph's fixed set or the automatic gauge).
  const std::set<Key>& fixed_keys() const;
  /// True where nothing was fixed and no prior anchored the graph, so gauge_key() was held.
  bool gauge_fixed_automatically() const;
  Key gauge_key() const;
  /// Seconds of the numeric factorisation (the constructor's), and of linearising and
  /// assembling before it.
  double factorize_seconds() const;
  double linearize_seconds() const;
  /// The method in use, e.g. "CHOLMOD supernodal, sparse inverse subset".
  std::string Description() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes covariances as text, one line per variable:
///   id type n c11 c12 ... c1n c22 ... cnn
/// (type as ToString(VarType), n the tangent dimension, then the upper triangle row by row,
/// each number the shortest text that reads back as the same double), after one comment line
/// starting with '#'. Throws InvalidArgument where keys and covariances differ in number.
void WriteCovariances(std::ostream& out, const Values& values, const std::vector<Key>& keys,
                      const std::vector<Eigen::MatrixXd>& covariances);
/// The same into a file, through tether's one output writer (tether/core/output_file.h): a
/// temporary file renamed into place, so a failure never leaves half a file. Throws IoError
/// where it cannot be written.
void WriteCovarianceFile(const std::string& path, const Values& values, const std::vector<Key>& keys,
                         const std::vector<Eigen::MatrixXd>& covariances);

}  // namespace tether
