#include "blas_threads.h"

#include <algorithm>
#include <mutex>

#include "backends.h"
#include "loaded_library.h"

namespace tether::internal {
namespace {

LoadedIntSetting Find() {
  const LoadedIntSetting openblas =
      FindLoadedIntSetting("openblas_get_num_threads", "openblas_set_num_threads", {"libopenblas.so.0"});
  if (openblas.found()) return openblas;
  return FindLoadedIntSetting("bli_thread_get_num_threads", "bli_thread_set_num_threads",
                              {"libblis.so.4", "libblis.so.3"});
}

// The thread count of the threaded BLAS libraries Debian ships (OpenBLAS, BLIS). The BLAS
// comes with the back-end module (backends.h), loaded at its first use: looked up once before
// and once after that load. (In the scope during which the module loads, the count is the
// library's own.)
LoadedIntSetting Calls() {
  struct Lookup {
    LoadedIntSetting calls;
    bool done = false;
  };
  static std::mutex mutex;
  static Lookup before, after;
  std::lock_guard<std::mutex> lock(mutex);
  Lookup& l = BackendsLoaded() ? after : before;
  if (!l.done) {
    l.calls = Find();
    l.done = true;
  }
  return l.calls;
}

}  // namespace

int BlasThreads() {
  const LoadedIntSetting c = Calls();
  return c.found() ? c.get() : 0;
}

ScopedBlasThreads::ScopedBlasThreads(int threads) {
  const LoadedIntSetting c = Calls();
  if (!c.found()) return;
  const int wanted = std::max(1, threads);
  const int now = c.get();
  if (now == wanted) return;
  previous_ = now;
  c.set(wanted);
}

ScopedBlasThreads::~ScopedBlasThreads() {
  if (previous_ > 0) Calls().set(previous_);
}

}  // namespace tether::internal
