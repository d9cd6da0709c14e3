#pragma once
// Robust losses by name, as factor types and linear solvers are. Every text form of a loss
// (MakeLoss, `tether optimize --robust loop=NAME:SCALE`, Python's make_loss and its loss=
// arguments) is looked up here:
//
//   NAME                 scale 1, and the entry's default parameter where it takes one
//   NAME:SCALE           the scale: a finite number above 0, in whitened units (standard deviations)
//   NAME:SCALE:PARAM     only for a loss that takes a parameter (LossEntry::parameter), e.g.
//                        barron:1:-2 (Barron's loss with alpha -2); any number but NaN, the
//                        loss's factory refuses what else it cannot take
//
// The built-in losses of robust_kernels.h (huber, cauchy, tukey, gm, dcs) are registered into
// DefaultLossRegistry() when it is first used, through Register, the same call a plugin's
// losses go through (PluginRegistrar::AddLoss, tether/plugins/plugin.h; the loader commits
// them all or none, like factor types). A name is taken once: a second entry of the same name
// is refused, naming both owners. Unknown names are refused with the list of registered ones.
//
// Lifetime: a plugin's losses stay registered until RemoveOwner(plugin name). The loss
// objects made from them stay valid after that (a plugin is never unloaded).
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "tether/core/loss_function.h"

namespace tether {

/// Makes a loss from its scale (checked already: finite, above 0) and parameter (the text's
/// PARAM, or the entry's default_parameter; never NaN; 0 for a loss without one). Throws
/// InvalidArgument for values it cannot take, saying which.
using LossFactory = std::function<std::shared_ptr<const LossFunction>(double scale, double parameter)>;

struct LossEntry {
  std::string name;               ///< what the text form names, e.g. "huber": letters, digits, '_', '-'
  std::string owner = "builtin";  ///< who registered it (the plugin's name for plugins)
  /// The name of the optional number after the scale (NAME:SCALE:PARAM), e.g. "alpha"; empty
  /// (the default): the loss takes none, and NAME:SCALE:PARAM is refused.
  std::string parameter;
  double default_parameter = 0;  ///< the parameter where the text gives none
  std::string description;       ///< one line for listings, e.g. "Cauchy: c^2 log(1 + s / c^2)"
  LossFactory make;
};

/// A loss's text form, read but not looked up (ParseLossSpec).
struct LossSpec {
  std::string name;
  double scale = 1;
  bool has_parameter = false;
  double parameter = 0;
};

/// Reads NAME[:SCALE[:PARAM]]; throws InvalidArgument naming the text where a field is
/// missing, not a number, or there are too many. The values are not checked here.
LossSpec ParseLossSpec(const std::string& spec);

/// Robust losses by name, in the order they were registered. Thread-safe: a plugin may
/// register while another thread makes a loss.
class LossRegistry {
 public:
  LossRegistry() = default;  ///< empty; DefaultLossRegistry() holds the built-ins
  LossRegistry(const LossRegistry& other);
  LossRegistry& operator=(const LossRegistry& other);

  /// Throws InvalidArgument where the name is empty, holds other characters than letters,
  /// digits, '_' and '-', or is taken (naming both owners), or `make` is missing.
  void Register(LossEntry entry);
  /// Removes the entry of that name; false if there is none.
  bool Remove(const std::string& name);
  /// Removes every entry registered by `owner`; returns how many.
  int RemoveOwner(const std::string& owner);
  /// A copy of the entry of that name into *out (when not null); false where there is none.
  bool Get(const std::string& name, LossEntry* out = nullptr) const;
  /// The registered names, in the order they were registered.
  std::vector<std::string> Names() const;
  /// Copies of the registered entries in that order (name, owner, parameter, description),
  /// for listings such as `tether plugins list`.
  std::vector<LossEntry> Entries() const;
  /// The registered losses for help texts and messages, in that order: a plugin's with its
  /// owner, one with a parameter with its form, e.g.
  /// "huber, cauchy, tukey, gm, dcs, barron (plugin barron_loss; barron:SCALE:ALPHA, alpha 1 if omitted)".
  std::string NamesText() const;
  /// The loss the text form names (see the top of this file). Throws InvalidArgument naming
  /// the text: for a malformed text, an unknown name (listing the registered ones and how to
  /// add one), a scale that is not a finite number above 0, a parameter the loss does not
  /// take or whose factory refuses it.
  std::shared_ptr<const LossFunction> Make(const std::string& spec) const;

 private:
  mutable std::mutex mutex_;
  std::vector<LossEntry> entries_;
};

/// The process-wide registry, holding the built-in losses from its first use
/// (RegisterBuiltinLosses, robust_kernels.h).
LossRegistry& DefaultLossRegistry();

/// The losses registered in DefaultLossRegistry(), in registration order: the built-ins,
/// then those of the plugins loaded so far.
std::vector<std::string> RegisteredLossNames();
/// DefaultLossRegistry().NamesText(), for help texts: "huber, cauchy, tukey, gm, dcs" and
/// whatever plugins added.
std::string RegisteredLossesText();

/// A loss from its text form, looked up in DefaultLossRegistry() (LossRegistry::Make):
/// "huber:1.0", "cauchy:2", "tukey:4.685", "gm:1", "dcs:1", "cauchy" (scale 1), or a
/// plugin's, e.g. "barron:1:0.5".
std::shared_ptr<const LossFunction> MakeLoss(const std::string& spec);

/// A loss's name for LossFunction::name(): "NAME:SCALE" with the shortest text that reads
/// back as the same numbers ("huber:1.5").
std::string LossName(const std::string& name, double scale);
/// The same with the parameter: "barron:1:-2".
std::string LossName(const std::string& name, double scale, double parameter);

}  // namespace tether
