#pragma once
// Loads plugins with dlopen(RTLD_NOW | RTLD_LOCAL) and registers their variable types, factor
// types, linear solvers and robust losses.
//
// Search order for Load(name): a path that exists as given (absolute or relative to the
// working directory); then each folder of TETHER_PLUGIN_PATH (colon-separated); then the
// installed plugin folder: lib/tether/plugins beside the installed libtether_plugins.so
// (so a relocated install finds its own plugins), and the one configured at build time.
//
// Lifetime: a loaded plugin stays loaded for the rest of the process (it is never
// dlclose'd), so factors it created stay valid whatever happens to the loader. Its types
// stay registered until Registry::RemoveOwner(plugin name), which is only safe once no
// factor of those types exists. A FactorType pointer or reference found in the registry
// (FindByTag, FindByName) stays valid until its own owner is removed: loading other plugins,
// or failing to, moves no registered type. A plugin's robust losses stay registered until
// LossRegistry::RemoveOwner(plugin name); losses made from them stay valid after that.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/linear_solver.h"
#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"
#include "tether/plugins/plugin.h"

namespace tether {

/// A plugin could not be loaded; the message names the file and what to do.
class PluginError : public Error {
 public:
  using Error::Error;
};

struct LoadedPlugin {
  std::string name;
  std::string version;
  std::string path;                              ///< canonical path of the shared library
  std::vector<std::string> type_names;           ///< factor types it registered
  std::vector<std::string> variable_names;       ///< variable types it registered
  std::vector<std::string> linear_solver_names;  ///< linear solvers it registered
  std::vector<std::string> extension_names;      ///< extensions it registered: "step strategy 'name'"
  std::vector<std::string> loss_names;           ///< robust losses it registered
  /// "loaded plugin NAME VERSION from PATH (1 variable type, 2 factor types, 1 linear solver,
  /// 1 robust loss)".
  std::string Summary() const;
};

/// How the loader registers one kind of PluginExtension for the plugin `owner`. `check` throws
/// (InvalidArgument) where another owner holds the name, and returns false where `owner` holds
/// it already (a second loader, a reload: nothing to do); `commit` registers it; `remove`
/// takes it back.
struct PluginExtensionKind {
  std::function<bool(const std::string& name, const std::string& owner)> check;
  std::function<void(const PluginExtension& extension, const std::string& owner)> commit;
  std::function<void(const std::string& name)> remove;
};

/// Makes a kind of extension known to every loader (called once by the module that owns the
/// kind, when it is loaded; throws InvalidArgument where the kind is known already).
void RegisterPluginExtensionKind(const std::string& kind, PluginExtensionKind handler);

class PluginLoader {
 public:
  /// Factor types go to `registry`, linear solvers to `linear_solvers`, robust losses to `losses`.
  explicit PluginLoader(Registry& registry, LinearSolverRegistry& linear_solvers = DefaultLinearSolverRegistry(),
                        LossRegistry& losses = DefaultLossRegistry())
      : registry_(registry), linear_solvers_(linear_solvers), losses_(losses) {}

  /// Loads and registers a plugin. Loading the same file again returns the earlier result
  /// and changes nothing. Throws PluginError.
  LoadedPlugin Load(const std::string& path_or_name);
  const std::vector<LoadedPlugin>& loaded() const { return loaded_; }

  /// Where Load looks for a bare file name, in order.
  static std::vector<std::string> SearchPath();
  /// The file Load would open for `path_or_name`; throws PluginError listing the places
  /// searched when there is none.
  static std::string Resolve(const std::string& path_or_name);

 private:
  // Registers what the trials accepted, all of it or (on an unexpected failure) none of it.
  void Commit(const PluginRegistrar& registrar, const std::vector<LinearSolverEntry>& solvers,
              const std::vector<LossEntry>& losses,
              const std::vector<std::pair<PluginExtensionKind, const PluginExtension*>>& kinds);

  Registry& registry_;
  LinearSolverRegistry& linear_solvers_;
  LossRegistry& losses_;
  std::vector<LoadedPlugin> loaded_;
};

}  // namespace tether
