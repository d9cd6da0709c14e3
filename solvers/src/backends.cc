#include "backends.h"

#include <atomic>
#include <mutex>
#include <string>

#include "builtin_linear_solvers.h"
#include "tether/core/error.h"
#include "tether/core/module.h"
#include "tether/solvers/backends.h"
#include "tether/solvers/ceres_adapter.h"

namespace tether {
namespace internal {
namespace {

constexpr const char* kModule = "libtether_backends.so";
constexpr const char* kEntry = "tether_backends_v1";

std::once_flag loaded_once;
std::atomic<const BackendTable*> loaded{nullptr};
std::string failure;

std::string CheckTable(const BackendTable* t) {
  if (t == nullptr) return "its entry point returned no table";
  if (t->version != kBackendTableVersion || t->size != sizeof(BackendTable)) {
    return "its table is version " + std::to_string(t->version) + " (" + std::to_string(t->size) +
           " bytes) where this libtether_solvers expects version " + std::to_string(kBackendTableVersion) + " (" +
           std::to_string(sizeof(BackendTable)) + " bytes): the two come from different builds";
  }
  if (!t->make_cholmod || !t->make_spqr || !t->make_cholmod_covariance || !t->make_qr_covariance ||
      !t->optimize_with_ceres || !t->dsyrk || !t->dtrsm || !t->dpotrf) {
    return "its table misses a function";
  }
  return "";
}

// The module's table, checked; nullptr and `why` (naming the file) where it cannot be used.
const BackendTable* TableOf(const LoadedModule& m, std::string* why) {
  if (m.entry == nullptr) {
    *why = m.failure;
    return nullptr;
  }
  const BackendTable* t = reinterpret_cast<const BackendTable* (*)()>(m.entry)();
  const std::string bad = CheckTable(t);
  if (!bad.empty()) {
    *why = m.path + ": " + bad;
    return nullptr;
  }
  return t;
}

void Load() {
#ifdef TETHER_BACKENDS_BUILT_IN
  const BackendTable* t = tether_backends_v1();
  failure = CheckTable(t);
  if (failure.empty()) loaded = t;
#else
  loaded = TableOf(LoadModuleBeside(reinterpret_cast<const void*>(&Backends), kModule, kEntry, ModuleScope::kGlobal),
                   &failure);
#endif
}

}  // namespace

const BackendTable* LoadBackendsFrom(const std::string& path, std::string* why) {
  return TableOf(LoadModuleFrom(path, kEntry, ModuleScope::kLocal), why);
}

const BackendTable& Backends() {
  std::call_once(loaded_once, Load);
  const BackendTable* table = loaded.load();
  if (table == nullptr) {
    throw Error("the solver back-ends (CHOLMOD, SuiteSparseQR, Ceres) could not be loaded: " + failure +
                "; reinstall tether (" + kModule +
                " is built and installed beside libtether_solvers.so), or use the native solvers: "
                "--linear block (or ldlt) with --solver lm, gn or dogleg");
  }
  return *table;
}

bool BackendsLoaded() { return loaded.load() != nullptr; }

std::unique_ptr<LinearSolver> MakeCholmod(std::vector<int> ordering) {
  return Backends().make_cholmod(std::move(ordering));
}
std::unique_ptr<LinearSolver> MakeSpqr() { return Backends().make_spqr(); }
std::unique_ptr<CovarianceFactor> MakeCholmodCovariance(const Csc& h, const ColumnNamer& name) {
  return Backends().make_cholmod_covariance(h, name);
}
std::unique_ptr<CovarianceFactor> MakeQrCovariance(const Csc& j, const ColumnNamer& name) {
  return Backends().make_qr_covariance(j, name);
}

}  // namespace internal

SolverSummary OptimizeWithCeres(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  const internal::BackendTable* backends = nullptr;
  try {
    backends = &internal::Backends();
  } catch (const Error& e) {
    // As the native solvers report a linear solver they cannot make: values untouched.
    SolverSummary s;
    s.algorithm = Algorithm::kCeres;
    s.num_factors = static_cast<int>(graph.size());
    s.status = SolverStatus::kInvalidInput;
    s.message = e.what();
    return s;
  }
  return backends->optimize_with_ceres(graph, values, options);
}

void LoadSolverBackends() { internal::Backends(); }
bool SolverBackendsLoaded() { return internal::BackendsLoaded(); }

}  // namespace tether
