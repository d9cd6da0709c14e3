#pragma once
// Internal: a setting of a library the process has already loaded (an OpenMP runtime's active
// levels, a BLAS's thread count), read and written through the library's own getter and
// setter, found at run time: nothing links against a particular implementation, and where
// none is loaded nothing happens.
#include <initializer_list>

namespace tether::internal {

struct LoadedIntSetting {
  int (*get)() = nullptr;
  void (*set)(int) = nullptr;
  bool found() const { return get != nullptr && set != nullptr; }
};

/// The functions `get_name` and `set_name`, looked up in the global scope first, then in each
/// of `libraries` that is loaded but local to whoever loaded it (RTLD_NOLOAD: never loads
/// one; the handle is kept, so the pointers stay valid). Both or neither.
LoadedIntSetting FindLoadedIntSetting(const char* get_name, const char* set_name,
                                      std::initializer_list<const char*> libraries);

}  // namespace tether::internal
