#include "step_strategy.h"

#include <map>
#include <mutex>

#include "tether/core/error.h"
#include "tether/plugins/plugin.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {

namespace {

constexpr const char* kBuiltin[] = {"gn", "lm", "dogleg"};

struct Entry {
  StepStrategyFactory make;
  std::string owner;  // "builtin", a plugin's name, or "" (a program's own)
};

// Guarded by Mutex(): a plugin may register while another thread looks a strategy up.
std::map<std::string, Entry>& Strategies() {
  static std::map<std::string, Entry> strategies;
  static std::once_flag once;
  std::call_once(once, [] {
    strategies.emplace("gn", Entry{internal::MakeGaussNewton, "builtin"});
    strategies.emplace("lm", Entry{internal::MakeLevenbergMarquardt, "builtin"});
    strategies.emplace("dogleg", Entry{internal::MakeDogLeg, "builtin"});
  });
  return strategies;
}

std::mutex& Mutex() {
  static std::mutex m;
  return m;
}

bool IsBuiltin(const std::string& name) {
  for (const char* b : kBuiltin)
    if (name == b) return true;
  return false;
}

// True where `owner` may register `name` (false: it holds it already); throws where another
// owner holds it.
bool CheckFree(const std::string& name, const std::string& owner) {
  if (name.empty()) throw InvalidArgument("a step strategy needs a name");
  const auto it = Strategies().find(name);
  if (it != Strategies().end() && !owner.empty() && it->second.owner == owner) return false;
  if (name == "ceres" || it != Strategies().end()) {
    const std::string who = name == "ceres" || IsBuiltin(name) ? " (built in)"
                            : it->second.owner.empty()         ? " (by the program)"
                                                               : " (by plugin '" + it->second.owner + "')";
    throw InvalidArgument("cannot register step strategy '" + name + "': the name is taken already" + who +
                          "; choose another name");
  }
  return true;
}

void Insert(const std::string& name, StepStrategyFactory make, const std::string& owner) {
  if (!make) throw InvalidArgument("step strategy '" + name + "' has no factory");
  std::lock_guard<std::mutex> lock(Mutex());
  if (CheckFree(name, owner)) Strategies().emplace(name, Entry{std::move(make), owner});
}

// Plugins add step strategies through the loader's extension kinds: checked with the
// plugin's other types first, committed with them, taken back on failure.
const bool kPluginKindRegistered = [] {
  PluginExtensionKind kind;
  kind.check = [](const std::string& name, const std::string& owner) {
    std::lock_guard<std::mutex> lock(Mutex());
    return CheckFree(name, owner);
  };
  kind.commit = [](const PluginExtension& e, const std::string& owner) {
    Insert(e.name, *std::static_pointer_cast<const StepStrategyFactory>(e.payload), owner);
  };
  kind.remove = [](const std::string& name) { RemoveStepStrategy(name); };
  RegisterPluginExtensionKind("step strategy", std::move(kind));
  return true;
}();

}  // namespace

void RegisterStepStrategy(const std::string& name, StepStrategyFactory make) { Insert(name, std::move(make), ""); }

bool RemoveStepStrategy(const std::string& name) {
  if (IsBuiltin(name)) return false;
  std::lock_guard<std::mutex> lock(Mutex());
  return Strategies().erase(name) != 0;
}

StepStrategyFactory FindStepStrategy(const std::string& name) {
  std::lock_guard<std::mutex> lock(Mutex());
  const auto& s = Strategies();
  const auto it = s.find(name);
  return it == s.end() ? StepStrategyFactory() : it->second.make;
}

std::vector<std::string> StepStrategyNames() {
  std::lock_guard<std::mutex> lock(Mutex());
  std::vector<std::string> names;
  for (const auto& kv : Strategies()) names.push_back(kv.first);
  return names;
}

void AddStepStrategy(PluginRegistrar& registrar, const std::string& name, StepStrategyFactory make) {
  if (!make) throw InvalidArgument("step strategy '" + name + "' has no factory");
  (void)kPluginKindRegistered;
  registrar.AddExtension(
      PluginExtension{"step strategy", name, std::make_shared<StepStrategyFactory>(std::move(make))});
}

}  // namespace tether
