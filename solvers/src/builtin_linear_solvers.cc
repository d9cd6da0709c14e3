#include "builtin_linear_solvers.h"

#include <mutex>

namespace tether {
namespace internal {

namespace {

LinearSolverEntry Entry(const char* name, LinearSystemForm form, std::unique_ptr<LinearSolver> (*make)()) {
  LinearSolverEntry e;
  e.name = name;
  e.form = form;
  e.direct = true;
  e.make = [make](const LinearSolverOptions&) { return make(); };
  return e;
}

void RegisterBuiltinLinearSolvers(LinearSolverRegistry& r) {
  r.Register(Entry("cholmod", LinearSystemForm::kNormalEquations, [] { return MakeCholmod(); }));
  r.Register(Entry("ldlt", LinearSystemForm::kNormalEquations, MakeEigenLDLT));
  r.Register(Entry("qr", LinearSystemForm::kJacobian, MakeSpqr));
  r.Register(Entry("block", LinearSystemForm::kNormalEquations, MakeBlockCholesky));
  r.Register(Entry("auto", LinearSystemForm::kNormalEquations, MakeAutoCholesky));
  RegisterDistributedLinearSolvers(r);
}

// The built-in names are taken when tether::solvers is loaded, so that a plugin loaded later
// cannot register a solver named "cholmod" in their place.
const bool kRegisteredAtLoad = (LinearSolvers(), true);

}  // namespace

LinearSolverRegistry& LinearSolvers() {
  static std::once_flag once;
  LinearSolverRegistry& r = DefaultLinearSolverRegistry();
  std::call_once(once, [&r] { RegisterBuiltinLinearSolvers(r); });
  return r;
}

}  // namespace internal
}  // namespace tether
