#include "tether/core/module.h"

#include <dlfcn.h>

namespace tether {
namespace {

std::string LastDlError() {
  const char* why = dlerror();
  return why != nullptr ? why : "unknown error";
}

}  // namespace

LoadedModule LoadModuleFrom(const std::string& path, const char* entry, ModuleScope scope) {
  LoadedModule m;
  m.path = path;
  void* handle = dlopen(path.c_str(), RTLD_LAZY | (scope == ModuleScope::kGlobal ? RTLD_GLOBAL : RTLD_LOCAL));
  if (handle == nullptr) {
    m.failure = path + " could not be loaded (" + LastDlError() + ")";
    return m;
  }
  dlerror();
  m.entry = dlsym(handle, entry);
  if (m.entry == nullptr) m.failure = path + " has no entry point " + entry + " (it is not the module tether expects)";
  return m;
}

LoadedModule LoadModuleBeside(const void* anchor, const std::string& file, const char* entry, ModuleScope scope) {
  std::string path = file;
  Dl_info info;
  if (dladdr(anchor, &info) != 0 && info.dli_fname != nullptr) {
    const std::string self = info.dli_fname;
    const std::size_t slash = self.rfind('/');
    if (slash != std::string::npos) path = self.substr(0, slash + 1) + file;
  }
  LoadedModule m = LoadModuleFrom(path, entry, scope);
  if (m.entry == nullptr && path != file) {
    LoadedModule searched = LoadModuleFrom(file, entry, scope);
    if (searched.entry != nullptr) return searched;
    // Report the file beside the library: that is where the module is built and installed.
  }
  return m;
}

}  // namespace tether
