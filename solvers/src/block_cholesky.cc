#include "block_cholesky.h"

#include <camd.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <numeric>
#include <string>
#include <type_traits>

#include "builtin_linear_solvers.h"
#include "tether/core/error.h"

namespace tether {
namespace internal {

namespace {

// Column-major views of a block of rows x cols at p; B (or Eigen::Dynamic) fixes both sizes
// where every block has the same size.
template <int R, int C>
using Block = Eigen::Map<Eigen::Matrix<double, R, C>>;
template <int R, int C>
using ConstBlock = Eigen::Map<const Eigen::Matrix<double, R, C>>;

// Elimination tree of the upper block pattern (column k's rows i < k), by Liu's algorithm with
// path compression: parent[i] is the first row below i that i's column of L reaches.
std::vector<int> EliminationTree(int n, const std::vector<int>& colptr, const std::vector<int>& row) {
  std::vector<int> parent(n, -1), ancestor(n, -1);
  for (int k = 0; k < n; ++k) {
    for (int p = colptr[k]; p < colptr[k + 1]; ++p) {
      for (int i = row[p]; i != -1 && i < k;) {
        const int next = ancestor[i];
        ancestor[i] = k;
        if (next == -1) {
          parent[i] = k;
          break;
        }
        i = next;
      }
    }
  }
  return parent;
}

// Calls f with std::integral_constant<int, B> for the block sizes the kernels are compiled for
// (1, 2, 3, 6) and with Eigen::Dynamic for any other (0: sizes that differ).
template <class F>
decltype(auto) WithBlockSize(int size, F&& f) {
  switch (size) {
    case 1:
      return f(std::integral_constant<int, 1>());
    case 2:
      return f(std::integral_constant<int, 2>());
    case 3:
      return f(std::integral_constant<int, 3>());
    case 6:
      return f(std::integral_constant<int, 6>());
    default:
      return f(std::integral_constant<int, Eigen::Dynamic>());
  }
}

// Where each block of a block-sparse matrix (compressed columns: rows row[colptr[j] ..]) goes
// in one array of values: column j's diagonal block (size[j] x size[j]) at diag[j], then its
// other blocks (size[row] x size[j]) at val[p], each column-major. Returns the values' count.
std::int64_t BlockOffsets(const std::vector<int>& colptr, const std::vector<int>& row, const std::vector<int>& size,
                          std::vector<std::int64_t>* diag, std::vector<std::int64_t>* val) {
  const int n = static_cast<int>(size.size());
  diag->assign(n, 0);
  val->assign(row.size(), 0);
  std::int64_t used = 0;
  for (int j = 0; j < n; ++j) {
    (*diag)[j] = used;
    used += static_cast<std::int64_t>(size[j]) * size[j];
    for (int p = colptr[j]; p < colptr[j + 1]; ++p) {
      (*val)[p] = used;
      used += static_cast<std::int64_t>(size[row[p]]) * size[j];
    }
  }
  return used;
}

// The inverse of the Cholesky factor of the symmetric n x n block a (column-major, both
// triangles), into linv (lower triangular, column-major); a is overwritten with the factor.
// False where a is not positive definite. The diagonal blocks are kept inverted: every use of
// them is then a product of small blocks, not a triangular solve.
template <int B>
bool InvertedCholesky(double* a, int n, double* linv) {
  if (B != Eigen::Dynamic) n = B;  // fixed loop bounds: the compiler unrolls them
  for (int j = 0; j < n; ++j) {
    double djj = a[j + j * n];
    for (int k = 0; k < j; ++k) djj -= a[j + k * n] * a[j + k * n];
    if (!(djj > 0) || !std::isfinite(djj)) return false;
    const double ljj = std::sqrt(djj);
    a[j + j * n] = ljj;
    for (int i = j + 1; i < n; ++i) {
      double v = a[i + j * n];
      for (int k = 0; k < j; ++k) v -= a[i + k * n] * a[j + k * n];
      a[i + j * n] = v / ljj;
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < j; ++i) linv[i + j * n] = 0;
    linv[j + j * n] = 1.0 / a[j + j * n];
    for (int i = j + 1; i < n; ++i) {
      double v = 0;
      for (int k = j; k < i; ++k) v -= a[i + k * n] * linv[k + j * n];
      linv[i + j * n] = v / a[i + i * n];
    }
  }
  return true;
}

}  // namespace

bool BlockCholesky::Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes, bool allocate,
                            double max_updates_per_block, bool require_uniform) {
  complete_ = false;
  ordered_ = false;
  factorized_ = false;
  if (a.rows != a.cols) {
    throw InvalidArgument("block Cholesky: the matrix is " + std::to_string(a.rows) + " x " + std::to_string(a.cols) +
                          "; it must be square");
  }
  n_ = a.cols;
  std::vector<int> sizes = block_sizes;
  if (sizes.empty()) sizes.assign(n_, 1);
  if (std::any_of(sizes.begin(), sizes.end(), [](int s) { return s < 1; }) ||
      std::accumulate(sizes.begin(), sizes.end(), 0L) != n_) {
    throw InvalidArgument("block Cholesky: the block sizes do not partition the " + std::to_string(n_) + " columns");
  }
  nb_ = static_cast<int>(sizes.size());
  uniform_ =
      !sizes.empty() && std::all_of(sizes.begin(), sizes.end(), [&](int s) { return s == sizes[0]; }) ? sizes[0] : 0;
  l_colptr_.assign(nb_ + 1, 0);
  if (require_uniform && uniform_ == 0) return false;
  orig_off_.assign(nb_ + 1, 0);
  for (int b = 0; b < nb_; ++b) orig_off_[b + 1] = orig_off_[b] + sizes[b];
  std::vector<int> block_of(n_);
  for (int b = 0; b < nb_; ++b) std::fill(block_of.begin() + orig_off_[b], block_of.begin() + orig_off_[b + 1], b);

  // The upper block pattern of A: the block rows I < J of each block column J, sorted, in
  // compressed columns. The ordering takes it as it is (it works on A + A^T).
  std::vector<int> up(nb_ + 1, 0), ui;
  {
    std::vector<int> mark(nb_, -1);
    for (int J = 0; J < nb_; ++J) {
      mark[J] = J;
      for (int c = orig_off_[J]; c < orig_off_[J + 1]; ++c) {
        for (int p = a.colptr[c]; p < a.colptr[c + 1]; ++p) {
          const int I = block_of[a.rowind[p]];
          if (I >= J || mark[I] == J) continue;  // the lower triangle is the mirror; seen
          mark[I] = J;
          ui.push_back(I);
        }
      }
      std::sort(ui.begin() + up[J], ui.end());
      up[J + 1] = static_cast<int>(ui.size());
    }
  }
  perm_.assign(nb_, 0);
  std::iota(perm_.begin(), perm_.end(), 0);
  if (nb_ > 1 && !ui.empty()) {
    double control[CAMD_CONTROL], info[CAMD_INFO];
    camd_defaults(control);
    std::vector<int> p(nb_ + 1);
    const int status = camd_order(nb_, up.data(), ui.data(), p.data(), control, info, nullptr);
    if (status == CAMD_OK || status == CAMD_OK_BUT_JUMBLED) std::copy(p.begin(), p.begin() + nb_, perm_.begin());
  }
  ordered_ = true;
  std::vector<int> pinv(nb_);
  for (int k = 0; k < nb_; ++k) pinv[perm_[k]] = k;
  size_.assign(nb_, 0);
  off_.assign(nb_ + 1, 0);
  for (int k = 0; k < nb_; ++k) {
    size_[k] = sizes[perm_[k]];
    off_[k + 1] = off_[k] + size_[k];
  }
  max_size_ = size_.empty() ? 0 : *std::max_element(size_.begin(), size_.end());

  // Permuted A's upper block pattern (in no particular order within a column), and where each
  // block of A's upper pattern went (upos).
  a_colptr_.assign(nb_ + 1, 0);
  for (int J = 0; J < nb_; ++J) {
    for (int q = up[J]; q < up[J + 1]; ++q) ++a_colptr_[std::max(pinv[ui[q]], pinv[J]) + 1];
  }
  for (int k = 0; k < nb_; ++k) a_colptr_[k + 1] += a_colptr_[k];
  a_row_.assign(a_colptr_[nb_], 0);
  std::vector<int> upos(ui.size());
  {
    std::vector<int> next(a_colptr_.begin(), a_colptr_.end() - 1);
    for (int J = 0; J < nb_; ++J) {
      for (int q = up[J]; q < up[J + 1]; ++q) {
        const int i = pinv[ui[q]], j = pinv[J];
        upos[q] = next[std::max(i, j)]++;
        a_row_[upos[q]] = std::min(i, j);
      }
    }
  }
  // The elimination tree and, for each row k of L, its reach in the tree from A's column k:
  // the columns of row k of L, in an order where a column comes before its ancestors. A first
  // pass counts (how dense the factor is decides whether to go on), a second stores.
  const std::vector<int> parent = EliminationTree(nb_, a_colptr_, a_row_);
  std::vector<int> count(nb_, 0), flag(nb_, -1), stack(nb_);
  const auto reach = [&](int k) {  // row k's columns at stack[top .. nb_)
    flag[k] = k;
    int top = nb_;
    for (int p = a_colptr_[k]; p < a_colptr_[k + 1]; ++p) {
      int len = 0;
      for (int i = a_row_[p]; flag[i] != k; i = parent[i]) {
        stack[len++] = i;
        flag[i] = k;
      }
      while (len > 0) stack[--top] = stack[--len];
    }
    return top;
  };
  r_rowptr_.assign(nb_ + 1, 0);
  for (int k = 0; k < nb_; ++k) {
    const int top = reach(k);
    for (int t = top; t < nb_; ++t) ++count[stack[t]];
    r_rowptr_[k + 1] = r_rowptr_[k] + (nb_ - top);
  }
  for (int i = 0; i < nb_; ++i) l_colptr_[i + 1] = l_colptr_[i] + count[i];
  if (UpdatesPerBlock() > max_updates_per_block) return false;
  std::fill(flag.begin(), flag.end(), -1);
  r_col_.resize(r_rowptr_[nb_]);
  for (int k = 0; k < nb_; ++k) {
    const int top = reach(k);
    std::copy(stack.begin() + top, stack.end(), r_col_.begin() + r_rowptr_[k]);
  }
  l_row_.assign(l_colptr_[nb_], 0);
  {
    std::vector<int> next(l_colptr_.begin(), l_colptr_.end() - 1);
    for (int k = 0; k < nb_; ++k) {
      for (int t = r_rowptr_[k]; t < r_rowptr_[k + 1]; ++t) l_row_[next[r_col_[t]]++] = k;
    }
  }

  ax_size_ = BlockOffsets(a_colptr_, a_row_, size_, &a_diag_, &a_val_);
  // Each scalar of A's upper triangle: its place in ax_. A column's rows are sorted, so its
  // blocks come in the order of the block column's upper pattern (a search where they are not).
  scatter_.assign(a.colptr[n_], -1);
  for (int c = 0; c < n_; ++c) {
    const int J = block_of[c], lc = c - orig_off_[J], j = pinv[J];
    int q = up[J];
    for (int p = a.colptr[c]; p < a.colptr[c + 1]; ++p) {
      const int r = a.rowind[p], I = block_of[r], lr = r - orig_off_[I];
      if (I > J || (I == J && lr > lc)) continue;  // below the diagonal: ignored
      if (I == J) {
        scatter_[p] = a_diag_[j] + lr + static_cast<std::int64_t>(lc) * size_[j];
        continue;
      }
      while (q < up[J + 1] && ui[q] != I) ++q;
      if (q == up[J + 1])
        q = static_cast<int>(std::lower_bound(ui.begin() + up[J], ui.begin() + up[J + 1], I) - ui.begin());
      const int i = pinv[I];
      // Block (i, j) of the permuted matrix, or where i > j its mirror (j, i), transposed.
      scatter_[p] = i < j ? a_val_[upos[q]] + lr + static_cast<std::int64_t>(lc) * size_[i]
                          : a_val_[upos[q]] + lc + static_cast<std::int64_t>(lr) * size_[j];
    }
  }

  lx_size_ = BlockOffsets(l_colptr_, l_row_, size_, &l_diag_, &l_val_);
  x_off_.assign(nb_, 0);
  for (int i = 0; i < nb_; ++i) x_off_[i] = static_cast<std::int64_t>(off_[i]) * max_size_;
  fill_.assign(nb_, 0);
  ax_.clear();
  lx_.clear();
  work_.clear();
  complete_ = true;
  if (allocate) Allocate();
  return true;
}

void BlockCholesky::Allocate() {
  ax_.assign(ax_size_, 0.0);
  lx_.assign(lx_size_, 0.0);
  // The factorisation's block rows, the solve's vector, one diagonal block.
  work_.assign(static_cast<std::size_t>(n_) * max_size_ + n_ + static_cast<std::size_t>(max_size_) * max_size_, 0.0);
}

std::vector<int> BlockCholesky::ScalarOrdering() const {
  std::vector<int> order;
  if (!ordered_) return order;
  order.reserve(n_);
  for (int k = 0; k < nb_; ++k) {
    for (int c = orig_off_[perm_[k]]; c < orig_off_[perm_[k] + 1]; ++c) order.push_back(c);
  }
  return order;
}

double BlockCholesky::UpdatesPerBlock() const {
  double updates = 0, blocks = 0;
  for (int j = 0; j < nb_; ++j) {
    const double c = 1.0 + l_colptr_[j + 1] - l_colptr_[j];
    updates += c * c;
    blocks += c;
  }
  return blocks > 0 ? updates / blocks : 0;
}

bool BlockCholesky::Factorize(const SparseMatrixView& a) {
  if (!complete_) throw Error("block Cholesky: Factorize after an analysis that stopped early");
  if (lx_.size() != static_cast<std::size_t>(lx_size_)) Allocate();
  std::fill(ax_.begin(), ax_.end(), 0.0);
  const std::int64_t nnz = static_cast<std::int64_t>(scatter_.size());
  for (std::int64_t p = 0; p < nnz; ++p) {
    if (scatter_[p] >= 0) ax_[scatter_[p]] = a.values[p];
  }
  factorized_ = WithBlockSize(uniform_, [this](auto b) { return FactorizeBlocks<decltype(b)::value>(); });
  return factorized_;
}

template <int B>
bool BlockCholesky::FactorizeBlocks() {
  double* x = work_.data();
  std::fill(fill_.begin(), fill_.end(), 0);
  double* dbuf = work_.data() + static_cast<std::size_t>(n_) * max_size_ + n_;
  for (int k = 0; k < nb_; ++k) {
    const int bk = Size(k);
    // Column k of A above the diagonal into the workspace, the diagonal block into d (its
    // lower triangle from the upper one).
    for (int p = a_colptr_[k]; p < a_colptr_[k + 1]; ++p) {
      const int i = a_row_[p], bi = Size(i);
      Block<B, B>(x + x_off_[i], bi, bk) = ConstBlock<B, B>(ax_.data() + a_val_[p], bi, bk);
    }
    Block<B, B> d(dbuf, bk, bk);
    d = ConstBlock<B, B>(ax_.data() + a_diag_[k], bk, bk).template selfadjointView<Eigen::Upper>();
    for (int t = r_rowptr_[k]; t < r_rowptr_[k + 1]; ++t) {
      const int i = r_col_[t], bi = Size(i);
      Block<B, B> xi(x + x_off_[i], bi, bk);
      // y = L_ii^{-1} x_i: the block L(k, i)^T.
      xi = ConstBlock<B, B>(lx_.data() + l_diag_[i], bi, bi) * xi;
      // The rows of column i already computed (rows below i, above k) take their share.
      const int p0 = l_colptr_[i], p1 = p0 + fill_[i];
      for (int p = p0; p < p1; ++p) {
        const int r = l_row_[p], br = Size(r);
        Block<B, B>(x + x_off_[r], br, bk).noalias() -= ConstBlock<B, B>(lx_.data() + l_val_[p], br, bi) * xi;
      }
      d.noalias() -= xi.transpose() * xi;
      Block<B, B>(lx_.data() + l_val_[p1], bk, bi) = xi.transpose();
      ++fill_[i];
      xi.setZero();
    }
    // (The workspace is clean here: every block row it used was in row k's reach.)
    if (!InvertedCholesky<B>(dbuf, bk, lx_.data() + l_diag_[k])) return false;
  }
  return true;
}

void BlockCholesky::Solve(const double* b, double* x) const {
  if (!factorized_) throw Error("block Cholesky: Solve before a successful Factorize");
  double* y = work_.data() + static_cast<std::size_t>(n_) * max_size_;
  for (int k = 0; k < nb_; ++k) {
    std::memcpy(y + off_[k], b + orig_off_[perm_[k]], sizeof(double) * Size(k));
  }
  WithBlockSize(uniform_, [this, y](auto b) { SolveBlocks<decltype(b)::value>(y); });
  for (int k = 0; k < nb_; ++k) {
    std::memcpy(x + orig_off_[perm_[k]], y + off_[k], sizeof(double) * Size(k));
  }
}

template <int B>
void BlockCholesky::SolveBlocks(double* y) const {
  using Vec = Eigen::Map<Eigen::Matrix<double, B, 1>>;
  // L z = y, column by column.
  for (int i = 0; i < nb_; ++i) {
    const int bi = Size(i);
    Vec yi(y + off_[i], bi);
    yi = ConstBlock<B, B>(lx_.data() + l_diag_[i], bi, bi) * yi;
    for (int p = l_colptr_[i]; p < l_colptr_[i + 1]; ++p) {
      const int r = l_row_[p], br = Size(r);
      Vec(y + off_[r], br).noalias() -= ConstBlock<B, B>(lx_.data() + l_val_[p], br, bi) * yi;
    }
  }
  // L^T x = z, backwards.
  for (int i = nb_ - 1; i >= 0; --i) {
    const int bi = Size(i);
    Vec yi(y + off_[i], bi);
    for (int p = l_colptr_[i]; p < l_colptr_[i + 1]; ++p) {
      const int r = l_row_[p], br = Size(r);
      yi.noalias() -= ConstBlock<B, B>(lx_.data() + l_val_[p], br, bi).transpose() * Vec(y + off_[r], br);
    }
    yi = ConstBlock<B, B>(lx_.data() + l_diag_[i], bi, bi).transpose() * yi;
  }
}

}  // namespace internal
}  // namespace tether

namespace tether {
namespace internal {

namespace {

// The block Cholesky as a LinearSolver ("block").
class BlockCholeskySolver : public LinearSolver {
 public:
  void Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) override {
    chol_.Analyze(a, block_sizes);
  }
  LinearSolverStatus Factorize(const SparseMatrixView& a) override {
    return chol_.Factorize(a) ? LinearSolverStatus::kOk : LinearSolverStatus::kNotPositiveDefinite;
  }
  LinearSolverStatus Solve(const double* b, double* x) override {
    chol_.Solve(b, x);
    return LinearSolverStatus::kOk;
  }
  std::string Description() const override { return Describe(chol_); }

  static std::string Describe(const BlockCholesky& c) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "block Cholesky (%d blocks of L on the diagonal, %lld below; %.1f updates per block)", c.num_blocks(),
                  static_cast<long long>(c.off_diagonal_blocks()), c.UpdatesPerBlock());
    return buf;
  }

 private:
  BlockCholesky chol_;
};

// "auto": the block Cholesky where the analysis finds the factor sparse and the blocks of one
// size (kMaxBlockUpdatesPerBlock), CHOLMOD (which picks simplicial or supernodal itself)
// otherwise.
class AutoCholesky : public LinearSolver {
 public:
  void Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) override {
    cholmod_.reset();
    block_ = std::make_unique<BlockCholesky>();
    // The analysis stops as soon as the rule says no; the factor's storage only where it is kept.
    if (!block_->Analyze(a, block_sizes, /*allocate=*/false, kMaxBlockUpdatesPerBlock, /*require_uniform=*/true)) {
      why_ = block_->uniform_size() == 0 ? "blocks of several sizes" : "a dense factor";
      char buf[64];
      std::snprintf(buf, sizeof buf, " (%.1f updates per block)", block_->UpdatesPerBlock());
      if (block_->uniform_size() != 0) why_ += buf;
      // The block ordering is as good as CHOLMOD's own on the scalars, and already paid for.
      cholmod_ = MakeCholmod(block_->ScalarOrdering());
      block_.reset();
      cholmod_->Analyze(a, block_sizes);
    } else {
      block_->Allocate();
    }
  }
  LinearSolverStatus Factorize(const SparseMatrixView& a) override {
    if (cholmod_) return cholmod_->Factorize(a);
    return block_->Factorize(a) ? LinearSolverStatus::kOk : LinearSolverStatus::kNotPositiveDefinite;
  }
  LinearSolverStatus Solve(const double* b, double* x) override {
    if (cholmod_) return cholmod_->Solve(b, x);
    block_->Solve(b, x);
    return LinearSolverStatus::kOk;
  }
  std::string Description() const override {
    if (cholmod_) return cholmod_->Description() + ", for " + why_;
    if (block_) return BlockCholeskySolver::Describe(*block_);
    return "block Cholesky or CHOLMOD (not analysed yet)";
  }

 private:
  std::unique_ptr<BlockCholesky> block_;
  std::unique_ptr<LinearSolver> cholmod_;
  std::string why_;
};

}  // namespace

std::unique_ptr<LinearSolver> MakeBlockCholesky() { return std::make_unique<BlockCholeskySolver>(); }
std::unique_ptr<LinearSolver> MakeAutoCholesky() { return std::make_unique<AutoCholesky>(); }

}  // namespace internal
}  // namespace tether
