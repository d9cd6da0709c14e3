#include "blas_threads.h"

#include <algorithm>

#include "loaded_library.h"

namespace tether::internal {
namespace {

// The thread count of the threaded BLAS libraries Debian ships (OpenBLAS, BLIS), looked up
// once.
const LoadedIntSetting& Calls() {
  static const LoadedIntSetting calls = [] {
    const LoadedIntSetting openblas =
        FindLoadedIntSetting("openblas_get_num_threads", "openblas_set_num_threads", {"libopenblas.so.0"});
    if (openblas.found()) return openblas;
    return FindLoadedIntSetting("bli_thread_get_num_threads", "bli_thread_set_num_threads",
                                {"libblis.so.4", "libblis.so.3"});
  }();
  return calls;
}

}  // namespace

int BlasThreads() {
  const LoadedIntSetting& c = Calls();
  return c.found() ? c.get() : 0;
}

ScopedBlasThreads::ScopedBlasThreads(int threads) {
  const LoadedIntSetting& c = Calls();
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
