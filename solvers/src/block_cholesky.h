#pragma once
// Internal: a sparse Cholesky factorisation A = P^T L L^T P of a symmetric positive definite
// matrix whose entries come in dense blocks, the variables' tangent blocks (3 x 3 for SE2,
// 6 x 6 for SE3). Everything symbolic works on the graph of the blocks, not on the scalars: the
// ordering (minimum degree on the block graph), the elimination tree and the pattern of L
// are found once, in Analyze, on a graph with a third (2D) or a sixth (3D) of the nodes the
// scalar matrix has and a ninth or a thirty-sixth of its entries. The numeric factorisation
// is up-looking (row by row of L, as CSparse's cs_chol does with scalars): row k of L solves
// a triangular system over the rows its elimination-tree reach names, each step a dense
// product of small blocks of fixed size where every block has the same size.
//
// No BLAS and no supernodes: on the sparse pose graphs of 2D SLAM (a few non-zero blocks per
// column of L) the dense blocks are too small for either to pay, and the scalar simplicial
// factorisations pay an index per scalar where this pays one per block. docs/solvers.md has the
// measurements against CHOLMOD.
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "tether/core/linear_solver.h"

namespace tether {
namespace internal {

/// The "auto" linear solver's rule: the block Cholesky where every block has the same size and
/// the factor is sparse (UpdatesPerBlock at most this), CHOLMOD otherwise, whose supernodes
/// with dense BLAS products win on long columns. The crossover measured on the public files and
/// simulated worlds of 2 000 to 100 000 poses lies between 38 (a 10 000-pose Manhattan world,
/// block 18% faster) and 43 (sphere2500, CHOLMOD 1.5 times faster); docs/solvers.md.
constexpr double kMaxBlockUpdatesPerBlock = 40;

struct BlockSymbolic;

class BlockCholesky {
 public:
  /// The pattern of A: its upper triangle in compressed columns, diagonal blocks whole (entries
  /// below the diagonal are ignored), as LinearSolver::Analyze is given it. `block_sizes`
  /// partitions the columns (their sum is a.cols); empty: every column its own block. Throws
  /// InvalidArgument where the sizes do not partition the columns or A is not square.
  /// `allocate` false leaves the numeric storage (the factor's values, the workspace) for
  /// Allocate, or the first Factorize. The analysis stops early, returning false, where
  /// `require_uniform` and the blocks differ in size, or where the factor is denser than
  /// `max_updates_per_block` (UpdatesPerBlock): a caller choosing a solver by these figures
  /// pays no more than it needs (uniform_size and UpdatesPerBlock are then set as far as they
  /// were computed; Factorize throws).
  bool Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes, bool allocate = true,
               double max_updates_per_block = std::numeric_limits<double>::infinity(), bool require_uniform = false);
  /// The numeric storage the analysis sized.
  void Allocate();
  /// A's values, same pattern. False where a pivot block is not positive definite (the
  /// factorisation is then unusable until a later Factorize succeeds).
  bool Factorize(const SparseMatrixView& a);
  /// x = A^{-1} b with the last successful factorisation; b and x may be the same array.
  void Solve(const double* b, double* x) const;

  /// Blocks of L below the diagonal (the fill the ordering left).
  std::int64_t off_diagonal_blocks() const;
  int num_blocks() const { return nb_; }
  /// The fill-reducing ordering of the last Analyze in scalar columns (column k of the factor
  /// is column ScalarOrdering()[k] of A); empty where the analysis stopped before ordering.
  std::vector<int> ScalarOrdering() const;
  /// Whether the last Analyze found its ordering and factor pattern done: the process's last
  /// analysis was of the same block pattern (the chordal start's, before the solve's).
  bool reused_analysis() const { return reused_; }
  /// The common size of the blocks, 0 where they differ.
  int uniform_size() const { return uniform_; }
  /// How dense the factor is: the block products of the factorisation per block of L,
  /// sum_j c_j^2 / sum_j c_j over the columns j of L with c_j blocks (diagonal included). About
  /// 2-4 on the sparse pose graphs of 2D SLAM; long columns, where dense supernodes pay, give
  /// tens.
  double UpdatesPerBlock() const;
  /// Estimates of the floating-point operations of one Factorize and one Solve, from the
  /// factor's pattern and the blocks' sizes (0 before a complete analysis).
  double FactorizeFlops() const;
  double SolveFlops() const;

 private:
  template <int B>
  bool FactorizeBlocks();
  template <int B>
  void SolveBlocks(double* y) const;
  int Size(int k) const { return size_[k]; }

  int nb_ = 0, n_ = 0;
  int uniform_ = 0;              // the common block size, 0 where they differ
  std::vector<int> size_, off_;  // per block of the permuted matrix: size and first scalar row
  std::vector<int> orig_off_;    // first scalar of each block of A
  // What does not depend on the blocks' sizes: the ordering, the permuted pattern of A, L's
  // pattern (shared with the process's last analysis of the same pattern, block_cholesky.cc).
  std::shared_ptr<const BlockSymbolic> sym_;
  // Permuted A's upper triangle by block columns (sym_->a_colptr, a_row): the diagonal block at
  // a_diag_[k], the blocks above it (rows a_row[p] < k) at a_val_[p], each b_row x b_k.
  std::vector<std::int64_t> a_val_, a_diag_;
  std::vector<double> ax_;
  std::int64_t ax_size_ = 0, lx_size_ = 0;
  std::vector<std::int64_t> scatter_;  // per scalar entry of the view: its place in ax_ (-1: ignored)
  // Row k of L (below the diagonal): the columns sym_->r_col[r_rowptr[k] ..] in topological
  // order of the elimination tree; the entries of column i of L: rows l_row[l_colptr[i] ..],
  // each block b_row x b_i (column-major) at l_val_; the diagonal blocks, inverted, at l_diag_.
  std::vector<std::int64_t> l_val_, l_diag_;
  std::vector<double> lx_;
  std::vector<std::int64_t> x_off_;  // workspace: one b_i x b_max block per block row
  mutable std::vector<double> work_;
  std::vector<int> fill_;  // per column of L: entries filled so far in this factorisation
  int max_size_ = 0;
  bool factorized_ = false;
  bool complete_ = false;  // the last Analyze ran to the end
  bool ordered_ = false;   // ... or at least as far as the ordering
  bool reused_ = false;    // ... from the process's last analysis of the same pattern
};

}  // namespace internal
}  // namespace tether
