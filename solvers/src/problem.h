#pragma once
// Internal: the solver's view of a graph — free variables with their column offsets,
// factors with their parameter pointers and Jacobian workspace, and the sparsity
// structure of H = J^T J (upper triangle, CSC) and of J itself (for QR).
// Built once per solve; every iteration reuses it without allocating.
//
// Threads: Linearize and Chi2 split the factors, AssembleNormal, Gradient and
// AssembleJacobian split the block columns (or the factors) into num_threads fixed parts.
// Every entry of H, g and chi2 is summed in the same order whatever the number of threads
// (H and g column by column in factor order; chi2 factor by factor), so results are
// bit-identical for any num_threads.
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/linear_solver.h"
#include "tether/core/values.h"
#include "tether/solvers/step_strategy.h"

namespace tether {
namespace internal {

class ThreadPool;

/// Compressed sparse column matrix with int indices (as CHOLMOD and Eigen want them).
struct Csc {
  int rows = 0, cols = 0;
  std::vector<int> colptr, rowind;
  std::vector<double> values;
};

/// The free variables as a Problem of the same graph, values and fixed set orders them, and
/// their graph: an edge between two variables that some factor shares (each neighbour once, no
/// self-loops), in compressed rows. What a solver that spans processes partitions
/// (LinearSolver::Partition) before the Problem is built.
struct VariableGraph {
  std::vector<int> block_sizes;  ///< tangent size of each free variable, in column order
  std::vector<int> xadj, adjacency;
  /// For each factor of the graph, its first free variable (-1: none).
  std::vector<int> first_free;
};

/// Neighbour lists (one per variable) into compressed rows, each list sorted and its repeats
/// dropped; the lists are emptied on the way.
void ToCompressedRows(std::vector<std::vector<int>>* lists, std::vector<int>* xadj, std::vector<int>* adjacency);

class Problem : public TrialPoint {
 public:
  /// `values` must outlive the Problem and must not gain variables while it lives.
  /// `factor_mask` (optional, one entry per factor of `graph`): only the factors marked
  /// linearise here; the variables and their columns are still those of the whole graph (a
  /// process's share of a problem split between processes).
  Problem(const FactorGraph& graph, Values* values, const std::set<Key>& fixed, int num_threads = 1,
          const std::vector<char>* factor_mask = nullptr);
  /// The free variables' graph of `graph` (above).
  static VariableGraph Variables(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed);
  ~Problem();

  int num_threads() const;

  int num_free() const { return static_cast<int>(vars_.size()); }
  int tangent_dim() const { return n_; }
  int num_residuals() const { return m_; }
  /// The free variables' tangent dimensions in column order (the blocks of H's columns).
  std::vector<int> BlockSizes() const;
  /// Free variable i (in column order): its key, type and first column.
  Key free_key(int i) const { return vars_[i].key; }
  VarType free_type(int i) const { return vars_[i].type; }
  int free_offset(int i) const { return vars_[i].offset; }

  /// chi2 at the current values; +inf if a factor fails or produces a non-finite value.
  double Chi2() const override;
  /// Whitened residuals and Jacobians at the current values; returns chi2 (inf on failure).
  /// Whether every Jacobian entry came out finite is kept in jacobian_finite().
  double Linearize();
  bool jacobian_finite() const { return jacobian_finite_; }
  /// The first factor whose error or Jacobian is not finite at the current values, as
  /// "factor 12 (BetweenSE2, keys 3, 4) has a non-finite error"; empty where none is.
  std::string DescribeNonFinite() const;
  /// H (upper, full diagonal blocks) into h.values and g = J^T r; needs BuildNormalStructure.
  void AssembleNormal(Csc* h, double* g) const;
  /// g = J^T r and the diagonal of J^T J.
  void Gradient(double* g, double* diag) const;
  /// J (plus n zero damping rows) into j.values and rhs = [-r; 0]; needs BuildJacobianStructure.
  void AssembleJacobian(Csc* j, double* rhs) const;

  void BuildNormalStructure(Csc* h, std::vector<int>* diagonal_positions);
  void BuildJacobianStructure(Csc* j, std::vector<int>* damping_positions);

  /// x <- x (+) delta for every free variable.
  void Retract(const double* delta) override;
  /// Norm of all free variables' parameters (for the step tolerance).
  double ParameterNorm() const;
  /// Where the linear solver spans processes (LinearSolver::processes()): Chi2, Linearize and
  /// ParameterNorm hand back the value all processes agree on; with `split` (this process
  /// linearises only its share of the factors, factor_mask), chi2 is summed over them first.
  /// nullptr: this process alone.
  void set_processes(ProcessGroup* group, bool split) {
    group_ = group;
    split_ = split;
  }
  /// Save copies the free variables aside; Restore puts them back (a no-op before any Save).
  void Save();
  void Restore() override;

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
    int index;  // in the graph (for messages)
    int m;
    int row;    // first residual row
    int first;  // first index into entries_/params_
    int count;
  };
  // blk += Jr^T Jc for row-major m x rd and m x cd Jacobian blocks; blk has column stride ld.
  using BlockKernel = void (*)(const double* jr, const double* jc, double* blk, int ld, int m, int rd, int cd);
  struct Pair {                // one block of H touched by one factor
    int row_entry, col_entry;  // entries giving the block's rows and columns
    int pos, ld;               // position of the block's (0,0) in the CSC values; column stride
    int m;                     // the factor's residual dimension
    BlockKernel kernel;
  };
  // g += J^T r for a row-major m x d Jacobian block.
  using GradientKernel = void (*)(const double* j, const double* r, double* g, int m, int d);
  struct VarEntry {  // one factor's use of a free variable, for the gradient
    int entry;       // index into entries_
    int row;         // the factor's first residual row
    int m;
    GradientKernel kernel;
  };

  // Factors of one part: whitened residuals and each factor's cost (chi2, or rho(chi2) where
  // it carries a robust loss) into factor_cost_; with res (= res_), the residuals go there and
  // the Jacobians into jac_ (weighted by sqrt(rho') under a loss), else only the cost.
  // Returns 0, 1 when a factor failed, 2 when some Jacobian entry is not finite.
  // `part` is the index of the thread's part of the factors (factor_parts_).
  int LinearizeRange(int part, double* res) const;
  // Block columns of variables [v0, v1) of H (zeroed first) and their g (and diag) entries.
  void AssembleColumns(int v0, int v1, double* hx, double* g) const;
  void GradientRange(int v0, int v1, double* g, double* diag) const;
  // Sums factor_cost_ in factor order (the objective, "chi2" in the minimiser's log); +inf
  // when not finite.
  double SumChi2() const;

  template <typename F>
  void Parallel(F& f) const;

  std::vector<Var> vars_;
  std::vector<FactorRef> factors_;
  std::vector<Entry> entries_;
  std::vector<const double*> params_;
  std::vector<double*> jac_ptrs_;
  std::vector<Pair> pairs_;            // grouped by block column, factor order within a column
  std::vector<int> column_pairs_;      // pairs_ of block column v: [column_pairs_[v], column_pairs_[v + 1])
  std::vector<long> column_base_;      // H values of block column v: [column_base_[v], column_base_[v + 1])
  std::vector<VarEntry> var_entries_;  // grouped by variable, factor order within one
  std::vector<int> var_entry_start_;
  std::vector<int> factor_jac_;                // jac_ of factor f: [factor_jac_[f], factor_jac_[f + 1])
  std::vector<int> factor_parts_, var_parts_;  // num_threads + 1 boundaries each
  mutable std::vector<double> factor_cost_;
  mutable std::vector<double> scratch_;  // one residual per part, for chi2 alone
  int max_m_ = 0;                        // the largest residual dimension
  mutable std::vector<int> part_status_;
  std::unique_ptr<ThreadPool> pool_;
  std::vector<double> jac_, res_;
  std::vector<double> saved_;
  std::vector<int> qr_colptr_;
  int n_ = 0, m_ = 0;
  bool jacobian_finite_ = false;
  bool has_saved_ = false;
  ProcessGroup* group_ = nullptr;
  bool split_ = false;
  // chi2-like totals: summed over the processes where the factors are split, then made one.
  void Total(double* v, int n) const;
};

}  // namespace internal
}  // namespace tether
