#pragma once
// Sparse linear solvers by name. The nonlinear solvers (tether::solvers) hand each step's
// linear system to a LinearSolver made by the entry registered under the name the options
// give (SolverOptions::linear_solver): "cholmod", "ldlt" and "qr" are built in, and a plugin
// adds more with PluginRegistrar::AddLinearSolver, the way it adds factor types.
//
// The interface lives in core so that a plugin needs nothing but core to provide a solver.
// The life of one solver object, made once per solve:
//   Analyze(pattern, block sizes)   once: the pattern never changes during the solve
//   Factorize(A)                    every iteration that needs a new factorisation
//   Solve(b, x)                     one or more times after each Factorize
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace tether {

/// A sparse matrix in compressed sparse column form whose arrays are borrowed, not owned.
/// Row indices are sorted within each column.
struct SparseMatrixView {
  int rows = 0, cols = 0;
  const int* colptr = nullptr;  ///< cols + 1 entries
  const int* rowind = nullptr;  ///< colptr[cols] entries
  const double* values = nullptr;
};

/// What a linear solver is given.
enum class LinearSystemForm {
  /// The normal equations A x = b: A = J^T J (+ damping) is n x n, symmetric positive definite,
  /// and given by its upper triangle. The diagonal blocks are stored whole: entries below the
  /// diagonal can be present and must be ignored. b and x have n entries.
  kNormalEquations,
  /// Least squares min |A x - b| on the (damped) Jacobian itself: A is m x n (m >= n), b has
  /// m entries and x has n.
  kJacobian,
};

/// How a factorisation (or a solve) went.
enum class LinearSolverStatus {
  kOk,
  kNotPositiveDefinite,  ///< a pivot was not positive: the system is singular or indefinite
  kRankDeficient,        ///< the matrix has dependent columns
  kFailed,               ///< out of memory or other numerical trouble
};

/// Settings of the linear solvers (SolverOptions::linear); each solver reads the ones it uses.
struct LinearSolverOptions {
  /// Direct solvers on the normal equations (cholmod, ldlt): the step is first solved by
  /// conjugate gradients preconditioned with the factorisation of an earlier A, at most this
  /// many iterations, and A is factorised afresh only where that does not converge (to 1e-3 of
  /// the step in the A-norm, as estimated with the earlier factorisation; the linear model's
  /// decrease is then within about 1e-6). Near the optimum A hardly changes and a few
  /// iterations replace a factorisation; 0 factorises every step. Where the solver estimates
  /// its operation counts (factorize_flops, solve_flops), fewer: only as many as can still cost
  /// less than a factorisation, and none where not even one can. docs/solvers.md has the
  /// measurements behind the default and the rule.
  int max_reuse_iterations = 8;
  /// Iterative solvers (for example the pcg example plugin): stop once |b - A x| <= this
  /// times |b|.
  double iterative_tolerance = 1e-10;
  /// Iterative solvers: at most this many iterations per solve (0: as many as A has columns).
  int iterative_max_iterations = 0;

  bool IsValid(std::string* why) const;
};

/// The processes of an MPI job that one solve spans (LinearSolver::processes()). Every process
/// runs the same solve; before any decision (keep or reject a step, reuse a factorisation,
/// stop) the values it rests on are made one across them, so that all take the same path. The
/// calls are collective: every process makes them in the same order with the same n.
class ProcessGroup {
 public:
  virtual ~ProcessGroup() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// Makes n values equal on every process: the first process's.
  virtual void Broadcast(double* values, int n) = 0;
  /// Replaces n values on every process by their sum over the processes.
  virtual void Sum(double* values, int n) = 0;
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  /// Once per solve, before any Factorize: the pattern of A (its values are not meaningful
  /// yet). `block_sizes` partitions the columns into the variables' tangent blocks, in column
  /// order (their sum is a.cols). Throws tether::Error where the pattern cannot be handled.
  virtual void Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) = 0;
  /// A with the pattern given to Analyze and this iteration's values. The arrays may change
  /// after the call returns: keep what Solve needs.
  virtual LinearSolverStatus Factorize(const SparseMatrixView& a) = 0;
  /// x for the A of the last successful Factorize (see LinearSystemForm for the sizes).
  virtual LinearSolverStatus Solve(const double* b, double* x) = 0;
  /// One line for reports, e.g. "CHOLMOD supernodal".
  virtual std::string Description() const = 0;
  /// Iterative solvers: the iterations the last Solve took (0 for direct ones).
  virtual int last_iterations() const { return 0; }
  /// Direct solvers, after Analyze: estimates of the floating-point operations of one
  /// Factorize and of one Solve (0: not known, as for CHOLMOD and Eigen's LDL^T). Where both
  /// are known, the reuse of an earlier factorisation (LinearSolverOptions::
  /// max_reuse_iterations) iterates only as long as reusing can still cost less than
  /// factorising afresh.
  virtual double factorize_flops() const { return 0; }
  virtual double solve_flops() const { return 0; }
  /// A solver whose work spans the processes of an MPI job (the "petsc" solver under
  /// mpirun): those processes, through which the solve makes its decisions one (below);
  /// nullptr for a solver in one process.
  virtual ProcessGroup* processes() { return nullptr; }
  /// A solver that spans processes may split the problem between them: given the variables'
  /// graph (compressed rows over the block columns, each neighbour once, no self-loops) and
  /// their block sizes, it fills owner[v] with the process that owns variable v and returns
  /// true. Each process then linearises only the factors whose first free variable it owns,
  /// and hands Analyze and Factorize its share of H: the sum over the processes is H (each
  /// variable's damping is in its owner's share), while every process gets the whole step from
  /// Solve. False (the default): every process hands over the whole H. Called before Analyze,
  /// collectively.
  virtual bool Partition(const std::vector<int>& xadj, const std::vector<int>& adjacency,
                         const std::vector<int>& block_sizes, std::vector<int>* owner) {
    (void)xadj;
    (void)adjacency;
    (void)block_sizes;
    (void)owner;
    return false;
  }
};

using LinearSolverFactory = std::function<std::unique_ptr<LinearSolver>(const LinearSolverOptions&)>;

struct LinearSolverEntry {
  std::string name;               ///< e.g. "cholmod"; what --linear and SolverOptions use
  std::string owner = "builtin";  ///< who registered it (the plugin's name for plugins)
  LinearSystemForm form = LinearSystemForm::kNormalEquations;
  /// Whether Solve applies the exact inverse of the A given to the last Factorize (a direct
  /// factorisation). Only then may the solvers reuse that factorisation as a preconditioner
  /// for later systems (LinearSolverOptions::max_reuse_iterations), and take the linear
  /// model's decrease from the system instead of forming A x.
  bool direct = false;
  /// Whether the solver spans the processes of an MPI job ("petsc"): then the chordal start
  /// solves its systems with it as well, so that every process starts from the same values.
  bool spans_processes = false;
  LinearSolverFactory make;
};

/// Linear solvers by name. DefaultLinearSolverRegistry() is the one the solvers use; the
/// built-in solvers join it as soon as tether::solvers is loaded.
/// Thread-safe: a plugin may register while another thread looks a solver up (use Get, which
/// copies, where an entry might be removed meanwhile).
class LinearSolverRegistry {
 public:
  LinearSolverRegistry() = default;
  LinearSolverRegistry(const LinearSolverRegistry& other);
  LinearSolverRegistry& operator=(const LinearSolverRegistry& other);

  /// Throws InvalidArgument where the name is empty or taken (naming both owners), or `make`
  /// is missing.
  void Register(LinearSolverEntry entry);
  /// Removes the entry of that name; false if there is none.
  bool Remove(const std::string& name);
  /// Removes every entry registered by `owner`; returns how many.
  int RemoveOwner(const std::string& owner);
  /// nullptr where none has that name. The pointer stays valid until that entry is removed.
  const LinearSolverEntry* Find(const std::string& name) const;
  /// A copy of the entry of that name into *out; false where there is none.
  bool Get(const std::string& name, LinearSolverEntry* out) const;
  /// The registered names, sorted.
  std::vector<std::string> Names() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, LinearSolverEntry> by_name_;
};

/// The process-wide registry of linear solvers.
LinearSolverRegistry& DefaultLinearSolverRegistry();

}  // namespace tether
