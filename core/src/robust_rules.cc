#include "tether/core/robust_rules.h"

#include <set>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"

namespace tether {

RobustRule ParseRobustRule(const std::string& text) {
  const std::size_t eq = text.find('=');
  RobustRule rule;
  rule.selector = text.substr(0, eq);
  if (rule.selector.empty()) {
    throw InvalidArgument("robust rule '" + text +
                          "': no selector before '=' (write loop=huber:1.0, all=cauchy:2 or TAG=KERNEL:SCALE)");
  }
  const std::string loss = eq == std::string::npos ? "huber:1" : text.substr(eq + 1);
  try {
    rule.loss = MakeLoss(loss);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument("robust rule '" + text + "': " + e.what());
  }
  return rule;
}

namespace {

// The type name each rule's tag selects (empty for "loop" and "all"); throws for a tag no type
// has.
std::vector<std::string> SelectedTypes(const std::vector<RobustRule>& rules, const Registry& registry) {
  std::vector<std::string> names(rules.size());
  for (std::size_t r = 0; r < rules.size(); ++r) {
    const std::string& s = rules[r].selector;
    if (s == "loop" || s == "all") continue;
    const FactorType* type = registry.FindByTag(s);
    if (type == nullptr) {
      throw InvalidArgument("robust rule for '" + s +
                            "': no factor type has that g2o tag (selectors: loop, all, or a tag such as EDGE_SE2)");
    }
    names[r] = type->name;
  }
  return names;
}

}  // namespace

void CheckRobustRules(const std::vector<RobustRule>& rules, const Registry& registry) {
  SelectedTypes(rules, registry);
}

int ApplyRobustRules(const std::vector<RobustRule>& rules, const Registry& registry, FactorGraph* graph) {
  const std::vector<std::string> names = SelectedTypes(rules, registry);  // checked before anything changes
  std::set<std::size_t> given;
  for (std::size_t r = 0; r < rules.size(); ++r) {
    const std::string& s = rules[r].selector;
    for (std::size_t i = 0; i < graph->size(); ++i) {
      Factor& f = graph->at(i);
      const bool selected = s == "all" || (s == "loop" ? f.loop_closure() : f.type_name() == names[r]);
      if (!selected) continue;
      f.set_loss(rules[r].loss);
      given.insert(i);
    }
  }
  return static_cast<int>(given.size());
}

}  // namespace tether
