// `tether mcl-demo`: the kidnapped-robot experiment of the thesis's section 5.2 in simulation
// (frontends/localization/mcl_experiment.h); this file only binds the flags and prints the tables.
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/registry.h"
#include "tether/frontends/localization/mcl_experiment.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

using localization::MclExperimentOptions;

struct MclDemoCommand {
  MclExperimentOptions options;
  std::vector<std::string> worlds = {"maze", "office"};
  std::vector<std::string> methods = {"amcl", "acmcl"};
  std::string output;
  bool quiet = false;
};

// Names to enum values; false after saying which name is unknown.
template <class E>
bool ParseNames(const std::vector<std::string>& names, const char* flag, std::vector<E>* out, std::ostream& err) {
  out->clear();
  for (const std::string& n : names) {
    E value;
    if (!FromString(n, &value)) {
      err << "tether mcl-demo: " << flag << ": '" << n << "' is not one of " << EnumNameList<E>() << "\n";
      return false;
    }
    out->push_back(value);
  }
  return true;
}

bool ResolveMclDemoOptions(MclDemoCommand* cmd, std::ostream& err) {
  if (!ParseNames(cmd->worlds, "--worlds", &cmd->options.worlds, err) ||
      !ParseNames(cmd->methods, "--methods", &cmd->options.methods, err)) {
    return false;
  }
  std::string why;
  if (!cmd->options.IsValid(&why)) {
    err << "tether mcl-demo: " << why << "\n";
    return false;
  }
  return true;
}

int RunMclDemo(MclDemoCommand cmd, std::ostream& out, std::ostream& err) {
  if (!ResolveMclDemoOptions(&cmd, err)) return kExitUsage;
  const MclExperimentOptions& o = cmd.options;
  OutputSet outputs;
  OutputFile* table_file = nullptr;
  const int rc = CheckOutputs(
      "mcl-demo", outputs, [&] { table_file = cmd.output.empty() ? nullptr : &outputs.Add(cmd.output, "table"); }, err);
  if (rc != 0) return rc;
  if (!cmd.quiet) {
    out << "kidnapped robot: " << o.seeds << " seeds from " << o.first_seed << ", kidnap before step " << o.kidnap_step
        << " (at least " << FormatDouble(o.min_jump) << " m), at most " << o.max_steps
        << " updates after it; one update per scan, " << FormatDouble(o.sim_step) << " m per scan\n"
        << std::flush;
  }
  std::string tables;
  try {
    tables = localization::MclExperimentTables(localization::RunMclExperiment(o));
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  out << "\n" << tables;
  try {
    if (table_file != nullptr) table_file->Stage(tables);
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  if (table_file != nullptr) out << "wrote " << cmd.output << "\n";
  return kExitOk;
}

class MclDemoCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunMclDemo(cmd_, out, err); }

 private:
  template <class T>
  void Option(const char* name, T& value, const char* help) {
    app_->add_option(name, value, help)->capture_default_str();
  }
  MclDemoCommand cmd_;
};

void MclDemoCli::Add(CLI::App& app) {
  app_ = app.add_subcommand("mcl-demo",
                            "The kidnapped-robot experiment in simulation: steps to converge and the recovery ratio "
                            "of Augmented MCL and ACMCL on a maze and an office, over seeds and particle counts");
  MclExperimentOptions& o = cmd_.options;
  Option("--seeds", o.seeds, "Seeds (worlds and routes) per configuration");
  Option("--first-seed", o.first_seed, "The first seed");
  app_->add_option("--particles", o.particles, "Particle counts, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  app_->add_option("--worlds", cmd_.worlds, "Worlds: maze, office (comma-separated)")
      ->delimiter(',')
      ->capture_default_str();
  app_->add_option("--methods", cmd_.methods, "Methods: mcl, amcl, cmcl, acmcl (comma-separated)")
      ->delimiter(',')
      ->capture_default_str();
  Option("--kidnap-step", o.kidnap_step, "The robot is carried off before this step's scan");
  Option("--max-steps", o.max_steps, "Updates after the kidnap at most (the cap)");
  Option("--min-jump", o.min_jump, "The kidnap carries the robot at least this far [m]");
  Option("--step", o.sim_step, "Metres the simulated robot moves between scans (one update per scan)");
  Option("--hold", o.converge_hold, "Converged: within 0.5 m and 10 degrees for this many updates in a row");
  app_->add_flag_function(
      "--filters-from-zero", [this](std::int64_t) { cmd_.options.settled_filters = false; },
      "Augmented MCL's w_slow and w_fast start from 0 as the textbook starts them (default: at the first "
      "update's average, as the filter starts them)");
  Option("--threads", o.threads, "Runs in parallel (0: every core; the figures do not depend on it)");
  AddPath(app_, "-o,--output", &cmd_.output, "Also write the tables (markdown) here");
  app_->add_flag("-q,--quiet", cmd_.quiet, "Only the tables");
}

}  // namespace

std::unique_ptr<Command> MakeMclDemoCommand() { return std::make_unique<MclDemoCli>(); }

}  // namespace tether
