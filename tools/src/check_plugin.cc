// `tether check-plugin PLUGIN.so`: loads a plugin as `optimize --plugin` does and checks the
// Jacobians of every factor type it registers at random points (tether/plugins/plugin_check.h).
#include <ostream>

#include "tether/core/error.h"
#include "tether/plugins/plugin_check.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

class CheckPluginCli : public Command {
 public:
  void Add(CLI::App& app) override {
    CLI::App* sub = app_ = app.add_subcommand(
        "check-plugin",
        "Check the Jacobians of every factor type a plugin registers against central differences, at random points");
    sub->add_option("plugin", plugin_, "The plugin (.so path or name)")->required();
    sub->add_option("--trials", options_.trials, "Random points per factor type")->capture_default_str();
    sub->add_option("--seed", options_.seed, "The random points' seed")->capture_default_str();
    sub->add_option("--tolerance", options_.jacobian.absolute_tolerance,
                    "An entry passes within this plus the same share of the numeric value")
        ->capture_default_str();
    sub->add_flag("-q,--quiet", quiet_, "Only the lines of the types that fail");
  }

  int Run(std::ostream& out, std::ostream& err) override {
    options_.jacobian.relative_tolerance = options_.jacobian.absolute_tolerance;
    Registry registry;  // the built-in variable types, and no factor types but the plugin's
    PluginLoader loader(registry);
    LoadedPlugin plugin;
    try {
      plugin = loader.Load(plugin_);
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return kExitPluginFailed;
    }
    if (!quiet_) out << plugin.Summary() << "\n";
    if (plugin.type_names.empty()) {
      out << plugin.name << " registers no factor type: nothing to check\n";
      return kExitOk;
    }
    std::vector<FactorTypeCheck> checks;
    try {
      checks = CheckFactorTypes(registry, plugin.type_names, options_);
    } catch (const InvalidArgument& e) {
      err << "tether check-plugin: " << e.what() << "\n";
      return kExitUsage;
    }
    bool ok = true;
    for (const FactorTypeCheck& c : checks) {
      if (!c.ok() && !c.first_failure.empty()) {
        out << c.first_failure << (c.first_failure.back() == '\n' ? "" : "\n");
      }
      if (!quiet_ || !c.ok()) out << c.Line() << "\n";
      ok = ok && c.ok();
    }
    return ok ? kExitOk : kExitBadInput;
  }

 private:
  std::string plugin_;
  FactorTypeCheckOptions options_;
  bool quiet_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeCheckPluginCommand() { return std::make_unique<CheckPluginCli>(); }

}  // namespace tether
