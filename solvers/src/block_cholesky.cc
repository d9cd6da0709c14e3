#include "block_cholesky.h"

#include <camd.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
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

// The last block pattern analysed in this process and its analysis: the chordal start and the
// solve after it (and any later solve of the same graph) analyse the same pose graph, and all
// but the first find the ordering and the factor's pattern done. One entry: a pattern is
// compared in full (O(its blocks)), never by a hash.
std::mutex last_mutex;
std::shared_ptr<const BlockSymbolic> last_symbolic;

}  // namespace

struct BlockSymbolic {
  std::vector<int> up, ui;               // the key: A's upper block pattern (rows I < J of each column J, sorted)
  std::vector<int> perm, pinv;           // block k of the permuted matrix is block perm[k] of A
  std::vector<int> a_colptr, a_row;      // the permuted upper block pattern (rows unsorted)
  std::vector<int> upos;                 // where each block (up, ui) went in it
  std::vector<int> parent;               // the elimination tree
  std::vector<int> r_rowptr, l_colptr;   // row k of L has r_rowptr[k+1]-r_rowptr[k] blocks, column i ...
  std::vector<int> r_col, l_row;         // ... and which: only where `stored`
  bool counted = false, stored = false;  // a_colptr .. l_colptr are there; r_col, l_row are there
  // Kept where the arrays are not: what the density rule and the reports read.
  double updates_per_block = 0;
  std::int64_t l_blocks = 0;  // blocks of L below the diagonal
};

namespace {

std::shared_ptr<const BlockSymbolic> RecallSymbolic(const std::vector<int>& up, const std::vector<int>& ui) {
  std::lock_guard<std::mutex> lock(last_mutex);
  if (last_symbolic && last_symbolic->up == up && last_symbolic->ui == ui) return last_symbolic;
  return nullptr;
}

void RememberSymbolic(std::shared_ptr<const BlockSymbolic> s) {
  std::lock_guard<std::mutex> lock(last_mutex);
  last_symbolic = std::move(s);
}

// Row k's columns of L (below the diagonal) at stack[top .. nb), returned top: the reach of A's
// column k in the elimination tree, a column before its ancestors.
int Reach(const BlockSymbolic& s, int k, std::vector<int>* flag, std::vector<int>* stack) {
  const int nb = static_cast<int>(s.perm.size());
  (*flag)[k] = k;
  int top = nb;
  for (int p = s.a_colptr[k]; p < s.a_colptr[k + 1]; ++p) {
    int len = 0;
    for (int i = s.a_row[p]; (*flag)[i] != k; i = s.parent[i]) {
      (*stack)[len++] = i;
      (*flag)[i] = k;
    }
    while (len > 0) (*stack)[--top] = (*stack)[--len];
  }
  return top;
}

// The ordering: CAMD on the block graph.
std::shared_ptr<BlockSymbolic> Order(int nb, std::vector<int> up, std::vector<int> ui) {
  auto sp = std::make_shared<BlockSymbolic>();
  BlockSymbolic& s = *sp;
  s.up = std::move(up);
  s.ui = std::move(ui);
  s.perm.resize(nb);
  std::iota(s.perm.begin(), s.perm.end(), 0);
  if (nb > 1 && !s.ui.empty()) {
    double control[CAMD_CONTROL], info[CAMD_INFO];
    camd_defaults(control);
    std::vector<int> p(nb + 1);
    const int status = camd_order(nb, s.up.data(), s.ui.data(), p.data(), control, info, nullptr);
    if (status == CAMD_OK || status == CAMD_OK_BUT_JUMBLED) std::copy(p.begin(), p.begin() + nb, s.perm.begin());
  }
  s.pinv.resize(nb);
  for (int k = 0; k < nb; ++k) s.pinv[s.perm[k]] = k;
  return sp;
}

// The permuted pattern, the elimination tree and how many blocks each row and column of L has
// (not yet which: StorePattern), and from those how dense the factor is.
void Count(BlockSymbolic* sp) {
  BlockSymbolic& s = *sp;
  const int nb = static_cast<int>(s.perm.size());
  s.a_colptr.assign(nb + 1, 0);
  for (int J = 0; J < nb; ++J) {
    for (int q = s.up[J]; q < s.up[J + 1]; ++q) ++s.a_colptr[std::max(s.pinv[s.ui[q]], s.pinv[J]) + 1];
  }
  for (int k = 0; k < nb; ++k) s.a_colptr[k + 1] += s.a_colptr[k];
  s.a_row.assign(s.a_colptr[nb], 0);
  s.upos.resize(s.ui.size());
  {
    std::vector<int> next(s.a_colptr.begin(), s.a_colptr.end() - 1);
    for (int J = 0; J < nb; ++J) {
      for (int q = s.up[J]; q < s.up[J + 1]; ++q) {
        const int i = s.pinv[s.ui[q]], j = s.pinv[J];
        s.upos[q] = next[std::max(i, j)]++;
        s.a_row[s.upos[q]] = std::min(i, j);
      }
    }
  }
  s.parent = EliminationTree(nb, s.a_colptr, s.a_row);
  std::vector<int> count(nb, 0), flag(nb, -1), stack(nb);
  s.r_rowptr.assign(nb + 1, 0);
  for (int k = 0; k < nb; ++k) {
    const int top = Reach(s, k, &flag, &stack);
    for (int t = top; t < nb; ++t) ++count[stack[t]];
    s.r_rowptr[k + 1] = s.r_rowptr[k] + (nb - top);
  }
  s.l_colptr.assign(nb + 1, 0);
  for (int i = 0; i < nb; ++i) s.l_colptr[i + 1] = s.l_colptr[i] + count[i];
  double updates = 0, blocks = 0;
  for (int j = 0; j < nb; ++j) {
    const double c = 1.0 + count[j];
    updates += c * c;
    blocks += c;
  }
  s.updates_per_block = blocks > 0 ? updates / blocks : 0;
  s.l_blocks = s.l_colptr[nb];
  s.counted = true;
}

// What an analysis that stopped at the density rule keeps for the next one of the same
// pattern: the ordering and the density (a dense pose graph of a million poses would otherwise
// hold some 100 MB of counts through the whole solve).
void Trim(BlockSymbolic* s) {
  for (std::vector<int>* v : {&s->a_colptr, &s->a_row, &s->upos, &s->parent, &s->r_rowptr, &s->l_colptr}) {
    std::vector<int>().swap(*v);
  }
  s->counted = false;
}

// Which blocks L has: each row's columns (in the order the factorisation visits them) and each
// column's rows.
void StorePattern(BlockSymbolic* sp) {
  BlockSymbolic& s = *sp;
  const int nb = static_cast<int>(s.perm.size());
  std::vector<int> flag(nb, -1), stack(nb);
  s.r_col.resize(s.r_rowptr[nb]);
  for (int k = 0; k < nb; ++k) {
    const int top = Reach(s, k, &flag, &stack);
    std::copy(stack.begin() + top, stack.end(), s.r_col.begin() + s.r_rowptr[k]);
  }
  s.l_row.assign(s.l_colptr[nb], 0);
  std::vector<int> next(s.l_colptr.begin(), s.l_colptr.end() - 1);
  for (int k = 0; k < nb; ++k) {
    for (int t = s.r_rowptr[k]; t < s.r_rowptr[k + 1]; ++t) s.l_row[next[s.r_col[t]]++] = k;
  }
  s.stored = true;
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
  sym_.reset();
  reused_ = false;
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
  std::shared_ptr<const BlockSymbolic> sym = RecallSymbolic(up, ui);
  std::shared_ptr<BlockSymbolic> fresh;
  reused_ = sym != nullptr;
  if (sym == nullptr) {
    fresh = Order(nb_, std::move(up), std::move(ui));
    Count(fresh.get());
    sym = fresh;
  }
  sym_ = sym;
  ordered_ = true;
  size_.assign(nb_, 0);
  off_.assign(nb_ + 1, 0);
  for (int k = 0; k < nb_; ++k) {
    size_[k] = sizes[sym->perm[k]];
    off_[k + 1] = off_[k] + size_[k];
  }
  max_size_ = size_.empty() ? 0 : *std::max_element(size_.begin(), size_.end());
  if (UpdatesPerBlock() > max_updates_per_block) {
    if (fresh) {
      Trim(fresh.get());
      RememberSymbolic(fresh);
    }
    return false;
  }
  if (!sym->stored) {
    if (!fresh) {  // ordered (and perhaps counted) before, stored now
      fresh = std::make_shared<BlockSymbolic>(*sym);
      if (!fresh->counted) Count(fresh.get());
    }
    StorePattern(fresh.get());
    sym_ = fresh;
  }
  if (fresh) RememberSymbolic(fresh);
  const BlockSymbolic& S = *sym_;

  ax_size_ = BlockOffsets(S.a_colptr, S.a_row, size_, &a_diag_, &a_val_);
  // Each scalar of A's upper triangle: its place in ax_. A column's rows are sorted, so its
  // blocks come in the order of the block column's upper pattern (a search where they are not).
  scatter_.assign(a.colptr[n_], -1);
  for (int c = 0; c < n_; ++c) {
    const int J = block_of[c], lc = c - orig_off_[J], j = S.pinv[J];
    int q = S.up[J];
    for (int p = a.colptr[c]; p < a.colptr[c + 1]; ++p) {
      const int r = a.rowind[p], I = block_of[r], lr = r - orig_off_[I];
      if (I > J || (I == J && lr > lc)) continue;  // below the diagonal: ignored
      if (I == J) {
        scatter_[p] = a_diag_[j] + lr + static_cast<std::int64_t>(lc) * size_[j];
        continue;
      }
      while (q < S.up[J + 1] && S.ui[q] != I) ++q;
      if (q == S.up[J + 1])
        q = static_cast<int>(std::lower_bound(S.ui.begin() + S.up[J], S.ui.begin() + S.up[J + 1], I) - S.ui.begin());
      const int i = S.pinv[I];
      // Block (i, j) of the permuted matrix, or where i > j its mirror (j, i), transposed.
      scatter_[p] = i < j ? a_val_[S.upos[q]] + lr + static_cast<std::int64_t>(lc) * size_[i]
                          : a_val_[S.upos[q]] + lc + static_cast<std::int64_t>(lr) * size_[j];
    }
  }

  lx_size_ = BlockOffsets(S.l_colptr, S.l_row, size_, &l_diag_, &l_val_);
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
  const BlockSymbolic& S = *sym_;
  order.reserve(n_);
  for (int k = 0; k < nb_; ++k) {
    for (int c = orig_off_[S.perm[k]]; c < orig_off_[S.perm[k] + 1]; ++c) order.push_back(c);
  }
  return order;
}

std::int64_t BlockCholesky::off_diagonal_blocks() const { return sym_ ? sym_->l_blocks : 0; }

double BlockCholesky::UpdatesPerBlock() const { return sym_ ? sym_->updates_per_block : 0; }

// Column i of L has c_i blocks below the diagonal, each b x b (b: the blocks' mean size). The
// up-looking factorisation multiplies two blocks of a column for every pair of its blocks
// (c_i (c_i - 1) / 2 products), scales each block by the inverted diagonal block and takes it
// off the diagonal of its row (2 c_i products), and inverts each diagonal block (b^3); a block
// product is 2 b^3 operations. A solve multiplies every block of L once going down and once
// going up, 2 b^2 operations each.
double BlockCholesky::FactorizeFlops() const {
  if (!complete_ || nb_ == 0) return 0;
  const double b = static_cast<double>(n_) / nb_;
  double products = 0;
  for (int i = 0; i < nb_; ++i) {
    const double c = sym_->l_colptr[i + 1] - sym_->l_colptr[i];
    products += c * (c - 1) / 2 + 2 * c;
  }
  return 2 * b * b * b * products + nb_ * b * b * b;
}

double BlockCholesky::SolveFlops() const {
  if (!complete_ || nb_ == 0) return 0;
  const double b = static_cast<double>(n_) / nb_;
  return 4 * b * b * (nb_ + static_cast<double>(sym_->l_colptr.back()));
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
  const BlockSymbolic& S = *sym_;
  double* x = work_.data();
  std::fill(fill_.begin(), fill_.end(), 0);
  double* dbuf = work_.data() + static_cast<std::size_t>(n_) * max_size_ + n_;
  for (int k = 0; k < nb_; ++k) {
    const int bk = Size(k);
    // Column k of A above the diagonal into the workspace, the diagonal block into d (its
    // lower triangle from the upper one).
    for (int p = S.a_colptr[k]; p < S.a_colptr[k + 1]; ++p) {
      const int i = S.a_row[p], bi = Size(i);
      Block<B, B>(x + x_off_[i], bi, bk) = ConstBlock<B, B>(ax_.data() + a_val_[p], bi, bk);
    }
    Block<B, B> d(dbuf, bk, bk);
    d = ConstBlock<B, B>(ax_.data() + a_diag_[k], bk, bk).template selfadjointView<Eigen::Upper>();
    for (int t = S.r_rowptr[k]; t < S.r_rowptr[k + 1]; ++t) {
      const int i = S.r_col[t], bi = Size(i);
      Block<B, B> xi(x + x_off_[i], bi, bk);
      // y = L_ii^{-1} x_i: the block L(k, i)^T.
      xi = ConstBlock<B, B>(lx_.data() + l_diag_[i], bi, bi) * xi;
      // The rows of column i already computed (rows below i, above k) take their share.
      const int p0 = S.l_colptr[i], p1 = p0 + fill_[i];
      for (int p = p0; p < p1; ++p) {
        const int r = S.l_row[p], br = Size(r);
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
  const BlockSymbolic& S = *sym_;
  double* y = work_.data() + static_cast<std::size_t>(n_) * max_size_;
  for (int k = 0; k < nb_; ++k) {
    std::memcpy(y + off_[k], b + orig_off_[S.perm[k]], sizeof(double) * Size(k));
  }
  WithBlockSize(uniform_, [this, y](auto b) { SolveBlocks<decltype(b)::value>(y); });
  for (int k = 0; k < nb_; ++k) {
    std::memcpy(x + orig_off_[S.perm[k]], y + off_[k], sizeof(double) * Size(k));
  }
}

template <int B>
void BlockCholesky::SolveBlocks(double* y) const {
  const BlockSymbolic& S = *sym_;
  using Vec = Eigen::Map<Eigen::Matrix<double, B, 1>>;
  // L z = y, column by column.
  for (int i = 0; i < nb_; ++i) {
    const int bi = Size(i);
    Vec yi(y + off_[i], bi);
    yi = ConstBlock<B, B>(lx_.data() + l_diag_[i], bi, bi) * yi;
    for (int p = S.l_colptr[i]; p < S.l_colptr[i + 1]; ++p) {
      const int r = S.l_row[p], br = Size(r);
      Vec(y + off_[r], br).noalias() -= ConstBlock<B, B>(lx_.data() + l_val_[p], br, bi) * yi;
    }
  }
  // L^T x = z, backwards.
  for (int i = nb_ - 1; i >= 0; --i) {
    const int bi = Size(i);
    Vec yi(y + off_[i], bi);
    for (int p = S.l_colptr[i]; p < S.l_colptr[i + 1]; ++p) {
      const int r = S.l_row[p], br = Size(r);
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
  double factorize_flops() const override { return chol_.FactorizeFlops(); }
  double solve_flops() const override { return chol_.SolveFlops(); }

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
  double factorize_flops() const override {
    return cholmod_ ? cholmod_->factorize_flops() : block_ ? block_->FactorizeFlops() : 0;
  }
  double solve_flops() const override { return cholmod_ ? cholmod_->solve_flops() : block_ ? block_->SolveFlops() : 0; }

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
