#include "serial_openmp.h"

#include <dlfcn.h>

#include <initializer_list>

namespace tether {
namespace internal {
namespace {

using GetLevels = int (*)();
using SetLevels = void (*)(int);

struct Runtime {
  GetLevels get = nullptr;
  SetLevels set = nullptr;
};

// Looks the two functions up in the global scope first, then in an OpenMP runtime that is
// loaded but local to whoever loaded it (RTLD_NOLOAD: never loads one).
Runtime FindRuntime() {
  Runtime r;
  r.get = reinterpret_cast<GetLevels>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  r.set = reinterpret_cast<SetLevels>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  for (const char* name : {"libgomp.so.1", "libomp.so.5", "libomp.so", "libiomp5.so"}) {
    if (r.get != nullptr && r.set != nullptr) break;
    void* handle = dlopen(name, RTLD_LAZY | RTLD_NOLOAD);
    if (handle == nullptr) continue;
    r.get = reinterpret_cast<GetLevels>(dlsym(handle, "omp_get_max_active_levels"));
    r.set = reinterpret_cast<SetLevels>(dlsym(handle, "omp_set_max_active_levels"));
    // The handle (a reference RTLD_NOLOAD took) is kept for good: the pointers above must
    // stay valid even if whoever loaded the runtime unloads it.
  }
  if (r.get == nullptr || r.set == nullptr) r = Runtime{};
  return r;
}

const Runtime& TheRuntime() {
  static const Runtime runtime = FindRuntime();
  return runtime;
}

// The setting is per thread in the runtime (OpenMP 5 makes max-active-levels a data
// environment ICV; libgomp keeps it per thread), so the bookkeeping is per thread too.
thread_local int depth = 0;         // live SerialOpenMp objects on this thread
thread_local int saved_levels = 0;  // this thread's value when the first of them began

}  // namespace

SerialOpenMp::SerialOpenMp() {
  const Runtime& rt = TheRuntime();
  if (rt.set == nullptr) return;
  if (depth++ == 0) {
    saved_levels = rt.get();
    rt.set(0);
  }
}

SerialOpenMp::~SerialOpenMp() {
  const Runtime& rt = TheRuntime();
  if (rt.set == nullptr) return;
  if (--depth == 0) rt.set(saved_levels);
}

bool OpenMpRuntimeLoaded() { return TheRuntime().set != nullptr; }

}  // namespace internal
}  // namespace tether
