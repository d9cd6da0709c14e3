// tether: the command-line program. `tether --help` lists the commands; each lives in a file of
// its own in tools/src/ (docs/architecture.md), and this file is only their table.
#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>
#include <memory>
#include <vector>

#include "tether/core/version.h"
#include "tether/tools/command.h"
#include "tether/tools/option_checks.h"

// The commands, one line each, in the order --help lists them: X(Name) is the function
// tether::MakeNameCommand() that the command's own file in tools/src/ defines.
#define TETHER_COMMANDS(X) \
  X(Optimize)              \
  X(Simulate)              \
  X(Plugins)               \
  X(CheckPlugin)           \
  X(Bench)                 \
  X(Replay)                \
  X(EkfDemo)               \
  X(Lidar)                 \
  X(LidarEval)             \
  X(LidarDegrade)          \
  X(Localize)              \
  X(Mcl)                   \
  X(MclDemo)               \
  X(MclBench)              \
  X(Odometry)

namespace tether {
#define TETHER_DECLARE_COMMAND(Name) std::unique_ptr<Command> Make##Name##Command();
TETHER_COMMANDS(TETHER_DECLARE_COMMAND)
}  // namespace tether

int main(int argc, char** argv) {
  tether::MarkMainEntered();  // first: the start-up is what ran before this line
  // A reader that goes away (`tether optimize ... | head -1`) must not end the run: writes to
  // it fail quietly and the outputs are still written. A file-size limit (ulimit -f) becomes
  // an error naming the file, not a signal that leaves it half written.
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);

  std::vector<std::unique_ptr<tether::Command>> commands;
#define TETHER_MAKE_COMMAND(Name) commands.push_back(tether::Make##Name##Command());
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
