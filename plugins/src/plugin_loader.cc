#include "tether/plugins/plugin_loader.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>

#include "tether/plugins/plugin.h"

namespace tether {

namespace {

namespace fs = std::filesystem;

bool IsFile(const std::string& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool IsDirectory(const std::string& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

std::string Count(std::size_t n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

// The linear solvers a plugin adds, tried on a copy of the registry first (so that a clash
// registers nothing of the plugin). One this plugin registered already, through another
// loader into the same process-wide registry, stays as it is.
std::vector<LinearSolverEntry> TrialLinearSolvers(const PluginRegistrar& registrar, const LinearSolverRegistry& target,
                                                  const std::string& path, LoadedPlugin* loaded) {
  const std::string& name = registrar.plugin_name();
  std::vector<LinearSolverEntry> added;
  LinearSolverRegistry trial = target;
  try {
    for (const LinearSolverEntry& e : registrar.linear_solvers()) {
      const LinearSolverEntry* there = target.Find(e.name);
      if (there == nullptr || there->owner != name) {
        trial.Register(e);
        added.push_back(e);
      }
      loaded->linear_solver_names.push_back(e.name);
    }
  } catch (const Error& e) {
    throw PluginError("plugin " + path + " ('" + name + "'): " + e.what() + "; nothing of it was registered");
  }
  return added;
}

// The robust losses a plugin adds, the same way: tried on a copy of the loss registry, and one
// this plugin registered already (through another loader) left as it is.
std::vector<LossEntry> TrialLosses(const PluginRegistrar& registrar, const LossRegistry& target,
                                   const std::string& path, LoadedPlugin* loaded) {
  const std::string& name = registrar.plugin_name();
  std::vector<LossEntry> added;
  LossRegistry trial = target;
  try {
    for (const LossEntry& e : registrar.losses()) {
      LossEntry there;
      if (!target.Get(e.name, &there) || there.owner != name) {
        trial.Register(e);
        added.push_back(e);
      }
      loaded->loss_names.push_back(e.name);
    }
  } catch (const Error& e) {
    throw PluginError("plugin " + path + " ('" + name + "'): " + e.what() + "; nothing of it was registered");
  }
  return added;
}

std::map<std::string, PluginExtensionKind>& ExtensionKinds() {
  static std::map<std::string, PluginExtensionKind> kinds;
  return kinds;
}

std::mutex& ExtensionKindsMutex() {
  static std::mutex m;
  return m;
}

// The handler of each extension the plugin adds that is not registered by it already, after
// checking that every name can be taken (nothing is registered yet). An extension of a kind no
// module of this program knows is refused, naming it.
std::vector<std::pair<PluginExtensionKind, const PluginExtension*>> TrialExtensions(const PluginRegistrar& registrar,
                                                                                    const std::string& path,
                                                                                    LoadedPlugin* loaded) {
  const std::string& name = registrar.plugin_name();
  std::vector<std::pair<PluginExtensionKind, const PluginExtension*>> kinds;
  std::lock_guard<std::mutex> lock(ExtensionKindsMutex());
  for (std::size_t i = 0; i < registrar.extensions().size(); ++i) {
    const PluginExtension& e = registrar.extensions()[i];
    const auto it = ExtensionKinds().find(e.kind);
    if (it == ExtensionKinds().end()) {
      throw PluginError("plugin " + path + " ('" + name + "'): it adds a " + e.kind + " ('" + e.name +
                        "'), which this program does not know how to register (link tether::solvers, which "
                        "registers them); nothing of it was registered");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (registrar.extensions()[j].kind == e.kind && registrar.extensions()[j].name == e.name) {
        throw PluginError("plugin " + path + " ('" + name + "'): it adds the " + e.kind + " '" + e.name +
                          "' twice; nothing of it was registered");
      }
    }
    bool fresh = false;
    try {
      fresh = it->second.check(e.name, name);
    } catch (const Error& err) {
      throw PluginError("plugin " + path + " ('" + name + "'): " + err.what() + "; nothing of it was registered");
    }
    if (fresh) kinds.emplace_back(it->second, &e);
    loaded->extension_names.push_back(e.kind + " '" + e.name + "'");
  }
  return kinds;
}

// Whether everything an earlier load of the plugin registered is still there, owned by it.
bool StillRegistered(const LoadedPlugin& p, const Registry& registry, const LinearSolverRegistry& solvers,
                     const LossRegistry& losses) {
  const auto owned_type = [&](const std::string& n) {
    const FactorType* t = registry.FindByName(n);
    return t != nullptr && t->owner == p.name;
  };
  const auto owned_variable = [&](const std::string& n) { return registry.VariableOwner(n) == p.name; };
  const auto owned_solver = [&](const std::string& n) {
    LinearSolverEntry e;
    return solvers.Get(n, &e) && e.owner == p.name;
  };
  const auto owned_loss = [&](const std::string& n) {
    LossEntry e;
    return losses.Get(n, &e) && e.owner == p.name;
  };
  return std::all_of(p.type_names.begin(), p.type_names.end(), owned_type) &&
         std::all_of(p.variable_names.begin(), p.variable_names.end(), owned_variable) &&
         std::all_of(p.linear_solver_names.begin(), p.linear_solver_names.end(), owned_solver) &&
         std::all_of(p.loss_names.begin(), p.loss_names.end(), owned_loss);
}

// Opens the library and checks its description: entry symbol, interface version, name, build
// fingerprint. The library stays loaded for the life of the process (see the header).
const PluginDescription* OpenDescription(const std::string& path) {
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    throw PluginError("plugin " + path + ": cannot be loaded as a shared library: " + (why ? why : "unknown error") +
                      "; check that it is a plugin built for this machine and that the libraries it needs are "
                      "installed");
  }
  dlerror();
  void* symbol = dlsym(handle, TETHER_PLUGIN_ENTRY_SYMBOL);
  if (symbol == nullptr) {
    throw PluginError("plugin " + path +
                      ": the entry symbol '" TETHER_PLUGIN_ENTRY_SYMBOL
                      "' is missing; define it with TETHER_PLUGIN(name, version, register_function) "
                      "in one source file of the plugin");
  }
  using Entry = const PluginDescription* (*)();
  const PluginDescription* d = reinterpret_cast<Entry>(symbol)();
  if (d == nullptr) throw PluginError("plugin " + path + ": " TETHER_PLUGIN_ENTRY_SYMBOL " returned no description");
  if (d->interface_version != TETHER_PLUGIN_INTERFACE_VERSION) {
    throw PluginError("plugin " + path + ": plugin interface version " + std::to_string(d->interface_version) +
                      ", but this tether speaks version " + std::to_string(TETHER_PLUGIN_INTERFACE_VERSION) +
                      "; rebuild the plugin against this tether's headers");
  }
  const std::string name = d->name ? d->name : "";
  if (name.empty()) throw PluginError("plugin " + path + ": the description has no name; give TETHER_PLUGIN a name");
  const std::vector<std::string> diffs = CompareFingerprints(CurrentBuildFingerprint(), d->fingerprint);
  if (!diffs.empty()) {
    std::string m = "plugin " + path + " ('" + name + "'): built with different settings than this tether (";
    for (std::size_t i = 0; i < diffs.size(); ++i) m += (i ? "; " : "") + diffs[i];
    throw PluginError(m + "); rebuild the plugin with the same tether, Eigen version and compiler flags");
  }
  if (d->register_types == nullptr) {
    throw PluginError("plugin " + path + " ('" + name + "'): the description has no registration function");
  }
  return d;
}

// Runs the plugin's registration function; what it adds is collected, not yet registered.
PluginRegistrar RunRegistration(const PluginDescription& d, const std::string& path) {
  const std::string name = d.name;
  PluginRegistrar registrar(name);
  try {
    d.register_types(registrar);
  } catch (const std::exception& e) {
    throw PluginError("plugin " + path + " ('" + name + "'): registration failed: " + e.what() +
                      "; nothing of it was registered");
  } catch (...) {
    throw PluginError("plugin " + path + " ('" + name +
                      "'): registration threw something that is not a std::exception; nothing of it was registered");
  }
  return registrar;
}

// The plugin's variable and factor types, tried on a copy of the registry.
void TrialTypes(const PluginRegistrar& registrar, const Registry& registry, const std::string& path,
                LoadedPlugin* loaded) {
  Registry trial = registry;
  try {
    for (const VariableType& t : registrar.variable_types()) {
      trial.RegisterVariable(t);
      loaded->variable_names.push_back(t.name);
    }
    for (const FactorType& t : registrar.factor_types()) {
      trial.Register(t);
      loaded->type_names.push_back(t.name);
    }
  } catch (const Error& e) {
    throw PluginError("plugin " + path + " ('" + registrar.plugin_name() + "'): " + e.what() +
                      "; nothing of it was registered");
  }
}

}  // namespace

void RegisterPluginExtensionKind(const std::string& kind, PluginExtensionKind handler) {
  if (!handler.check || !handler.commit || !handler.remove) {
    throw InvalidArgument("extension kind '" + kind + "' needs check, commit and remove");
  }
  std::lock_guard<std::mutex> lock(ExtensionKindsMutex());
  if (!ExtensionKinds().emplace(kind, std::move(handler)).second) {
    throw InvalidArgument("extension kind '" + kind + "' is known already");
  }
}

std::string LoadedPlugin::Summary() const {
  std::string s = "loaded plugin " + name + " " + version + " from " + path + " (";
  if (!variable_names.empty()) s += Count(variable_names.size(), "variable type") + ", ";
  s += Count(type_names.size(), "factor type");
  if (!linear_solver_names.empty()) s += ", " + Count(linear_solver_names.size(), "linear solver");
  if (!loss_names.empty()) s += ", " + Count(loss_names.size(), "robust loss");
  for (const std::string& e : extension_names) s += ", " + e;
  return s + ")";
}

std::vector<std::string> PluginLoader::SearchPath() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("TETHER_PLUGIN_PATH")) {
    std::string s(env);
    std::size_t start = 0;
    while (start <= s.size()) {
      const std::size_t end = std::min(s.find(':', start), s.size());
      if (end > start) dirs.push_back(s.substr(start, end - start));
      start = end + 1;
    }
  }
  // The installed plugin folder: beside this library (lib/tether/plugins), which also holds
  // for a tree installed with `cmake --install --prefix`, then the configured one.
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&PluginLoader::Resolve), &info) != 0 && info.dli_fname != nullptr) {
    // Canonical, so that ".../bin/../lib" (an RPATH of $ORIGIN/../lib) matches the configured
    // folder below instead of listing it twice.
    std::error_code ec;
    const fs::path here = fs::canonical(fs::path(info.dli_fname).parent_path() / "tether" / "plugins", ec);
    if (!ec && IsDirectory(here.string())) dirs.push_back(here.string());
  }
  if (std::find(dirs.begin(), dirs.end(), TETHER_PLUGIN_INSTALL_DIR) == dirs.end()) {
    dirs.push_back(TETHER_PLUGIN_INSTALL_DIR);
  }
  return dirs;
}

std::string PluginLoader::Resolve(const std::string& path_or_name) {
  if (IsFile(path_or_name)) return fs::canonical(path_or_name).string();
  std::string searched = path_or_name;
  // A bare name (no folder) is looked up along the search path.
  if (path_or_name.find('/') == std::string::npos) {
    for (const std::string& dir : SearchPath()) {
      const std::string candidate = dir + "/" + path_or_name;
      if (IsFile(candidate)) return fs::canonical(candidate).string();
      searched += ", " + candidate;
    }
  }
  throw PluginError("plugin " + path_or_name + ": no such file (looked in: " + searched +
                    "); give the path of the .so, or add its folder to TETHER_PLUGIN_PATH");
}

LoadedPlugin PluginLoader::Load(const std::string& path_or_name) {
  const std::string path = Resolve(path_or_name);
  for (auto it = loaded_.begin(); it != loaded_.end(); ++it) {
    if (it->path != path) continue;
    // Loading the same file twice is harmless. But where its types were removed since
    // (Registry::RemoveOwner), it is registered afresh below, as a new loader would do.
    if (StillRegistered(*it, registry_, linear_solvers_, losses_)) return *it;
    loaded_.erase(it);
    break;
  }
  const PluginDescription* d = OpenDescription(path);
  const std::string name = d->name;
  for (const LoadedPlugin& p : loaded_) {
    if (p.name == name) {
      throw PluginError("plugin " + path + ": a plugin named '" + name + "' is loaded already from " + p.path +
                        "; load only one of them");
    }
  }
  const PluginRegistrar registrar = RunRegistration(*d, path);
  // All or nothing: trial copies take everything first, so a conflict leaves every registry
  // exactly as it was. Then the same entries go into the registries themselves, added beside
  // the entries already there: a FactorType found before the load stays where it is
  // (replacing the registry by the copy would free every one of them).
  LoadedPlugin loaded{name, d->version ? d->version : "", path, {}, {}, {}, {}, {}};
  TrialTypes(registrar, registry_, path, &loaded);
  const std::vector<LinearSolverEntry> solvers = TrialLinearSolvers(registrar, linear_solvers_, path, &loaded);
  const std::vector<LossEntry> losses = TrialLosses(registrar, losses_, path, &loaded);
  const auto kinds = TrialExtensions(registrar, path, &loaded);
  loaded_.reserve(loaded_.size() + 1);  // so that recording the plugin below cannot fail
  Commit(registrar, solvers, losses, kinds);
  loaded_.push_back(std::move(loaded));
  return loaded_.back();
}

void PluginLoader::Commit(const PluginRegistrar& registrar, const std::vector<LinearSolverEntry>& solvers,
                          const std::vector<LossEntry>& losses,
                          const std::vector<std::pair<PluginExtensionKind, const PluginExtension*>>& kinds) {
  std::size_t variables = 0, committed = 0, committed_solvers = 0, committed_losses = 0, extensions = 0;
  try {
    for (const VariableType& t : registrar.variable_types()) {
      registry_.RegisterVariable(t);
      ++variables;
    }
    for (const FactorType& t : registrar.factor_types()) {
      registry_.Register(t);
      ++committed;
    }
    for (const LinearSolverEntry& e : solvers) {
      linear_solvers_.Register(e);
      ++committed_solvers;
    }
    for (const LossEntry& e : losses) {
      losses_.Register(e);
      ++committed_losses;
    }
    for (const auto& [kind, extension] : kinds) {
      kind.commit(*extension, registrar.plugin_name());
      ++extensions;
    }
  } catch (...) {
    // Not expected (the trial took the same entries), short of memory: take back exactly
    // what this load added.
    for (std::size_t i = 0; i < committed; ++i) registry_.Remove(registrar.factor_types()[i].name);
    for (std::size_t i = 0; i < variables; ++i) registry_.RemoveVariable(registrar.variable_types()[i].name);
    for (std::size_t i = 0; i < committed_solvers; ++i) linear_solvers_.Remove(solvers[i].name);
    for (std::size_t i = 0; i < committed_losses; ++i) losses_.Remove(losses[i].name);
    for (std::size_t i = 0; i < extensions; ++i) kinds[i].first.remove(kinds[i].second->name);
    throw;
  }
}

}  // namespace tether
