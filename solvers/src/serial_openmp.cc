#include "serial_openmp.h"

#include "loaded_library.h"

namespace tether {
namespace internal {
namespace {

// omp_{get,set}_max_active_levels, in the global scope or in an OpenMP runtime loaded locally.
const LoadedIntSetting& TheRuntime() {
  static const LoadedIntSetting runtime =
      FindLoadedIntSetting("omp_get_max_active_levels", "omp_set_max_active_levels",
                           {"libgomp.so.1", "libomp.so.5", "libomp.so", "libiomp5.so"});
  return runtime;
}

// The setting is per thread in the runtime (OpenMP 5 makes max-active-levels a data
// environment ICV; libgomp keeps it per thread), so the bookkeeping is per thread too.
thread_local int depth = 0;         // live SerialOpenMp objects on this thread
thread_local int saved_levels = 0;  // this thread's value when the first of them began

}  // namespace

SerialOpenMp::SerialOpenMp() {
  const LoadedIntSetting& rt = TheRuntime();
  if (rt.set == nullptr) return;
  if (depth++ == 0) {
    saved_levels = rt.get();
    rt.set(0);
  }
}

SerialOpenMp::~SerialOpenMp() {
  const LoadedIntSetting& rt = TheRuntime();
  if (rt.set == nullptr) return;
  if (--depth == 0) rt.set(saved_levels);
}

bool OpenMpRuntimeLoaded() { return TheRuntime().set != nullptr; }

}  // namespace internal
}  // namespace tether
