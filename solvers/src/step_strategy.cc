#include "step_strategy.h"

#include <map>
#include <mutex>

#include "tether/core/error.h"

namespace tether {
namespace internal {

namespace {

std::map<std::string, StepStrategyFactory>& Strategies() {
  static std::map<std::string, StepStrategyFactory> strategies;
  static std::once_flag once;
  std::call_once(once, [] {
    strategies.emplace("gn", MakeGaussNewton);
    strategies.emplace("lm", MakeLevenbergMarquardt);
    strategies.emplace("dogleg", MakeDogLeg);
  });
  return strategies;
}

}  // namespace

void RegisterStepStrategy(const std::string& name, StepStrategyFactory make) {
  if (name.empty() || !make) throw InvalidArgument("a step strategy needs a name and a factory");
  if (name == "ceres" || !Strategies().emplace(name, std::move(make)).second) {
    throw InvalidArgument("cannot register step strategy '" + name + "': the name is taken already");
  }
}

const StepStrategyFactory* FindStepStrategy(const std::string& name) {
  const auto& s = Strategies();
  const auto it = s.find(name);
  return it == s.end() ? nullptr : &it->second;
}

std::vector<std::string> StepStrategyNames() {
  std::vector<std::string> names;
  for (const auto& kv : Strategies()) names.push_back(kv.first);
  return names;
}

}  // namespace internal
}  // namespace tether
