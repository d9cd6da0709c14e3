#pragma once
// Internal: the solver's view of a graph — free variables with their column offsets,
// factors with their parameter pointers and Jacobian workspace, and the sparsity
// structure of H = J^T J (upper triangle, CSC) and of J itself (for QR).
// Built once per solve; every iteration reuses it without allocating.
#include <set>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {
namespace internal {

/// Compressed sparse column matrix with int indices (as CHOLMOD and Eigen want them).
struct Csc {
  int rows = 0, cols = 0;
  std::vector<int> colptr, rowind;
  std::vector<double> values;
};

class Problem {
 public:
  /// `values` must outlive the Problem and must not gain variables while it lives.
  Problem(const FactorGraph& graph, Values* values, const std::set<Key>& fixed);

  int num_free() const { return static_cast<int>(vars_.size()); }
  int tangent_dim() const { return n_; }
  int num_residuals() const { return m_; }

  /// chi2 at the current values; +inf if a factor fails or produces a non-finite value.
  double Chi2() const;
  /// Whitened residuals and Jacobians at the current values; returns chi2 (inf on failure).
  /// Whether every Jacobian entry came out finite is kept in jacobian_finite().
  double Linearize();
  bool jacobian_finite() const { return jacobian_finite_; }
  /// H (upper, full diagonal blocks) into h.values and g = J^T r; needs BuildNormalStructure.
  void AssembleNormal(Csc* h, double* g) const;
  /// g = J^T r and the diagonal of J^T J.
  void Gradient(double* g, double* diag) const;
  /// J (plus n zero damping rows) into j.values and rhs = [-r; 0]; needs BuildJacobianStructure.
  void AssembleJacobian(Csc* j, double* rhs) const;

  void BuildNormalStructure(Csc* h, std::vector<int>* diagonal_positions);
  void BuildJacobianStructure(Csc* j, std::vector<int>* damping_positions);

  /// x <- x (+) delta for every free variable.
  void Retract(const double* delta);
  /// Norm of all free variables' parameters (for the step tolerance).
  double ParameterNorm() const;
  /// Save copies the free variables aside; Restore puts them back (a no-op before any Save).
  void Save();
  void Restore();

 private:
  struct Var {
    Key key;
    VarType type;
    int offset;  // first column
    int dim;
    double* params;
  };
  struct Entry {        // one key of one factor
    int var;            // index into vars_, or -1 when the variable is fixed
    int dim;            // tangent dimension
    int jac;            // offset of its Jacobian block in jac_
    int qr_offset = 0;  // offset of this factor's rows within the variable's J column
  };
  struct FactorRef {
    const Factor* factor;
    int m;
    int row;    // first residual row
    int first;  // first index into entries_/params_
    int count;
  };
  struct Pair {                // one block of H touched by one factor
    int row_entry, col_entry;  // entries giving the block's rows and columns
    int pos, ld;               // position of the block's (0,0) in the CSC values; column stride
  };

  // g += J_f^T r_f and, where diag is not null, diag += the column norms of J_f squared.
  void AddGradient(const FactorRef& f, double* g, double* diag) const;

  std::vector<Var> vars_;
  std::vector<FactorRef> factors_;
  std::vector<Entry> entries_;
  std::vector<const double*> params_;
  std::vector<double*> jac_ptrs_;
  std::vector<Pair> pairs_;
  std::vector<double> jac_, res_;
  std::vector<double> saved_;
  std::vector<int> qr_colptr_;
  Values* values_;
  int n_ = 0, m_ = 0;
  bool jacobian_finite_ = false;
  bool has_saved_ = false;
};

}  // namespace internal
}  // namespace tether
