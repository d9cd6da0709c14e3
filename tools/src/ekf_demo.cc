#include "tether/tools/ekf_demo.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_writer.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {

bool ParseList(const std::string& text, const std::vector<std::string>& allowed, std::vector<std::string>* out) {
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (std::find(allowed.begin(), allowed.end(), item) == allowed.end()) return false;
    out->push_back(item);
  }
  return !out->empty();
}

}  // namespace

// The experiments and associations to run, and the command's own rules; false after saying
// why.
bool ResolveDemoOptions(const EkfDemoCommand& cmd, std::vector<std::string>* experiments,
                        std::vector<std::string>* associations, std::ostream& err) {
  if (!ParseList(cmd.experiments, {"1", "2"}, experiments)) {
    err << "tether ekf-demo: --experiments takes 1, 2 or 1,2 (got '" << cmd.experiments << "')\n";
    return false;
  }
  if (!ParseList(cmd.association, {"known", "nn"}, associations)) {
    err << "tether ekf-demo: --association takes known, nn or known,nn (got '" << cmd.association << "')\n";
    return false;
  }
  std::vector<std::string> versions;
  if (!ParseList(cmd.fastslam, {"1", "2"}, &versions)) {
    err << "tether ekf-demo: --fastslam takes 1, 2 or 1,2 (got '" << cmd.fastslam << "')\n";
    return false;
  }
  if (cmd.fastslam_particles != "none") {
    std::stringstream in(cmd.fastslam_particles);
    std::string item;
    bool ok = !cmd.fastslam_particles.empty();
    while (ok && std::getline(in, item, ',')) {
      char* end = nullptr;
      const long n = std::strtol(item.c_str(), &end, 10);
      ok = !item.empty() && end != nullptr && *end == '\0' && n >= 1 && n <= 100000;
    }
    if (!ok) {
      err << "tether ekf-demo: --fastslam-particles takes a list of particle counts in 1..100000 (e.g. 10,100,1000) "
             "or none (got '"
          << cmd.fastslam_particles << "')\n";
      return false;
    }
  }
  if (!std::isfinite(cmd.setup.invariant_min_range) ||
      !(std::isfinite(cmd.setup.min_range) && cmd.setup.min_range >= 0)) {
    err << "tether ekf-demo: --invariant-min-range must be finite (negative: 1.5 range sigmas) and --min-range "
           "finite and not negative\n";
    return false;
  }
  if (cmd.seeds < 1 || cmd.setup.steps < 1 || cmd.setup.invariant_iterations < 1) {
    err << "tether ekf-demo: --seeds, --steps and --invariant-iterations must be at least 1\n";
    return false;
  }
  if (!(cmd.setup.range_sigma > 0 && cmd.setup.bearing_sigma > 0 && std::isfinite(cmd.setup.range_sigma) &&
        std::isfinite(cmd.setup.bearing_sigma))) {
    err << "tether ekf-demo: --range-sigma and --bearing-sigma must be positive and finite\n";
    return false;
  }
  return true;
}

int RunEkfDemo(const EkfDemoCommand& cmd, std::ostream& out, std::ostream& err) {
  std::vector<std::string> experiments, associations;
  if (!ResolveDemoOptions(cmd, &experiments, &associations, err)) return kExitUsage;
  EkfDemoSetup setup = cmd.setup;
  setup.fastslam_particles.clear();
  if (cmd.fastslam_particles != "none") {
    std::stringstream in(cmd.fastslam_particles);
    std::string item;
    while (std::getline(in, item, ',')) setup.fastslam_particles.push_back(std::stoi(item));
  }
  setup.fastslam_one = cmd.fastslam.find('1') != std::string::npos;
  setup.fastslam_two = cmd.fastslam.find('2') != std::string::npos;
  OutputSet outputs;
  OutputFile* table_file = nullptr;
  OutputFile* plot_file = nullptr;
  const int rc = CheckOutputs(
      "ekf-demo", outputs,
      [&] {
        if (!cmd.output.empty()) table_file = &outputs.Add(cmd.output, "table");
        if (!cmd.plot.empty()) plot_file = &outputs.Add(cmd.plot, "plot");
      },
      err);
  if (rc != 0) return rc;
  std::vector<EkfDemoConfig> configs;
  for (const std::string& e : experiments) {
    for (const std::string& a : associations) {
      const int experiment = std::stoi(e);
      const bool nn = a == "nn";
      if (!cmd.quiet) {
        out << "experiment " << experiment << " (control noise std "
            << (experiment == 2 ? "0.2 m/s, pi/9" : "0.1 m/s, pi/18") << " rad/s), "
            << (nn ? "nearest-neighbour" : "known") << " association, " << cmd.seeds << " seeds\n";
      }
      configs.push_back(RunEkfExperiment(experiment, nn, cmd.seeds, cmd.first_seed, setup));
    }
  }
  std::ostringstream head;
  head << "measurement noise std " << svg::Label(cmd.setup.range_sigma, 4) << " m, "
       << svg::Label(cmd.setup.bearing_sigma, 4) << " rad; " << cmd.setup.steps << " steps; seeds " << cmd.first_seed
       << ".." << cmd.first_seed + static_cast<std::uint64_t>(cmd.seeds) - 1 << "\n\n";
  std::string table = head.str() + EkfDemoTable(configs);
  if (setup.consistency) table += "\nConsistency of the pose estimate (NEES):\n\n" + EkfDemoConsistencyTable(configs);
  out << table;
  for (const EkfDemoConfig& c : configs) {
    for (const EkfDemoRow& r : c.rows) {
      if (r.failures > 0)
        out << "note: " << r.method << " failed on " << r.failures << " runs (first: " << r.failure_note << ")\n";
    }
  }
  try {
    if (table_file != nullptr) table_file->Stage(table);
    if (plot_file != nullptr) {
      const int experiment = std::stoi(experiments.front());
      plot_file->Stage(EkfDemoSvg(experiment, associations.front() == "nn", cmd.first_seed, setup));
    }
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  if (table_file != nullptr) out << "wrote " << cmd.output << "\n";
  if (plot_file != nullptr) out << "wrote " << cmd.plot << "\n";
  return 0;
}

namespace {

class EkfDemoCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunEkfDemo(cmd_, out, err); }

 private:
  EkfDemoCommand cmd_;
};

void EkfDemoCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "ekf-demo", "Dead reckoning, EKF-SLAM, UKF-SLAM and the pose graph they seed, on simulated landmark worlds");
  sub->add_option("--seeds", cmd_.seeds, "Number of seeds (worlds) per experiment")->capture_default_str();
  sub->add_option("--first-seed", cmd_.first_seed, "The first seed")->capture_default_str();
  sub->add_option("--experiments", cmd_.experiments, "1 (control noise std 0.1 m/s, pi/18 rad/s), 2 (doubled), or 1,2")
      ->capture_default_str();
  sub->add_option("--association", cmd_.association, "known, nn (nearest neighbour with a Mahalanobis gate), or both")
      ->capture_default_str();
  sub->add_option("--steps", cmd_.setup.steps, "Time steps per run (dt = 1 s)")->capture_default_str();
  sub->add_option("--range-sigma", cmd_.setup.range_sigma, "Range noise std [m]")->capture_default_str();
  sub->add_option("--bearing-sigma", cmd_.setup.bearing_sigma, "Bearing noise std [rad]")->capture_default_str();
  sub->add_option("--invariant-min-range", cmd_.setup.invariant_min_range,
                  "The invariant EKF uses no observation nearer than this [m] (negative: 1.5 range sigmas)")
      ->capture_default_str();
  sub->add_option("--min-range", cmd_.setup.min_range,
                  "The EKF, the UKF and FastSLAM use no landmark nearer than this [m]")
      ->capture_default_str();
  sub->add_option("--invariant-iterations", cmd_.setup.invariant_iterations,
                  "Gauss-Newton iterations of each invariant EKF correction (1: the plain update)")
      ->capture_default_str();
  sub->add_option("--fastslam-particles", cmd_.fastslam_particles,
                  "FastSLAM's particle counts, a list (a row per count and version), or none")
      ->capture_default_str();
  sub->add_option("--fastslam", cmd_.fastslam, "The FastSLAM versions: 1, 2 or 1,2")->capture_default_str();
  sub->add_flag_function(
      "--no-graph", [this](std::int64_t) { cmd_.setup.graphs = false; },
      "The filters alone: no graph seeded by them (much faster)");
  sub->add_flag("--nees", cmd_.setup.consistency,
                "Also the consistency of every pose estimate: the NEES per step averaged over the seeds, "
                "against its 95% interval (the graphs: the smoother's online estimate and marginal)");
  AddPath(sub, "-o,--output", &cmd_.output, "Also write the table (markdown) here");
  AddPath(sub, "--plot", &cmd_.plot,
          "Draw truth, dead reckoning, EKF, UKF and the optimised graph of the first seed (SVG)");
  sub->add_flag("-q,--quiet", cmd_.quiet, "Only the table");
}

}  // namespace

std::unique_ptr<Command> MakeEkfDemoCommand() { return std::make_unique<EkfDemoCli>(); }

}  // namespace tether
