#pragma once
// Internal: the incremental smoother's linear algebra. A block-sparse Cholesky factor
// H = L L^T of the Gauss-Newton system of whitened, linearised factors, kept between updates.
//
// Each variable is one block column of L; its elimination position orders the columns. An
// update marks the variables whose column of H changed ("touched": the variables of added,
// removed and re-linearised factors). The columns that must be refactored are the touched
// ones and their ancestors in the elimination tree (the path to the root from each), the
// "affected" set. Every other column is unchanged, and so is its contribution to the affected
// columns, which are all eliminated after it. So only the affected columns are reordered (by
// CAMD, constrained minimum degree, on the graph of their Schur complement; the variables the
// caller marks as recent go last, where the next update will touch them again) and given
// fresh positions after every other column.
//
// The affected columns are refactored left-looking (column by column) or, by Method,
// multifrontally: runs of them that form a chain in the
// tree with (nearly) equal rows are grouped into supernodes, each factorised as one dense
// front (its columns' rows of H, plus the update matrix of each child subtree, dense Cholesky
// of its columns, and the Schur complement on the rows below: its own update matrix). A
// column keeps its update matrix while it is unchanged, so the subtrees the update leaves
// alone cost one extend-add each, not a sum over their columns. The forward solution rides
// along as one more column of each front. The back substitution starts at the affected
// columns and goes down the tree while a variable's solution changes by more than a threshold
// (0: exactly every column that depends on a change).
//
// Variables are dense indices handed out by AddVariable; factors are slots from AddFactor,
// whose whitened Jacobian blocks and residual the caller writes (SetLinearization).
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace tether {
namespace internal {

class IncrementalCholesky {
 public:
  /// How the affected columns are refactored: column by column, left-looking (every earlier
  /// column that reaches a column is subtracted from it), or multifrontal (supernodes as dense
  /// fronts, with the update matrices of unchanged subtrees kept between updates). kAuto
  /// chooses at every full refactor: multifrontal where the variables are mostly 6 wide (3D),
  /// where it is faster; left-looking where they are narrower (2D), where the fronts' dense
  /// update matrices cost more than the sums they save (benchmarks/RESULTS.md).
  enum class Method { kAuto, kLeftLooking, kMultifrontal };
  void SetMethod(Method m) {
    if (m != method_) full_ = true;
    method_ = m;
  }
  /// The method the last Solve used (kLeftLooking or kMultifrontal).
  bool multifrontal() const { return multifrontal_; }

  struct Stats {
    int affected = 0;           ///< columns refactored
    int supernodes = 0;         ///< supernodes (dense fronts) the affected columns formed
    int blas_fronts = 0;        ///< fronts and on-demand updates large enough for the BLAS
    int back_substituted = 0;   ///< columns whose solution was recomputed
    bool full = false;          ///< every column was refactored
    double factor_seconds = 0;  ///< finding, ordering and refactoring the affected columns
    double back_seconds = 0;    ///< the back substitution
  };

  /// A new variable with a tangent of `dim`; its solution starts at zero.
  int AddVariable(int dim);
  /// Takes a variable out (it must use no factor). Its index is not reused.
  void RemoveVariable(int v);
  /// A constant variable is not solved for (a fixed variable, the gauge); its solution is 0.
  void SetConstant(int v, bool constant);
  bool IsConstant(int v) const { return vars_[v].constant; }

  /// A factor over `vars` with `rows` whitened residuals; its linearisation starts at zero.
  int AddFactor(const std::vector<int>& vars, int rows);
  void RemoveFactor(int f);
  /// The factor's whitened Jacobian block of its k-th variable (rows x dim, row-major, as
  /// Factor::Linearize writes it) and its whitened residual. Marks its variables touched.
  double* JacobianBlock(int f, int k) { return factors_[f].J.data() + factors_[f].offsets[k]; }
  double* Residual(int f) { return factors_[f].r.data(); }
  void Touch(int f);

  /// Marks a variable as recent: the next ordering puts it among the last columns. Where
  /// every reordered column is recent (a first batch) or none is (a full refactor after
  /// Finish), the newest goes last: marked in the latest Solve, and of those the one added
  /// last.
  void MarkRecent(int v) {
    recent_.push_back(v);
    marked_[v] = generation_;
  }
  /// Refactors every column on the next Solve (for a changed gauge or fixed set).
  void RequestFullRefactor() { full_ = true; }

  /// Refactors the affected columns and updates the solution. Returns false, with the reason
  /// in *why, where a column is not positive definite (the variable it names is not determined
  /// by its factors); the factor is then invalid until a full refactor succeeds. The variables
  /// whose solution changed are appended to *changed.
  bool Solve(double wildfire, std::vector<int>* changed, std::string* why);

  /// The Gauss-Newton step of variable v (zero for constant or unconstrained variables).
  const Eigen::VectorXd& delta(int v) const { return vars_[v].delta; }
  /// The square roots of the diagonal of H's block of v (of its factors alone) at the last
  /// refactor of its column: the step in these units is the step in standard deviations of
  /// the information the variable's own factors give it.
  const Eigen::VectorXd& scale(int v) const { return vars_[v].scale; }
  /// Sets the step of v to zero (the caller moved its linearisation point by it) and marks
  /// its factors for re-linearisation by the caller (their variables are touched by Touch).
  void ClearDelta(int v) { vars_[v].delta.setZero(); }
  int dim(int v) const { return vars_[v].dim; }
  const std::vector<int>& factors_of(int v) const { return vars_[v].factors; }
  const std::vector<int>& vars_of(int f) const { return factors_[f].vars; }
  const Stats& stats() const { return stats_; }
  /// The marginal covariance of v from the factor, where v's path to the root of the
  /// elimination tree (v and its ancestors) has at most max_columns columns, as the newest
  /// variables' have (the ordering puts them last), and the factor is current (refactored
  /// since the last change, the last refactor succeeded): v's block of (L_PP L_PP^T)^-1, L_PP
  /// the path's rows and columns of L. False otherwise.
  bool PathMarginal(int v, int max_columns, Eigen::MatrixXd* cov) const;
  /// Number of stored scalars of L (diagonal blocks in full, for the record).
  std::int64_t FactorEntries() const;

 private:
  struct Var {
    int dim = 0;
    bool alive = false;
    bool constant = false;
    std::vector<int> factors;  // live factor slots using the variable
    // Column of L: the diagonal block (dim x dim) on top, then one block per row variable.
    Eigen::MatrixXd L;
    std::vector<int> rows;        // row variables, in position order
    std::vector<int> offsets;     // first row of each row variable's block in L
    std::vector<int> dependents;  // columns whose rows hold this variable
    Eigen::VectorXd y;            // forward solution
    Eigen::VectorXd delta;        // back substitution: the step
    Eigen::VectorXd scale;        // sqrt(diag(H_vv))
    // The update of the column's subtree to its rows (minus the sum of L_rk L_rk^T over the
    // columns k of the subtree, lower triangle, rows in update_rows order) and to the forward
    // solution; kept while the column is unchanged. Held by the last column of each refactored
    // supernode, computed on demand for the others.
    bool has_update = false;
    std::vector<int> update_rows;
    Eigen::MatrixXd update;
    Eigen::VectorXd update_rhs;
  };
  struct FactorSlot {
    bool alive = false;
    int rows = 0;
    std::vector<int> vars;
    std::vector<int> offsets;  // of each variable's block in J
    std::vector<double> J;     // blocks, row-major, one after the other
    Eigen::VectorXd r;
  };

  bool InSystem(const Var& v) const { return v.alive && !v.constant && !v.factors.empty(); }
  int Parent(int v) const;
  void Affected(std::vector<int>* affected);
  void Order(std::vector<int>* columns);
  // Refactored columns first, ..., last, each the parent of the one before, factorised as
  // one dense front.
  struct Supernode {
    int first = 0, last = 0;
    int width = 0;
    std::int64_t zeros = 0;  // entries stored as zeros (rows its columns take from the last)
  };
  bool Merge(Supernode& s, int j) const;
  void Symbolic(int j);
  bool FactorSupernodes(const std::vector<int>& columns, std::string* why);
  bool FactorSupernode(const Supernode& s, std::string* why);
  bool FactorColumn(int j, std::string* why);
  /// The index of the first of `rows` at or after position `pos`.
  int RowIndex(const std::vector<int>& rows, std::int64_t pos) const;
  void ComputeUpdate(int k);
  // Adds the update of column k to the front F (leading dimension ld) and its right-hand side
  // b, at the positions scratch_ gives its rows; columns from `split` on go to U (leading
  // dimension ldu) instead, shifted by split in both coordinates.
  void ExtendAdd(int k, double* F, int ld, double* b, int split = std::numeric_limits<int>::max(), double* U = nullptr,
                 int ldu = 0);
  int Height(const Var& c) const;
  void BackSubstitute(const std::vector<int>& columns, double wildfire, std::vector<int>* changed);
  void SortRows(int k);

  std::vector<Var> vars_;
  std::vector<FactorSlot> factors_;
  std::vector<int> touched_;
  std::vector<int> recent_;
  std::vector<std::uint64_t> marked_;  // the Solve before which each variable was last marked recent
  std::uint64_t generation_ = 1;       // counts the Solves (0 in marked_: never marked)
  bool full_ = true;
  std::int64_t next_pos_ = 0;
  Stats stats_;
  // Scratch, indexed by variable.
  std::vector<std::int64_t> pos_;  // elimination position of each column; -1: none
  std::vector<std::uint32_t> stamp_;
  std::uint32_t stamp_now_ = 0;
  std::vector<std::uint32_t> seen_;
  std::uint32_t seen_now_ = 0;
  std::vector<int> scratch_;
  std::vector<std::pair<std::int64_t, int>> row_scratch_;
  Eigen::VectorXd x_scratch_, above_scratch_;
  struct Run {
    int src, dst, len;
  };
  std::vector<Run> run_scratch_;
  std::vector<int> children_scratch_;
  std::vector<int> index_scratch_;
  Method method_ = Method::kAuto;
  bool multifrontal_ = false;
  std::vector<double> front_scratch_;
  Eigen::VectorXd front_rhs_scratch_;
};

}  // namespace internal
}  // namespace tether
