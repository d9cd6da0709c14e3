#include "tether/core/robust_rules.h"

#include <set>

#include "tether/core/error.h"

namespace tether {

RobustRule ParseRobustRule(const std::string& text, const LossRegistry& losses) {
  const std::size_t eq = text.find('=');
  RobustRule rule;
  rule.selector = text.substr(0, eq);
  if (rule.selector.empty()) {
    throw InvalidArgument("robust rule '" + text +
                          "': no selector before '=' (write loop=huber:1.0, all=cauchy:2 or TAG=KERNEL:SCALE)");
  }
  rule.loss_spec = eq == std::string::npos ? "huber:1" : text.substr(eq + 1);
  try {
    // The form is checked now; a name not registered yet may be a plugin's, loaded later.
    if (losses.Get(ParseLossSpec(rule.loss_spec).name)) rule.loss = losses.Make(rule.loss_spec);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument("robust rule '" + text + "': " + e.what());
  }
  return rule;
}

namespace {

// What each rule selects and gives, found before anything changes: the type name its tag
// selects (empty for "loop" and "all") and its loss. Throws for a tag no type has or a loss
// that cannot be made.
struct ResolvedRules {
  std::vector<std::string> names;
  std::vector<std::shared_ptr<const LossFunction>> losses;
};

ResolvedRules Resolve(const std::vector<RobustRule>& rules, const Registry& registry, const LossRegistry& losses) {
  ResolvedRules out;
  out.names.resize(rules.size());
  out.losses.resize(rules.size());
  for (std::size_t r = 0; r < rules.size(); ++r) {
    out.losses[r] = rules[r].loss;
    if (out.losses[r] == nullptr) {
      try {
        out.losses[r] = losses.Make(rules[r].loss_spec);
      } catch (const InvalidArgument& e) {
        throw InvalidArgument("robust rule '" + rules[r].selector + "=" + rules[r].loss_spec + "': " + e.what());
      }
    }
    const std::string& s = rules[r].selector;
    if (s == "loop" || s == "all") continue;
    const FactorType* type = registry.FindByTag(s);
    if (type == nullptr) {
      throw InvalidArgument("robust rule for '" + s +
                            "': no factor type has that g2o tag (selectors: loop, all, or a tag such as EDGE_SE2)");
    }
    out.names[r] = type->name;
  }
  return out;
}

}  // namespace

void CheckRobustRules(const std::vector<RobustRule>& rules, const Registry& registry, const LossRegistry& losses) {
  Resolve(rules, registry, losses);
}

int ApplyRobustRules(const std::vector<RobustRule>& rules, const Registry& registry, FactorGraph* graph,
                     const LossRegistry& losses) {
  const ResolvedRules resolved = Resolve(rules, registry, losses);
  std::set<std::size_t> given;
  for (std::size_t r = 0; r < rules.size(); ++r) {
    const std::string& s = rules[r].selector;
    for (std::size_t i = 0; i < graph->size(); ++i) {
      Factor& f = graph->at(i);
      const bool selected = s == "all" || (s == "loop" ? f.loop_closure() : f.type_name() == resolved.names[r]);
      if (!selected) continue;
      f.set_loss(resolved.losses[r]);
      given.insert(i);
    }
  }
  return static_cast<int>(given.size());
}

}  // namespace tether
