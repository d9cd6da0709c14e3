#include "loaded_library.h"

#include <dlfcn.h>

namespace tether::internal {
namespace {

LoadedIntSetting Lookup(void* handle, const char* get_name, const char* set_name) {
  LoadedIntSetting s;
  s.get = reinterpret_cast<int (*)()>(dlsym(handle, get_name));
  s.set = reinterpret_cast<void (*)(int)>(dlsym(handle, set_name));
  return s.found() ? s : LoadedIntSetting{};
}

}  // namespace

LoadedIntSetting FindLoadedIntSetting(const char* get_name, const char* set_name,
                                      std::initializer_list<const char*> libraries) {
  LoadedIntSetting s = Lookup(RTLD_DEFAULT, get_name, set_name);
  for (const char* name : libraries) {
    if (s.found()) break;
    void* handle = dlopen(name, RTLD_LAZY | RTLD_NOLOAD);
    if (handle != nullptr) s = Lookup(handle, get_name, set_name);
  }
  return s;
}

}  // namespace tether::internal
