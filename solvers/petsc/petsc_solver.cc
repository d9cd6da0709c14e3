// libtether_petsc.so: the linear solvers "petsc" (MUMPS's sparse Cholesky over every process of
// an MPI job) and "petsc-iterative" (conjugate gradients preconditioned with PETSc's algebraic
// multigrid, GAMG), and the start of MPI and PETSc. Loaded by libtether_solvers at the first
// use (../src/distributed.cc, ../src/petsc_module.h).
//
// Every process holds the whole normal-equation matrix H (each runs the same solve). The
// variables are split by a METIS k-way partition of their graph (weighted by their tangent
// sizes), computed on the first process and sent to the others; PETSc numbers them part after
// part, so that each process owns a contiguous range of block rows, and each process sets only
// the blocks of its own rows (MatSetValuesBlocked). The pattern is analysed once (Analyze);
// every Factorize sets the values into the same PETSc matrix, whose unchanged nonzero pattern
// lets PETSc and MUMPS keep the symbolic factorisation. The step comes back whole to every
// process (a scatter to all).
#include <metis.h>
#include <petscksp.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "../src/petsc_module.h"
#include "tether/core/error.h"

namespace tether {
namespace petsc {
namespace {

// PETSc's own words for the first error of a failing call ("Unknown KSP type: no_such_method"),
// kept by the error handler (Start) for Check.
std::string last_error;

PetscErrorCode KeepError(MPI_Comm, int, const char*, const char*, PetscErrorCode code, PetscErrorType type,
                         const char* message, void*) {
  if (type == PETSC_ERROR_INITIAL) last_error = message != nullptr ? message : "";
  return code;
}

// Throws tether::Error naming the PETSc call that failed and PETSc's reason.
void Check(PetscErrorCode code, const char* call) {
  if (code == 0) return;
  std::string text = last_error;
  last_error.clear();
  if (text.empty()) {
    const char* generic = nullptr;
    PetscErrorMessage(code, &generic, nullptr);
    text = generic != nullptr ? generic : "unknown error";
  }
  throw Error(std::string("PETSc: ") + call + " failed: " + text + " (error " + std::to_string(static_cast<int>(code)) +
              ")");
}
#define TETHER_PETSC(call) Check((call), #call)

bool started = false;
int rank = 0;
int size = 1;

void Finish() {
  PetscBool finalized = PETSC_FALSE;
  PetscFinalized(&finalized);
  if (!finalized) PetscFinalize();
}

// PETSc's options from one string, split at white space, behind a program name; PETSc keeps
// the pointers, so they live as long as the process.
std::vector<char*>* Arguments(const std::string& options) {
  static std::vector<std::string> words;
  static std::vector<char*> argv;
  words.assign(1, "tether");
  // PETSc's own handlers would take SIGSEGV and SIGFPE from the program (and from sanitizers).
  words.push_back("-no_signal_handler");
  std::istringstream in(options);
  for (std::string w; in >> w;) words.push_back(w);
  argv.clear();
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  return &argv;
}

bool Start(const std::string& options, int* rank_out, int* size_out, std::string* why) {
  if (!started) {
    std::istringstream in(options);
    for (std::string w; in >> w;) {
      if (w.find('\n') != std::string::npos) {
        *why = "a PETSc option holds a line break";
        return false;
      }
    }
    std::vector<char*>* argv = Arguments(options);
    int argc = static_cast<int>(argv->size()) - 1;
    char** args = argv->data();
    const PetscErrorCode code = PetscInitialize(&argc, &args, nullptr, nullptr);
    if (code != 0) {
      *why = "PetscInitialize failed (error " + std::to_string(static_cast<int>(code)) +
             "): check the PETSc options and that the program runs under mpirun (or alone)";
      return false;
    }
    // Errors come back as codes, turned into tether::Error with PETSc's message, not printed.
    PetscPushErrorHandler(KeepError, nullptr);
    MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
    MPI_Comm_size(PETSC_COMM_WORLD, &size);
    std::atexit(Finish);
    started = true;
  }
  *rank_out = rank;
  *size_out = size;
  return true;
}

void Abort(int exit_code) { MPI_Abort(PETSC_COMM_WORLD, exit_code); }

// A METIS k-way partition of the variables' graph (an edge where H has a block), weighted by
// the variables' tangent sizes, into `parts`: part[v] for each variable, computed on the first
// process and sent to the others (so that all use one even where METIS's arithmetic differed).
// Returns METIS's edge cut (0 for one part).
int PartitionVariables(const SparseMatrixView& a, const std::vector<int>& col_var, const std::vector<int>& block_sizes,
                       int parts, std::vector<int>* part) {
  const int nv = static_cast<int>(block_sizes.size());
  part->assign(nv, 0);
  int cut = 0;
  if (parts > 1 && nv > 0) {
    if (rank == 0) {
      std::vector<std::vector<idx_t>> adj(nv);
      for (int c = 0; c < a.cols; ++c) {
        for (int k = a.colptr[c]; k < a.colptr[c + 1]; ++k) {
          const int u = col_var[a.rowind[k]], v = col_var[c];
          if (u == v) continue;
          adj[u].push_back(v);
          adj[v].push_back(u);
        }
      }
      std::vector<idx_t> xadj(1, 0), adjncy, vwgt(block_sizes.begin(), block_sizes.end());
      for (std::vector<idx_t>& l : adj) {
        std::sort(l.begin(), l.end());
        l.erase(std::unique(l.begin(), l.end()), l.end());
        adjncy.insert(adjncy.end(), l.begin(), l.end());
        xadj.push_back(static_cast<idx_t>(adjncy.size()));
        std::vector<idx_t>().swap(l);
      }
      idx_t n = nv, ncon = 1, np = parts, objval = 0;
      idx_t opts[METIS_NOPTIONS];
      METIS_SetDefaultOptions(opts);
      opts[METIS_OPTION_SEED] = 1;  // the same partition on every run
      std::vector<idx_t> p(nv, 0);
      int status = METIS_OK;
      if (nv >= parts && !adjncy.empty()) {
        status = METIS_PartGraphKway(&n, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, nullptr, &np, nullptr,
                                     nullptr, opts, &objval, p.data());
      } else {
        for (int v = 0; v < nv; ++v) p[v] = static_cast<idx_t>(static_cast<long>(v) * parts / nv);
      }
      if (status != METIS_OK) {
        // A partition is only about speed: fall back to contiguous ranges of the columns.
        for (int v = 0; v < nv; ++v) p[v] = static_cast<idx_t>(static_cast<long>(v) * parts / nv);
        objval = -1;
      }
      std::copy(p.begin(), p.end(), part->begin());
      cut = static_cast<int>(objval);
    }
    MPI_Bcast(part->data(), nv, MPI_INT, 0, PETSC_COMM_WORLD);
    MPI_Bcast(&cut, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  }
  return cut;
}

class PetscSolver : public LinearSolver {
 public:
  PetscSolver(const LinearSolverOptions& o, bool iterative) : options_(o), iterative_(iterative) {}

  ~PetscSolver() override {
    PetscBool finalized = PETSC_FALSE;
    PetscFinalized(&finalized);
    if (finalized) return;
    if (scatter_ != nullptr) VecScatterDestroy(&scatter_);
    if (x_all_ != nullptr) VecDestroy(&x_all_);
    if (x_ != nullptr) VecDestroy(&x_);
    if (b_ != nullptr) VecDestroy(&b_);
    if (ksp_ != nullptr) KSPDestroy(&ksp_);
    if (mat_ != nullptr) MatDestroy(&mat_);
  }

  void Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) override;
  LinearSolverStatus Factorize(const SparseMatrixView& a) override;
  LinearSolverStatus Solve(const double* b, double* x) override;
  std::string Description() const override { return description_; }
  int last_iterations() const override { return last_iterations_; }
  void AgreeAcrossProcesses(double* values, int n) override {
    if (size > 1 && n > 0) MPI_Bcast(values, n, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
  }

 private:
  void Number(const std::vector<int>& block_sizes, const std::vector<int>& part);
  void CollectBlocks(const SparseMatrixView& a);
  void CreateMatrix();
  void CreateSolver();

  LinearSolverOptions options_;
  bool iterative_;
  int n_ = 0;
  int bs_ = 1;                       // PETSc's block size: the variables' one size, or 1 where they differ
  std::vector<int> new_col_;         // PETSc's index of each column of H
  std::vector<int> old_col_;         // and back
  int own_begin_ = 0, own_end_ = 0;  // this process's columns in PETSc's numbering
  // The blocks this process sets: block row and column (PETSc's numbering) and, for each of
  // the bs x bs entries (row-major), its position in H's values (-1: zero).
  std::vector<int> block_row_, block_col_, block_slot_;
  std::vector<double> buffer_;
  int edge_cut_ = 0;
  Mat mat_ = nullptr;
  KSP ksp_ = nullptr;
  Vec b_ = nullptr, x_ = nullptr, x_all_ = nullptr;
  VecScatter scatter_ = nullptr;
  bool set_up_ = false;
  int last_iterations_ = 0;
  std::string description_;
};

void PetscSolver::Analyze(const SparseMatrixView& a, const std::vector<int>& block_sizes) {
  n_ = a.cols;
  std::vector<int> col_var(n_, 0);
  int at = 0;
  for (std::size_t v = 0; v < block_sizes.size(); ++v) {
    for (int i = 0; i < block_sizes[v]; ++i) {
      if (at >= n_) throw Error("petsc: the block sizes add up to more than H's " + std::to_string(n_) + " columns");
      col_var[at++] = static_cast<int>(v);
    }
  }
  if (at != n_)
    throw Error("petsc: the block sizes add up to " + std::to_string(at) + ", not H's " + std::to_string(n_));
  bs_ = block_sizes.empty() ? 1 : block_sizes[0];
  for (int d : block_sizes) {
    if (d != bs_) bs_ = 1;
  }
  std::vector<int> part;
  edge_cut_ = PartitionVariables(a, col_var, block_sizes, size, &part);
  Number(block_sizes, part);
  CollectBlocks(a);
  CreateMatrix();
  CreateSolver();
}

// PETSc's numbering: the variables part after part (in their order within a part), so that
// process r owns the columns of part r.
void PetscSolver::Number(const std::vector<int>& block_sizes, const std::vector<int>& part) {
  const int nv = static_cast<int>(block_sizes.size());
  std::vector<int> start(nv + 1, 0);
  for (int v = 0; v < nv; ++v) start[v + 1] = start[v] + block_sizes[v];
  std::vector<int> order(nv);
  for (int v = 0; v < nv; ++v) order[v] = v;
  std::stable_sort(order.begin(), order.end(), [&part](int u, int v) { return part[u] < part[v]; });
  new_col_.assign(n_, 0);
  old_col_.assign(n_, 0);
  int next = 0;
  own_begin_ = own_end_ = -1;
  for (int v : order) {
    if (part[v] == rank && own_begin_ < 0) own_begin_ = next;
    for (int i = 0; i < block_sizes[v]; ++i) {
      new_col_[start[v] + i] = next;
      old_col_[next] = start[v] + i;
      ++next;
    }
    if (part[v] == rank) own_end_ = next;
  }
  if (own_begin_ < 0) {  // no variable here: an empty range where the part would begin
    int before = 0;
    for (int v = 0; v < nv; ++v) before += part[v] < rank ? block_sizes[v] : 0;
    own_begin_ = own_end_ = before;
  }
}

// The blocks of this process's rows: the upper triangle for MUMPS's symmetric Cholesky
// (diagonal blocks whole), both triangles for the iterative solver.
void PetscSolver::CollectBlocks(const SparseMatrixView& a) {
  const int bs2 = bs_ * bs_;
  std::unordered_map<long long, int> index;
  auto slot = [&](int row, int col) -> int* {
    const int br = row / bs_, bc = col / bs_;
    const long long key = static_cast<long long>(br) * (n_ / bs_) + bc;
    auto [it, added] = index.emplace(key, static_cast<int>(block_row_.size()));
    if (added) {
      block_row_.push_back(br);
      block_col_.push_back(bc);
      block_slot_.insert(block_slot_.end(), bs2, -1);
    }
    return &block_slot_[static_cast<std::size_t>(it->second) * bs2 + (row % bs_) * bs_ + col % bs_];
  };
  auto mine = [this](int row) { return row >= own_begin_ && row < own_end_; };
  for (int c = 0; c < a.cols; ++c) {
    for (int k = a.colptr[c]; k < a.colptr[c + 1]; ++k) {
      const int r = a.rowind[k];
      if (r > c) continue;  // below the diagonal: H is given by its upper triangle
      const int nr = new_col_[r], nc = new_col_[c];
      const int lo = std::min(nr, nc), hi = std::max(nr, nc);
      const bool same_block = lo / bs_ == hi / bs_;
      if (mine(lo)) *slot(lo, hi) = k;
      if ((iterative_ || same_block) && lo != hi && mine(hi)) *slot(hi, lo) = k;
    }
  }
  // Sorted by row, then column: PETSc inserts a row's blocks in order fastest.
  std::vector<int> order(block_row_.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [this](int x, int y) {
    return block_row_[x] != block_row_[y] ? block_row_[x] < block_row_[y] : block_col_[x] < block_col_[y];
  });
  std::vector<int> rows(order.size()), cols(order.size()), slots(block_slot_.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    rows[i] = block_row_[order[i]];
    cols[i] = block_col_[order[i]];
    std::copy_n(&block_slot_[static_cast<std::size_t>(order[i]) * bs2], bs2, &slots[i * bs2]);
  }
  block_row_.swap(rows);
  block_col_.swap(cols);
  block_slot_.swap(slots);
  buffer_.assign(bs2, 0.0);
}

void PetscSolver::CreateMatrix() {
  const int local = own_end_ - own_begin_;
  const int first_block = own_begin_ / bs_, blocks = local / bs_;
  // Blocks per row inside this process's columns (d) and outside them (o).
  std::vector<PetscInt> d(blocks, 0), o(blocks, 0);
  for (std::size_t i = 0; i < block_row_.size(); ++i) {
    const int row = block_row_[i] - first_block;
    const bool inside = block_col_[i] >= first_block && block_col_[i] < first_block + blocks;
    ++(inside ? d : o)[row];
  }
  TETHER_PETSC(MatCreate(PETSC_COMM_WORLD, &mat_));
  TETHER_PETSC(MatSetSizes(mat_, local, local, n_, n_));
  TETHER_PETSC(MatSetType(mat_, iterative_ ? MATAIJ : MATSBAIJ));
  TETHER_PETSC(MatSetBlockSize(mat_, bs_));
  if (iterative_) {
    TETHER_PETSC(MatXAIJSetPreallocation(mat_, bs_, d.data(), o.data(), nullptr, nullptr));
  } else {
    TETHER_PETSC(MatXAIJSetPreallocation(mat_, bs_, nullptr, nullptr, d.data(), o.data()));
    TETHER_PETSC(MatSetOption(mat_, MAT_IGNORE_LOWER_TRIANGULAR, PETSC_TRUE));
  }
  TETHER_PETSC(MatSetOption(mat_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  TETHER_PETSC(MatSetOption(mat_, MAT_SPD, PETSC_TRUE));
  TETHER_PETSC(MatCreateVecs(mat_, &x_, &b_));
  TETHER_PETSC(VecScatterCreateToAll(x_, &scatter_, &x_all_));
}

void PetscSolver::CreateSolver() {
  TETHER_PETSC(KSPCreate(PETSC_COMM_WORLD, &ksp_));
  TETHER_PETSC(KSPSetOperators(ksp_, mat_, mat_));
  PC pc = nullptr;
  TETHER_PETSC(KSPGetPC(ksp_, &pc));
  if (iterative_) {
    TETHER_PETSC(KSPSetType(ksp_, KSPCG));
    TETHER_PETSC(PCSetType(pc, PCGAMG));
    const PetscInt max_it = options_.iterative_max_iterations > 0 ? options_.iterative_max_iterations : 10000;
    TETHER_PETSC(KSPSetTolerances(ksp_, options_.iterative_tolerance, 0.0, PETSC_DEFAULT, max_it));
  } else {
    TETHER_PETSC(KSPSetType(ksp_, KSPPREONLY));
    TETHER_PETSC(PCSetType(pc, PCCHOLESKY));
    TETHER_PETSC(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  // The user's PETSc options (StartDistributed, PETSC_OPTIONS) come last and win.
  TETHER_PETSC(KSPSetFromOptions(ksp_));
  KSPType kt = nullptr;
  PCType pt = nullptr;
  TETHER_PETSC(KSPGetType(ksp_, &kt));
  TETHER_PETSC(PCGetType(pc, &pt));
  std::string what = std::string("PETSc ") + (kt != nullptr ? kt : "?") + " + " + (pt != nullptr ? pt : "?");
  MatSolverType st = nullptr;
  if (pt != nullptr && (std::strcmp(pt, PCCHOLESKY) == 0 || std::strcmp(pt, PCLU) == 0)) {
    TETHER_PETSC(PCFactorGetMatSolverType(pc, &st));
    if (st != nullptr) what += std::string(" (") + st + ")";
  }
  char buf[200];
  std::snprintf(buf, sizeof buf, " on %d process%s, METIS k-way (edge cut %d), block size %d", size,
                size == 1 ? "" : "es", edge_cut_, bs_);
  description_ = what + buf;
}

LinearSolverStatus PetscSolver::Factorize(const SparseMatrixView& a) {
  const int bs2 = bs_ * bs_;
  for (std::size_t i = 0; i < block_row_.size(); ++i) {
    const int* s = &block_slot_[i * bs2];
    for (int e = 0; e < bs2; ++e) buffer_[e] = s[e] >= 0 ? a.values[s[e]] : 0.0;
    const PetscInt row = block_row_[i], col = block_col_[i];
    TETHER_PETSC(MatSetValuesBlocked(mat_, 1, &row, 1, &col, buffer_.data(), INSERT_VALUES));
  }
  TETHER_PETSC(MatAssemblyBegin(mat_, MAT_FINAL_ASSEMBLY));
  TETHER_PETSC(MatAssemblyEnd(mat_, MAT_FINAL_ASSEMBLY));
  // The values changed, not the pattern: PETSc keeps the symbolic factorisation (or GAMG its
  // hierarchy's structure) and redoes the numeric part.
  TETHER_PETSC(KSPSetUp(ksp_));
  set_up_ = true;
  PC pc = nullptr;
  TETHER_PETSC(KSPGetPC(ksp_, &pc));
  PCFailedReason reason = PC_NOERROR;
  TETHER_PETSC(PCGetFailedReasonRank(pc, &reason));
  int failed = reason != PC_NOERROR ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
  if (failed != 0) return LinearSolverStatus::kNotPositiveDefinite;
  return LinearSolverStatus::kOk;
}

LinearSolverStatus PetscSolver::Solve(const double* b, double* x) {
  if (!set_up_) throw Error("petsc: Solve before Factorize");
  PetscScalar* local = nullptr;
  TETHER_PETSC(VecGetArray(b_, &local));
  for (int k = own_begin_; k < own_end_; ++k) local[k - own_begin_] = b[old_col_[k]];
  TETHER_PETSC(VecRestoreArray(b_, &local));
  TETHER_PETSC(KSPSolve(ksp_, b_, x_));
  KSPConvergedReason reason = KSP_CONVERGED_ITERATING;
  TETHER_PETSC(KSPGetConvergedReason(ksp_, &reason));
  PetscInt its = 0;
  TETHER_PETSC(KSPGetIterationNumber(ksp_, &its));
  last_iterations_ = iterative_ ? static_cast<int>(its) : 0;
  // Out of iterations: the best x so far, which the step strategy judges by its decrease of
  // chi2 (as the pcg plugin does). Any other divergence is a failure.
  if (reason < 0 && reason != KSP_DIVERGED_ITS) {
    return reason == KSP_DIVERGED_PC_FAILED || reason == KSP_DIVERGED_INDEFINITE_PC ||
                   reason == KSP_DIVERGED_INDEFINITE_MAT
               ? LinearSolverStatus::kNotPositiveDefinite
               : LinearSolverStatus::kFailed;
  }
  TETHER_PETSC(VecScatterBegin(scatter_, x_, x_all_, INSERT_VALUES, SCATTER_FORWARD));
  TETHER_PETSC(VecScatterEnd(scatter_, x_, x_all_, INSERT_VALUES, SCATTER_FORWARD));
  const PetscScalar* all = nullptr;
  TETHER_PETSC(VecGetArrayRead(x_all_, &all));
  for (int c = 0; c < n_; ++c) x[c] = all[new_col_[c]];
  TETHER_PETSC(VecRestoreArrayRead(x_all_, &all));
  return LinearSolverStatus::kOk;
}

std::unique_ptr<LinearSolver> MakeSolver(const LinearSolverOptions& options, bool iterative) {
  if (!started) throw Error("petsc: a solver was made before MPI and PETSc started (StartDistributed)");
  return std::make_unique<PetscSolver>(options, iterative);
}

}  // namespace
}  // namespace petsc
}  // namespace tether

extern "C" const tether::internal::PetscTable* tether_petsc_v1() {
  static const tether::internal::PetscTable table = [] {
    tether::internal::PetscTable t;
    t.start = tether::petsc::Start;
    t.make_solver = tether::petsc::MakeSolver;
    t.abort = tether::petsc::Abort;
    return t;
  }();
  return &table;
}
