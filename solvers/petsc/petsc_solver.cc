// libtether_petsc.so: the linear solvers "petsc" (MUMPS's sparse Cholesky over every process of
// an MPI job) and "petsc-iterative" (conjugate gradients preconditioned with PETSc's algebraic
// multigrid, GAMG), and the start of MPI and PETSc. Loaded by libtether_solvers at the first
// use (../src/distributed.cc, ../src/petsc_module.h).
//
// Two ways to hand H over. Split (Partition was called: more than one process): the variables
// are split by a METIS k-way partition of their graph (weighted by their tangent sizes),
// computed on the first process and sent to the others; each process holds its share of H (its
// own factors') and adds every nonzero block of it into one PETSc matrix, PETSc sending the
// blocks of rows another process owns to it. Whole (the chordal start's systems, or one
// process): every process holds the whole H, partitions its block graph the same way and sets
// only the blocks of its own rows. Either way PETSc numbers the variables part after part, so
// that each process owns a contiguous range of block rows; the pattern is analysed once
// (Analyze), and every Factorize puts the values into the same PETSc matrix, whose unchanged
// nonzero pattern lets PETSc and MUMPS keep the symbolic factorisation. The step comes back
// whole to every process (a scatter to all).
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
#include "../src/problem.h"
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

// A METIS k-way partition of the variables' graph (compressed rows, no self-loops), weighted by
// the variables' tangent sizes, into `parts`: part[v] for each variable, computed on the first
// process and sent to the others (so that all use one even where METIS's arithmetic differed).
// Returns METIS's edge cut (0 for one part, -1 where METIS failed and contiguous ranges of the
// variables stand in: a partition is only about speed).
int PartitionVariables(const std::vector<int>& xadj_in, const std::vector<int>& adjacency,
                       const std::vector<int>& block_sizes, int parts, std::vector<int>* part) {
  const int nv = static_cast<int>(block_sizes.size());
  part->assign(nv, 0);
  int cut = 0;
  if (parts <= 1 || nv == 0) return 0;
  if (rank == 0) {
    std::vector<idx_t> xadj(xadj_in.begin(), xadj_in.end()), adj(adjacency.begin(), adjacency.end());
    std::vector<idx_t> vwgt(block_sizes.begin(), block_sizes.end()), p(nv, 0);
    idx_t n = nv, ncon = 1, np = parts, objval = 0;
    idx_t opts[METIS_NOPTIONS];
    METIS_SetDefaultOptions(opts);
    opts[METIS_OPTION_SEED] = 1;  // the same partition on every run
    int status = METIS_ERROR;
    if (nv >= parts && !adj.empty()) {
      status = METIS_PartGraphKway(&n, &ncon, xadj.data(), adj.data(), vwgt.data(), nullptr, nullptr, &np, nullptr,
                                   nullptr, opts, &objval, p.data());
    }
    if (status != METIS_OK) {
      for (int v = 0; v < nv; ++v) p[v] = static_cast<idx_t>(static_cast<long>(v) * parts / nv);
      objval = -1;
    }
    std::copy(p.begin(), p.end(), part->begin());
    cut = static_cast<int>(objval);
  }
  MPI_Bcast(part->data(), nv, MPI_INT, 0, PETSC_COMM_WORLD);
  MPI_Bcast(&cut, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  return cut;
}

// The job's processes, as the solve sees them (tether/core/linear_solver.h).
class Processes : public ProcessGroup {
 public:
  int rank() const override { return petsc::rank; }
  int size() const override { return petsc::size; }
  void Broadcast(double* values, int n) override {
    if (petsc::size > 1 && n > 0) MPI_Bcast(values, n, MPI_DOUBLE, 0, PETSC_COMM_WORLD);
  }
  void Sum(double* values, int n) override {
    if (petsc::size > 1 && n > 0) MPI_Allreduce(MPI_IN_PLACE, values, n, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  }
};

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
  ProcessGroup* processes() override { return &processes_; }
  // Splits the problem where there is more than one process (the variables' owners by METIS).
  bool Partition(const std::vector<int>& xadj, const std::vector<int>& adjacency, const std::vector<int>& block_sizes,
                 std::vector<int>* owner) override {
    if (size <= 1) return false;
    edge_cut_ = PartitionVariables(xadj, adjacency, block_sizes, size, &part_);
    *owner = part_;
    split_ = true;
    return true;
  }

 private:
  void Number(const std::vector<int>& block_sizes, const std::vector<int>& part);
  void CollectBlocks(const SparseMatrixView& a);
  // Per block row of this process: how many blocks in its own columns (d) and in others' (o),
  // over every process's share where the problem is split.
  void CountBlocks(std::vector<PetscInt>* d, std::vector<PetscInt>* o);
  void CreateMatrix();
  void CreateSolver();

  LinearSolverOptions options_;
  bool iterative_;
  Processes processes_;
  // Partition was called: each process holds its share of H (its factors'), whose blocks go to
  // the processes that own their rows and are added there. Else every process holds the whole
  // H and sets its own rows only.
  bool split_ = false;
  std::vector<int> part_;         // each variable's process
  std::vector<int> range_begin_;  // each process's first column in PETSc's numbering (+ the end)
  int n_ = 0;
  int bs_ = 1;                       // PETSc's block size: the variables' one size, or 1 where they differ
  std::vector<int> col_var_;         // the variable of each column of H
  std::vector<int> new_col_;         // PETSc's index of each column of H
  std::vector<int> old_col_;         // and back
  int own_begin_ = 0, own_end_ = 0;  // this process's columns in PETSc's numbering
  // The blocks this process sets: block row and column (PETSc's numbering) and, for each of
  // the bs x bs entries (row-major), its position in H's values (-1: zero).
  std::vector<int> block_row_, block_col_, block_slot_;
  std::vector<double> buffer_;
  int edge_cut_ = 0;
  long long blocks_sent_ = 0;  // blocks of H all processes send to others per factorisation (split)
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
  std::vector<int>& col_var = col_var_;
  col_var.assign(n_, 0);
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
  if (!split_) {
    // Every process holds the whole H: partition its block graph here.
    const int nv = static_cast<int>(block_sizes.size());
    std::vector<std::vector<int>> adj(nv);
    for (int c = 0; c < a.cols; ++c) {
      for (int k = a.colptr[c]; k < a.colptr[c + 1]; ++k) {
        const int u = col_var[a.rowind[k]], v = col_var[c];
        if (u == v) continue;
        adj[u].push_back(v);
        adj[v].push_back(u);
      }
    }
    std::vector<int> xadj, adjacency;
    internal::ToCompressedRows(&adj, &xadj, &adjacency);
    edge_cut_ = PartitionVariables(xadj, adjacency, block_sizes, size, &part_);
  } else if (part_.size() != block_sizes.size()) {
    throw Error("petsc: Analyze got " + std::to_string(block_sizes.size()) + " variables, Partition " +
                std::to_string(part_.size()));
  }
  Number(block_sizes, part_);
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
  for (int v : order) {
    for (int i = 0; i < block_sizes[v]; ++i) {
      new_col_[start[v] + i] = next;
      old_col_[next] = start[v] + i;
      ++next;
    }
  }
  range_begin_.assign(size + 1, 0);
  for (int v = 0; v < nv; ++v) range_begin_[part[v] + 1] += block_sizes[v];
  for (int r = 0; r < size; ++r) range_begin_[r + 1] += range_begin_[r];
  own_begin_ = range_begin_[rank];
  own_end_ = range_begin_[rank + 1];
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
  // Split: every block of this process's share goes (to its row's owner); else own rows only.
  auto mine = [this](int row) { return split_ || (row >= own_begin_ && row < own_end_); };
  // Split: the diagonal block of a variable another process owns is zero here unless one of
  // this process's factors joins it to another variable (a factor of that variable alone, a
  // prior, belongs to its owner; so does its damping): only those are sent.
  std::vector<char> joined;
  if (split_) {
    joined.assign(n_, 0);
    for (int c = 0; c < a.cols; ++c) {
      for (int k = a.colptr[c]; k < a.colptr[c + 1]; ++k) {
        const int r = a.rowind[k];
        if (col_var_[r] != col_var_[c]) joined[r] = joined[c] = 1;
      }
    }
  }
  for (int c = 0; c < a.cols; ++c) {
    for (int k = a.colptr[c]; k < a.colptr[c + 1]; ++k) {
      const int r = a.rowind[k];
      if (r > c) continue;  // below the diagonal: H is given by its upper triangle
      const int nr = new_col_[r], nc = new_col_[c];
      const int lo = std::min(nr, nc), hi = std::max(nr, nc);
      const bool same_block = lo / bs_ == hi / bs_;
      if (split_ && col_var_[r] == col_var_[c] && !joined[c] && (lo < own_begin_ || lo >= own_end_)) continue;
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

void PetscSolver::CountBlocks(std::vector<PetscInt>* d, std::vector<PetscInt>* o) {
  const int first_block = own_begin_ / bs_, blocks = (own_end_ - own_begin_) / bs_;
  std::vector<long long> rows_cols;        // (row, column) of the blocks of this process's rows
  std::vector<std::vector<int>> to(size);  // the others' blocks, as row, column pairs
  for (std::size_t i = 0; i < block_row_.size(); ++i) {
    const int row = block_row_[i];
    const int owner =
        static_cast<int>(std::upper_bound(range_begin_.begin(), range_begin_.end(), row * bs_) - range_begin_.begin()) -
        1;
    if (owner == rank) {
      rows_cols.push_back(static_cast<long long>(row) * (n_ / bs_ + 1) + block_col_[i]);
    } else {
      to[owner].push_back(row);
      to[owner].push_back(block_col_[i]);
    }
  }
  long long sent = 0;
  for (const std::vector<int>& t : to) sent += static_cast<long long>(t.size() / 2);
  if (split_ && size > 1) {
    MPI_Allreduce(&sent, &blocks_sent_, 1, MPI_LONG_LONG, MPI_SUM, PETSC_COMM_WORLD);
    // The blocks the other processes will add into this process's rows join its own.
    std::vector<int> send_counts(size), recv_counts(size), send_at(size + 1, 0), recv_at(size + 1, 0);
    for (int r = 0; r < size; ++r) send_counts[r] = static_cast<int>(to[r].size());
    MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, PETSC_COMM_WORLD);
    std::vector<int> send;
    for (int r = 0; r < size; ++r) {
      send.insert(send.end(), to[r].begin(), to[r].end());
      std::vector<int>().swap(to[r]);
      send_at[r + 1] = send_at[r] + send_counts[r];
      recv_at[r + 1] = recv_at[r] + recv_counts[r];
    }
    std::vector<int> recv(static_cast<std::size_t>(recv_at[size]));
    MPI_Alltoallv(send.data(), send_counts.data(), send_at.data(), MPI_INT, recv.data(), recv_counts.data(),
                  recv_at.data(), MPI_INT, PETSC_COMM_WORLD);
    for (std::size_t i = 0; i + 1 < recv.size(); i += 2) {
      rows_cols.push_back(static_cast<long long>(recv[i]) * (n_ / bs_ + 1) + recv[i + 1]);
    }
  }
  std::sort(rows_cols.begin(), rows_cols.end());
  rows_cols.erase(std::unique(rows_cols.begin(), rows_cols.end()), rows_cols.end());
  d->assign(blocks, 0);
  o->assign(blocks, 0);
  for (long long rc : rows_cols) {
    const int row = static_cast<int>(rc / (n_ / bs_ + 1)) - first_block;
    const int col = static_cast<int>(rc % (n_ / bs_ + 1));
    const bool inside = col >= first_block && col < first_block + blocks;
    ++(inside ? *d : *o)[row];
  }
}

void PetscSolver::CreateMatrix() {
  const int local = own_end_ - own_begin_;
  std::vector<PetscInt> d, o;
  CountBlocks(&d, &o);
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
  std::snprintf(buf, sizeof buf, " on %d process%s, METIS k-way (edge cut %d), block size %d%s", size,
                size == 1 ? "" : "es", edge_cut_, bs_, split_ ? ", factors split by owner" : "");
  description_ = what + buf;
  if (split_) {
    std::snprintf(buf, sizeof buf, " (%lld blocks of H, %.2f MB of values, sent between them per factorisation)",
                  blocks_sent_, static_cast<double>(blocks_sent_) * bs_ * bs_ * sizeof(double) / 1e6);
    description_ += buf;
  }
}

LinearSolverStatus PetscSolver::Factorize(const SparseMatrixView& a) {
  const int bs2 = bs_ * bs_;
  // Split: every process adds its share (blocks of zeros left out), so the matrix starts empty.
  if (split_) TETHER_PETSC(MatZeroEntries(mat_));
  const InsertMode mode = split_ ? ADD_VALUES : INSERT_VALUES;
  for (std::size_t i = 0; i < block_row_.size(); ++i) {
    const int* s = &block_slot_[i * bs2];
    bool zero = true;
    for (int e = 0; e < bs2; ++e) {
      buffer_[e] = s[e] >= 0 ? a.values[s[e]] : 0.0;
      zero = zero && buffer_[e] == 0.0;
    }
    if (split_ && zero) continue;
    const PetscInt row = block_row_[i], col = block_col_[i];
    TETHER_PETSC(MatSetValuesBlocked(mat_, 1, &row, 1, &col, buffer_.data(), mode));
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
