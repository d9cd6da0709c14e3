#include "step_strategy.h"

#include <map>
#include <mutex>

#include "tether/core/error.h"
#include "tether/plugins/plugin.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {

namespace {

constexpr const char* kBuiltin[] = {"gn", "lm", "dogleg"};

// Guarded by Mutex(): a plugin may register while another thread looks a strategy up.
std::map<std::string, StepStrategyFactory>& Strategies() {
  static std::map<std::string, StepStrategyFactory> strategies;
  static std::once_flag once;
  std::call_once(once, [] {
    strategies.emplace("gn", internal::MakeGaussNewton);
    strategies.emplace("lm", internal::MakeLevenbergMarquardt);
    strategies.emplace("dogleg", internal::MakeDogLeg);
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

void CheckFree(const std::string& name) {
  if (name.empty()) throw InvalidArgument("a step strategy needs a name");
  if (name == "ceres" || Strategies().count(name) != 0) {
    throw InvalidArgument("cannot register step strategy '" + name + "': the name is taken already" +
                          (IsBuiltin(name) || name == "ceres" ? " (built in)" : "") + "; choose another name");
  }
}

// Plugins add step strategies through the loader's extension kinds: checked with the
// plugin's other types first, committed with them, taken back on failure.
const bool kPluginKindRegistered = [] {
  PluginExtensionKind kind;
  kind.check = [](const std::string& name) {
    std::lock_guard<std::mutex> lock(Mutex());
    CheckFree(name);
  };
  kind.commit = [](const PluginExtension& e) {
    RegisterStepStrategy(e.name, *std::static_pointer_cast<const StepStrategyFactory>(e.payload));
  };
  kind.remove = [](const std::string& name) { RemoveStepStrategy(name); };
  RegisterPluginExtensionKind("step strategy", std::move(kind));
  return true;
}();

}  // namespace

void RegisterStepStrategy(const std::string& name, StepStrategyFactory make) {
  if (!make) throw InvalidArgument("step strategy '" + name + "' has no factory");
  std::lock_guard<std::mutex> lock(Mutex());
  CheckFree(name);
  Strategies().emplace(name, std::move(make));
}

bool RemoveStepStrategy(const std::string& name) {
  if (IsBuiltin(name)) return false;
  std::lock_guard<std::mutex> lock(Mutex());
  return Strategies().erase(name) != 0;
}

const StepStrategyFactory* FindStepStrategy(const std::string& name) {
  std::lock_guard<std::mutex> lock(Mutex());
  const auto& s = Strategies();
  const auto it = s.find(name);
  return it == s.end() ? nullptr : &it->second;  // map nodes stay put until removed
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
