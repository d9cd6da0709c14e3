// `tether plugins list`: the plugins loaded and every registered variable and factor type.
#include <cstdio>
#include <ostream>

#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/tools/commands.h"

namespace tether {

int RunPluginsList(const PluginsListCommand& cmd, std::ostream& out, std::ostream& err) {
  Registry& registry = DefaultRegistry();
  PluginLoader loader(registry);
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return kExitPluginFailed;
  out << "plugin search path (after explicit paths):";
  for (const std::string& d : PluginLoader::SearchPath()) out << " " << d;
  out << "\n";
  char line[512];
  std::snprintf(line, sizeof(line), "%-20s %-24s %-22s %s\n", "variable type", "g2o vertex tag", "ambient/tangent",
                "owner");
  out << line;
  for (const auto& [name, id] : registry.variable_types()) {
    const VariableType& d = Describe(id);
    const std::string sizes = std::to_string(d.ambient_dim) + "/" + std::to_string(d.tangent_dim);
    std::snprintf(line, sizeof(line), "%-20s %-24s %-22s %s\n", name.c_str(), d.tag.empty() ? "(none)" : d.tag.c_str(),
                  sizes.c_str(), registry.VariableOwner(name).c_str());
    out << line;
  }
  out << "\n";
  std::snprintf(line, sizeof(line), "%-20s %-24s %4s  %-20s %s\n", "factor type", "g2o tag", "dim", "variables",
                "owner");
  out << line;
  for (const auto& [name, t] : registry.types()) {
    std::string vars;
    for (VarType v : t.variable_types) vars += (vars.empty() ? "" : " ") + std::string(ToString(v));
    std::snprintf(line, sizeof(line), "%-20s %-24s %4d  %-20s %s\n", name.c_str(),
                  t.tag.empty() ? "(none)" : t.tag.c_str(), t.dim, vars.c_str(), t.owner.c_str());
    out << line;
  }
  out << "\n";
  std::snprintf(line, sizeof(line), "%-20s %-14s %-22s %s\n", "robust loss", "parameter", "owner", "description");
  out << line;
  for (const LossEntry& e : DefaultLossRegistry().Entries()) {
    std::snprintf(line, sizeof(line), "%-20s %-14s %-22s %s\n", e.name.c_str(),
                  e.parameter.empty() ? "(none)" : e.parameter.c_str(), e.owner.c_str(), e.description.c_str());
    out << line;
  }
  return 0;
}

namespace {

class PluginsCli : public Command {
 public:
  void Add(CLI::App& app) override {
    CLI::App* plugins = app.add_subcommand("plugins", "Factor plugins");
    plugins->require_subcommand(1);
    CLI::App* list = app_ = plugins->add_subcommand("list", "List loaded plugins and every registered factor type");
    list->add_option("--plugin", cmd_.plugins, "Load this plugin first; repeatable")->allow_extra_args(false);
  }
  int Run(std::ostream& out, std::ostream& err) override { return RunPluginsList(cmd_, out, err); }

 private:
  PluginsListCommand cmd_;
};

}  // namespace

std::unique_ptr<Command> MakePluginsCommand() { return std::make_unique<PluginsCli>(); }

}  // namespace tether
