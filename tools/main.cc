// tether: the command-line program. `tether --help` lists the commands; each lives in a file of
// its own in tools/src/ (docs/architecture.md), and this file is only their table.
#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>
#include <memory>
#include <vector>

#include "tether/tools/command.h"
#include "tether/tools/option_checks.h"

int main(int argc, char** argv) {
  // A reader that goes away (`tether optimize ... | head -1`) must not end the run: writes to
  // it fail quietly and the outputs are still written. A file-size limit (ulimit -f) becomes
  // an error naming the file, not a signal that leaves it half written.
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);

  std::vector<std::unique_ptr<tether::Command>> commands;
  for (auto make :
       {tether::MakeOptimizeCommand, tether::MakeSimulateCommand, tether::MakePluginsCommand,
        tether::MakeCheckPluginCommand, tether::MakeBenchCommand, tether::MakeReplayCommand, tether::MakeEkfDemoCommand,
        tether::MakeLidarCommand, tether::MakeLidarEvalCommand, tether::MakeLidarDegradeCommand,
        tether::MakeLocalizeCommand, tether::MakeMclCommand, tether::MakeMclDemoCommand, tether::MakeMclBenchCommand}) {
    commands.push_back(make());
  }
  CLI::App app{"tether: factor-graph optimisation for SLAM"};
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
    try {
      return c->Run(std::cout, std::cerr);
    } catch (const std::exception& e) {
      // The commands report expected errors themselves; this is the last line of defence.
      std::cerr << "error: " << e.what() << "\n";
      return tether::kExitBadInput;
    }
  }
  return tether::kExitUsage;
}
