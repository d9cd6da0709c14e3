#pragma once
// Which factors of a graph get which robust loss: rules of the form SELECTOR=NAME:SCALE, as
// `tether optimize --robust` takes them.
//
//   loop=huber:1.0      the factors marked as loop closures (Factor::loop_closure)
//   all=cauchy:2        every factor
//   EDGE_SE2=dcs:1      the factors of the type with that g2o tag
//   loop                a selector alone: huber:1 (the loop-closure default)
//   loop=barron:1:0.5   a loss with a parameter, here one a plugin registered
//
// NAME is looked up in the loss registry (loss_registry.h): the built-in losses and those of
// the plugins loaded. Rules apply in order; a later rule replaces the loss an earlier one
// gave a factor.
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/loss_function.h"
#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"

namespace tether {

struct RobustRule {
  std::string selector;  ///< "loop", "all", or a g2o tag
  /// The loss, made when the rule was parsed; null where its name was not registered then
  /// (a plugin's loss, the plugin loaded after the rule was parsed): ApplyRobustRules makes it
  /// from `loss_spec`.
  std::shared_ptr<const LossFunction> loss;
  std::string loss_spec;  ///< the loss's text form, e.g. "huber:1"
};

/// Parses one rule; throws InvalidArgument naming the text and the accepted forms, for a
/// malformed text, or a registered loss that refuses its scale or parameter. A loss name
/// `losses` does not hold yet is left for ApplyRobustRules to look up (the loss stays null).
RobustRule ParseRobustRule(const std::string& text, const LossRegistry& losses = DefaultLossRegistry());

/// Throws InvalidArgument, as ApplyRobustRules would, for a rule whose tag no type of
/// `registry` has or whose loss `losses` cannot make; changes nothing.
void CheckRobustRules(const std::vector<RobustRule>& rules, const Registry& registry,
                      const LossRegistry& losses = DefaultLossRegistry());

/// Sets the loss of every factor each rule selects; returns how many factors carry a loss
/// from the rules. Throws InvalidArgument (before changing anything) for a tag no type of
/// `registry` has, or a rule's loss that `losses` cannot make (an unknown name: the message
/// lists the registered ones).
int ApplyRobustRules(const std::vector<RobustRule>& rules, const Registry& registry, FactorGraph* graph,
                     const LossRegistry& losses = DefaultLossRegistry());

}  // namespace tether
