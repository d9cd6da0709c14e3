#pragma once
// Loading a module of tether's own (a shared library that carries heavy dependencies, loaded
// at its first use so that a program that never needs it never pays for it): the solver
// back-ends (libtether_backends.so: CHOLMOD, SuiteSparseQR, Ceres, BLAS and LAPACK) and the
// ROS 1 bag reader (libtether_rosbag.so).
#include <string>

namespace tether {

struct LoadedModule {
  void* entry = nullptr;  ///< the entry point, or null
  std::string path;       ///< the file that was tried (or loaded)
  std::string failure;    ///< empty when entry is set: why the module or its entry was not found
};

/// Where a module's symbols (and its libraries') resolve once it is loaded.
enum class ModuleScope {
  kLocal,   ///< only through the entry point (RTLD_LOCAL)
  kGlobal,  ///< for the whole process, as if the module had been linked (RTLD_GLOBAL)
};

/// Loads `file` from the folder of the shared library that holds `anchor` (an address in one
/// of tether's libraries, so a module is found beside the library that uses it, in the build
/// tree and where installed alike), else by the dynamic loader's search, and looks up the
/// symbol `entry` in it. Functions are bound at their first call (RTLD_LAZY), as for the
/// libraries a program links: binding all of the back-ends' at once (Ceres, OpenBLAS) took 2 ms
/// more. The module is never unloaded.
/// Never throws: a failure is described in `failure`.
LoadedModule LoadModuleBeside(const void* anchor, const std::string& file, const char* entry, ModuleScope scope);

/// As above, from the given path only (no search): what a test uses to see each failure.
LoadedModule LoadModuleFrom(const std::string& path, const char* entry, ModuleScope scope);

}  // namespace tether
