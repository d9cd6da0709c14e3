#include "blas_threads.h"

#include <dlfcn.h>

#include <algorithm>

namespace tether::internal {
namespace {

using GetThreads = int (*)();
using SetThreads = void (*)(int);

struct BlasThreadCalls {
  GetThreads get = nullptr;
  SetThreads set = nullptr;
};

// The setters of the threaded BLAS libraries Debian ships (OpenBLAS, BLIS), found among the
// symbols the process has loaded. Looked up once.
const BlasThreadCalls& Calls() {
  static const BlasThreadCalls calls = [] {
    BlasThreadCalls c;
    const char* const names[][2] = {{"openblas_get_num_threads", "openblas_set_num_threads"},
                                    {"bli_thread_get_num_threads", "bli_thread_set_num_threads"}};
    for (const auto& n : names) {
      void* get = dlsym(RTLD_DEFAULT, n[0]);
      void* set = dlsym(RTLD_DEFAULT, n[1]);
      if (get != nullptr && set != nullptr) {
        c.get = reinterpret_cast<GetThreads>(get);
        c.set = reinterpret_cast<SetThreads>(set);
        break;
      }
    }
    return c;
  }();
  return calls;
}

}  // namespace

int BlasThreads() {
  const BlasThreadCalls& c = Calls();
  return c.get != nullptr ? c.get() : 0;
}

ScopedBlasThreads::ScopedBlasThreads(int threads) {
  const BlasThreadCalls& c = Calls();
  if (c.get == nullptr) return;
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
