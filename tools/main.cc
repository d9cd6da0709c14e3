// tether: the command-line program. `tether --help` lists the commands; each lives in a file of
// its own in tools/src/ (docs/architecture.md), and this file is only their table.
#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/version.h"
#include "tether/tools/command.h"
#include "tether/tools/option_checks.h"

// The commands, one line each, in the order --help lists them: X(Name, "name") is the function
// tether::MakeNameCommand() that the command's own file in tools/src/ defines, and the name
// its subcommand has on the command line.
#define TETHER_COMMANDS(X)         \
  X(Optimize, "optimize")          \
  X(Simulate, "simulate")          \
  X(Plugins, "plugins")            \
  X(CheckPlugin, "check-plugin")   \
  X(Bench, "bench")                \
  X(Replay, "replay")              \
  X(EkfDemo, "ekf-demo")           \
  X(Lidar, "lidar")                \
  X(LidarEval, "lidar-eval")       \
  X(LidarDegrade, "lidar-degrade") \
  X(Localize, "localize")          \
  X(Mcl, "mcl")                    \
  X(MclDemo, "mcl-demo")           \
  X(MclBench, "mcl-bench")         \
  X(PfSlam, "pf-slam")             \
  X(Odometry, "odometry")

namespace tether {
#define TETHER_DECLARE_COMMAND(Name, cli) std::unique_ptr<Command> Make##Name##Command();
TETHER_COMMANDS(TETHER_DECLARE_COMMAND)
}  // namespace tether

int main(int argc, char** argv) {
  tether::MarkMainEntered();  // first: the start-up is what ran before this line
  // A reader that goes away (`tether optimize ... | head -1`) must not end the run: writes to
  // it fail quietly and the outputs are still written. A file-size limit (ulimit -f) becomes
  // an error naming the file, not a signal that leaves it half written.
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);

  // Where the first argument names a command, only that command's flags are built (all of
  // them cost about 1.5 ms, a tenth of a small file's whole run); every command otherwise
  // (tether --help, --version, a misspelt command, which the parser then names).
  const std::string first = argc > 1 ? argv[1] : "";
  bool named = false;
#define TETHER_IS_NAMED(Name, cli) named = named || first == (cli);
  TETHER_COMMANDS(TETHER_IS_NAMED)
  std::vector<std::unique_ptr<tether::Command>> commands;
#define TETHER_MAKE_COMMAND(Name, cli) \
  if (!named || first == (cli)) commands.push_back(tether::Make##Name##Command());
  TETHER_COMMANDS(TETHER_MAKE_COMMAND)
  CLI::App app{"tether: factor-graph optimisation for SLAM"};
  app.set_version_flag("--version", "tether " TETHER_VERSION_STRING);
  app.require_subcommand(1);
  for (const auto& c : commands) c->Add(app);
  tether::AddOptionChecks(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? tether::kExitOk : tether::kExitUsage;
  }
  for (const auto& c : commands) {
    if (!c->Selected()) continue;
    if (const int rc = c->CheckPaths(std::cerr); rc != 0) return rc;
    // A library message that names an option's field names the flag too.
    tether::FlagNamingStream err(std::cerr, tether::FieldFlagsOf(*c->app()));
    try {
      return c->Run(std::cout, err);
    } catch (const std::exception& e) {
      // The commands report expected errors themselves; this is the last line of defence.
      err << "error: " << e.what() << "\n";
      return tether::kExitBadInput;
    }
  }
  return tether::kExitUsage;
}
