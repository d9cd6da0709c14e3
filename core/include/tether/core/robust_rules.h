#pragma once
// Which factors of a graph get which robust loss: rules of the form SELECTOR=NAME:SCALE, as
// `tether optimize --robust` takes them.
//
//   loop=huber:1.0      the factors marked as loop closures (Factor::loop_closure)
//   all=cauchy:2        every factor
//   EDGE_SE2=dcs:1      the factors of the type with that g2o tag
//   loop                a selector alone: huber:1 (the loop-closure default)
//
// Rules apply in order; a later rule replaces the loss an earlier one gave a factor.
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/loss_function.h"
#include "tether/core/registry.h"

namespace tether {

struct RobustRule {
  std::string selector;  ///< "loop", "all", or a g2o tag
  std::shared_ptr<const LossFunction> loss;
};

/// Parses one rule; throws InvalidArgument naming the text and the accepted forms.
RobustRule ParseRobustRule(const std::string& text);

/// Throws InvalidArgument for a rule whose tag no type of `registry` has.
void CheckRobustRules(const std::vector<RobustRule>& rules, const Registry& registry);

/// Sets the loss of every factor each rule selects; returns how many factors carry a loss
/// from the rules. Throws InvalidArgument for a tag no type of `registry` has (before
/// changing anything).
int ApplyRobustRules(const std::vector<RobustRule>& rules, const Registry& registry, FactorGraph* graph);

}  // namespace tether
