// A back-end module that libtether_solvers must refuse: its table is of another version
// (BAD_BACKENDS_WRONG_VERSION) or misses a function (BAD_BACKENDS_MISSING_FUNCTION).
#include "backends.h"

extern "C" const tether::internal::BackendTable* tether_backends_v1() {
  static const tether::internal::BackendTable table = [] {
    tether::internal::BackendTable t;
#ifdef BAD_BACKENDS_WRONG_VERSION
    t.version = tether::internal::kBackendTableVersion + 1;
#endif
    // BAD_BACKENDS_MISSING_FUNCTION: every function is left null.
    return t;
  }();
  return &table;
}
