#pragma once
// What a plugin includes (variable types, factor types, linear solvers, robust losses). A
// plugin is a shared library that exports one C function,
//
//   extern "C" const tether::PluginDescription* tether_plugin_entry();
//
// written for you by TETHER_PLUGIN(name, version, register_function). The loader checks the
// interface version and the build fingerprint, then calls register_function with a
// PluginRegistrar; the variable and factor types it adds are committed to the registry all
// at once, or not at all. No static initialisers take part: nothing happens until the loader
// asks. Each factor type is checked against a probe factor made by its `make` (name,
// dimension, variable types), so a mismatch is refused at load time, naming the field.
//
//   void RegisterMyTypes(tether::PluginRegistrar& r) {
//     r.AddVariableType<MyScale>();                       // a value type with VariableTraits
//     r.AddFactorType(tether::DescribeFactor<MyFactor>("EDGE_MY", 1, make));
//     r.AddLinearSolver("my_solver", make_solver);         // tether/core/linear_solver.h
//     r.AddLoss(my_loss_entry);                            // tether/core/loss_registry.h
//   }
//   TETHER_PLUGIN("my_factors", "1.0.0", RegisterMyTypes)
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/linear_solver.h"
#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"
#include "tether/core/version.h"

/// Changes whenever PluginDescription or the registration contract changes.
#define TETHER_PLUGIN_INTERFACE_VERSION 2
/// The symbol the loader looks up.
#define TETHER_PLUGIN_ENTRY_SYMBOL "tether_plugin_entry"

namespace tether {

/// Build settings that must agree between tether and a plugin: the layout of Eigen's
/// fixed-size types and of tether's own classes depends on them.
struct BuildFingerprint {
  int tether_major, tether_minor, tether_patch;
  int eigen_world, eigen_major, eigen_minor;
  int eigen_max_align_bytes;         ///< EIGEN_MAX_ALIGN_BYTES
  int eigen_max_static_align_bytes;  ///< EIGEN_MAX_STATIC_ALIGN_BYTES
  int eigen_vectorize;               ///< 1 where EIGEN_VECTORIZE is defined
  int eigen_dont_align;              ///< 1 where EIGEN_DONT_ALIGN is defined
  int cxx11_abi;                     ///< _GLIBCXX_USE_CXX11_ABI (-1 elsewhere)
  int pointer_bytes;
};

/// The fingerprint of the translation unit that calls it (inline on purpose: a plugin gets its
/// own compiler's view, tether its own).
inline BuildFingerprint CurrentBuildFingerprint() {
  BuildFingerprint f{};
  f.tether_major = TETHER_VERSION_MAJOR;
  f.tether_minor = TETHER_VERSION_MINOR;
  f.tether_patch = TETHER_VERSION_PATCH;
  f.eigen_world = EIGEN_WORLD_VERSION;
  f.eigen_major = EIGEN_MAJOR_VERSION;
  f.eigen_minor = EIGEN_MINOR_VERSION;
  f.eigen_max_align_bytes = EIGEN_MAX_ALIGN_BYTES;
  f.eigen_max_static_align_bytes = EIGEN_MAX_STATIC_ALIGN_BYTES;
#ifdef EIGEN_VECTORIZE
  f.eigen_vectorize = 1;
#endif
#ifdef EIGEN_DONT_ALIGN
  f.eigen_dont_align = 1;
#endif
#ifdef _GLIBCXX_USE_CXX11_ABI
  f.cxx11_abi = _GLIBCXX_USE_CXX11_ABI;
#else
  f.cxx11_abi = -1;
#endif
  f.pointer_bytes = static_cast<int>(sizeof(void*));
  return f;
}

/// One line per field that differs: "eigen_max_align_bytes: tether 16, plugin 32".
std::vector<std::string> CompareFingerprints(const BuildFingerprint& tether, const BuildFingerprint& plugin);

/// Something a plugin adds that a module above plugins knows how to register (a step strategy:
/// tether/solvers/step_strategy.h, AddStepStrategy). `kind` names the handler
/// (RegisterPluginExtensionKind, plugin_loader.h); `payload` is the handler's to interpret.
struct PluginExtension {
  std::string kind;
  std::string name;
  std::shared_ptr<const void> payload;
};

/// Collects what a plugin registers; the loader commits it to the registry afterwards.
class PluginRegistrar {
 public:
  explicit PluginRegistrar(std::string plugin_name) : plugin_(std::move(plugin_name)) {}
  /// Adds a factor type; its owner is set to the plugin's name.
  void AddFactorType(FactorType type);
  /// Adds a variable type; its owner is set to the plugin's name. The type gets its id at once
  /// (so that factor types added after it can name it); its tag reaches the registry when
  /// the plugin is committed. Throws InvalidArgument for an incomplete description or a name
  /// that exists with other sizes.
  void AddVariableType(VariableType type);
  /// The same for a value type with a VariableTraits specialisation.
  template <class V>
  void AddVariableType() {
    AddVariableType(DescribeVariable<V>());
  }
  const std::vector<FactorType>& factor_types() const { return types_; }
  const std::vector<VariableType>& variable_types() const { return variables_; }
  /// Adds a linear solver (tether/core/linear_solver.h) under `name`, selected with
  /// SolverOptions::linear_solver or `--linear name`. By default it is given the normal
  /// equations and is not direct (its factorisation is not reused across steps).
  void AddLinearSolver(const std::string& name, LinearSolverFactory make);
  /// The same with every field of the entry given; its owner is set to the plugin's name.
  void AddLinearSolver(LinearSolverEntry entry);
  const std::vector<LinearSolverEntry>& linear_solvers() const { return linear_solvers_; }
  /// Adds a robust loss (tether/core/loss_registry.h) under entry.name, for the text forms
  /// NAME:SCALE (and NAME:SCALE:PARAM where entry.parameter is set) of MakeLoss, `--robust`
  /// and Python; its owner is set to the plugin's name. A name taken already (a built-in's or
  /// another plugin's) registers nothing of the plugin.
  void AddLoss(LossEntry entry);
  /// The same for a loss without a parameter.
  void AddLoss(const std::string& name, LossFactory make);
  const std::vector<LossEntry>& losses() const { return losses_; }
  /// Adds an extension of a kind a module above plugins registers (see PluginExtension).
  void AddExtension(PluginExtension extension) { extensions_.push_back(std::move(extension)); }
  const std::vector<PluginExtension>& extensions() const { return extensions_; }
  const std::string& plugin_name() const { return plugin_; }

 private:
  std::string plugin_;
  std::vector<FactorType> types_;
  std::vector<VariableType> variables_;
  std::vector<LinearSolverEntry> linear_solvers_;
  std::vector<PluginExtension> extensions_;
  // Last, and only touched by functions compiled into tether (AddLoss is not inline): a
  // plugin built before losses existed sees the members above where it expects them, and
  // still loads (the interface version did not change).
  std::vector<LossEntry> losses_;
};

struct PluginDescription {
  int interface_version;  ///< TETHER_PLUGIN_INTERFACE_VERSION when the plugin was built
  const char* name;       ///< unique plugin name, e.g. "range_factors"
  const char* version;    ///< the plugin's own version
  BuildFingerprint fingerprint;
  void (*register_types)(PluginRegistrar& registrar);
};

}  // namespace tether

/// Defines the entry function of a plugin.
#define TETHER_PLUGIN(NAME, VERSION, REGISTER_FUNCTION)                                                              \
  extern "C" __attribute__((visibility("default"))) const ::tether::PluginDescription* tether_plugin_entry() {       \
    static const ::tether::PluginDescription description = {TETHER_PLUGIN_INTERFACE_VERSION, NAME, VERSION,          \
                                                            ::tether::CurrentBuildFingerprint(), REGISTER_FUNCTION}; \
    return &description;                                                                                             \
  }
