#include "tether/solvers/distributed.h"

#include <mutex>

#include "builtin_linear_solvers.h"
#include "petsc_module.h"
#include "tether/core/error.h"
#include "tether/core/module.h"

namespace tether {

#ifdef TETHER_WITH_MPI
namespace internal {
namespace {

constexpr const char* kModule = "libtether_petsc.so";

std::mutex mutex;
const PetscTable* table = nullptr;
bool started = false;
DistributedProcess process;

// The module's table, loaded once; throws Error naming the module and what to do.
const PetscTable& Table() {
  if (table != nullptr) return *table;
  const LoadedModule m = LoadModuleBeside(reinterpret_cast<const void*>(&StartDistributed), kModule, "tether_petsc_v1",
                                          ModuleScope::kGlobal);
  std::string why = m.failure;
  const PetscTable* t = nullptr;
  if (m.entry != nullptr) {
    t = reinterpret_cast<const PetscTable* (*)()>(m.entry)();
    if (t == nullptr || t->version != kPetscTableVersion || t->size != sizeof(PetscTable) || !t->start ||
        !t->make_solver || !t->abort) {
      why = m.path + ": its table is not the one this libtether_solvers expects (the two come from different builds)";
      t = nullptr;
    }
  }
  if (t == nullptr) {
    throw Error("the distributed solvers (PETSc, MUMPS, MPI) could not be loaded: " + why + "; reinstall tether (" +
                kModule + " is built with -DTETHER_WITH_MPI=ON and installed beside libtether_solvers.so)");
  }
  table = t;
  return *table;
}

DistributedProcess StartLocked(const std::string& options) {
  if (started) return process;
  const PetscTable& t = Table();
  std::string why;
  if (!t.start(options, &process.rank, &process.size, &why)) throw Error("MPI and PETSc could not start: " + why);
  started = true;
  return process;
}

std::unique_ptr<LinearSolver> MakePetsc(const LinearSolverOptions& options, bool iterative) {
  std::lock_guard<std::mutex> lock(mutex);
  StartLocked("");
  return table->make_solver(options, iterative);
}

}  // namespace

void RegisterDistributedLinearSolvers(LinearSolverRegistry& r) {
  for (const bool iterative : {false, true}) {
    LinearSolverEntry e;
    e.name = iterative ? "petsc-iterative" : "petsc";
    e.form = LinearSystemForm::kNormalEquations;
    e.direct = !iterative;
    e.spans_processes = true;
    e.make = [iterative](const LinearSolverOptions& o) { return MakePetsc(o, iterative); };
    r.Register(std::move(e));
  }
}

}  // namespace internal

bool DistributedBuilt() { return true; }

DistributedProcess StartDistributed(const std::string& petsc_options) {
  std::lock_guard<std::mutex> lock(internal::mutex);
  return internal::StartLocked(petsc_options);
}

DistributedProcess CurrentProcess() {
  std::lock_guard<std::mutex> lock(internal::mutex);
  return internal::process;
}

void AbortDistributed(int exit_code) {
  const internal::PetscTable* t = nullptr;
  {
    std::lock_guard<std::mutex> lock(internal::mutex);
    if (!internal::started || internal::process.size <= 1) return;
    t = internal::table;
  }
  t->abort(exit_code);
}

#else

namespace internal {
void RegisterDistributedLinearSolvers(LinearSolverRegistry&) {}
}  // namespace internal

bool DistributedBuilt() { return false; }

DistributedProcess StartDistributed(const std::string&) {
  throw Error(
      "this tether was built without the distributed solvers; build it with -DTETHER_WITH_MPI=ON "
      "(scripts/install_deps.sh --mpi installs what it needs; docs/distributed.md)");
}

DistributedProcess CurrentProcess() { return {}; }

void AbortDistributed(int) {}

#endif

}  // namespace tether
