#include "tether/tools/option_checks.h"

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <limits>

#include "tether/core/registry.h"

namespace tether {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kBig = 1e12;  // counts: scans, iterations, seeds

// Every numeric option's range, one row each.
const OptionRange kRanges[] = {
    // optimize
    {"optimize", "--max-iterations", 0, 1e9},
    {"optimize", "--time-limit", 0, 1e9},
    {"optimize", "--threads", 1, 256},
    {"optimize", "--max-reuse-iterations", 0, 1e6},
    {"optimize", "--switch-prior-sigma", 0, 1e6},
    // odometry
    {"odometry", "--controls-per-pose", 1, 1e6},
    {"odometry", "--v-sigma", 0, 1e3},
    {"odometry", "--w-sigma", 0, 1e3},
    {"odometry", "--floor-sigma", 1e-6, 1e3},
    {"odometry", "--prior-sigma", 0, 1e6},
    // simulate
    {"simulate", "--poses", 1, 1e8},
    {"simulate", "--scans", 1, 1e7},
    {"simulate", "--beams", 2, 1 << 20},
    {"simulate", "--map-resolution", 1e-3, 100},
    // check-plugin
    {"check-plugin", "--trials", 1, 1e7},
    {"check-plugin", "--tolerance", 0, 1},
    // bench
    {"bench", "--repeat", 1, 1e6},
    // replay
    {"replay", "--every", 1, kBig},
    {"replay", "--check", 0, kBig},
    {"replay", "--relinearize-threshold", 0, 1e6},
    {"replay", "--relinearize-sigmas", 0, 1e6},
    {"replay", "--iterate-ratio", 1, 1e6},
    {"replay", "--iterate-fraction", 0, 1},
    {"replay", "--iterate-share", 0, 1},
    {"replay", "--rounds", 1, 1000},
    {"replay", "--wildfire", 0, 1e6},
    // A local solve's tolerance of 0 never stops short of the exact optimum: seconds per update.
    {"replay", "--local-tolerance", 1e-6, 1},
    {"replay", "--local-hops", 0, 1000},
    {"replay", "--local-max-region", 1, 1e9},
    {"replay", "--local-batch-gap", 0, 1},
    {"replay", "--local-batch-correction", 0, 1},
    {"replay", "--local-batch-share", 0, 1},
    {"replay", "--lag", 0, kBig},
    {"replay", "--lag-batch", 0, 1e6},
    // ekf-demo
    {"ekf-demo", "--seeds", 1, 1e6},
    {"ekf-demo", "--first-seed", 0, 4294967295.0},
    {"ekf-demo", "--steps", 1, 1e7},
    {"ekf-demo", "--range-sigma", 1e-6, 1e3},
    {"ekf-demo", "--bearing-sigma", 1e-6, kPi},
    {"ekf-demo", "--invariant-min-range", -1, 1e6},
    {"ekf-demo", "--min-range", 0, 1e6},
    {"ekf-demo", "--invariant-iterations", 1, 1000},
    // pf-slam
    {"pf-slam", "--particles", 1, 100000},
    {"pf-slam", "--max-scans", 0, kBig},
    {"pf-slam", "--resolution", 0.001, 10},
    {"pf-slam", "--max-range", 0.01, 1e4},
    {"pf-slam", "--linear-update", 0, 1e6},
    {"pf-slam", "--angular-update", 0, kPi},
    {"pf-slam", "--likelihood-points", 1e-6, 1e6},
    {"pf-slam", "--resample-fraction", 0, 1},
    {"pf-slam", "--threads", 0, 256},
    {"pf-slam", "--seed", 0, 4294967295.0},
    // lidar
    {"lidar", "--threads", 0, 256},
    {"lidar", "--max-scans", 0, kBig},
    {"lidar", "--scans-per-submap", 1, 1e6},
    {"lidar", "--resolution", 0.001, 10},
    {"lidar", "--search-every", 1, kBig},
    {"lidar", "--search-every-metres", 0, 1e6},
    {"lidar", "--max-submap-travel", 0, 1e6},
    {"lidar", "--update-every", 1, kBig},
    {"lidar", "--min-score", 0, 1},
    {"lidar", "--local-sigma-t", 1e-9, 1e6},
    {"lidar", "--local-sigma-r", 1e-9, 1e6},
    {"lidar", "--consecutive-sigma-t", 0, 1e6},
    {"lidar", "--consecutive-sigma-r", 0, 1e6},
    {"lidar", "--local-huber", 0, 1e6},
    {"lidar", "--loop-sigma-t", 1e-9, 1e6},
    {"lidar", "--loop-sigma-r", 1e-9, 1e6},
    {"lidar", "--rival-ratio", 0, 1},
    {"lidar", "--confirm-t", 0, 1000},
    {"lidar", "--confirm-r", 1e-9, kPi},
    {"lidar", "--max-search-distance", 0, 1e6},
    {"lidar", "--search-voxel", 0, 100},
    {"lidar", "--search-window", 0, 1000},
    {"lidar", "--search-window-growth", 0, 10},
    {"lidar", "--max-search-window", 0, 1000},
    {"lidar", "--search-angle-growth", 0, 10},
    {"lidar", "--max-search-angle", 0, kPi},
    {"lidar", "--search-angle", 0, 180},
    {"lidar", "--huber", 1e-9, 1e6},
    {"lidar", "--match-translation-weight", 1e-9, 1e9},
    {"lidar", "--match-rotation-weight", 1e-9, 1e9},
    {"lidar", "--correlative-translation-weight", 0, 1e9},
    {"lidar", "--correlative-rotation-weight", 0, 1e9},
    {"lidar", "--correlative-angle", 0, 180},
    {"lidar", "--min-match-probability", 0, 1},
    {"lidar", "--still-distance", 0, 100},
    {"lidar", "--still-angle", 0, kPi},
    {"lidar", "--weak-window", 0, 100},
    {"lidar", "--line-radius", 0, 100},
    {"lidar", "--degenerate-information", 0, 1e6},
    {"lidar", "--kidnap-filter", 1, 1000},
    {"lidar", "--kidnap-threshold", 1, 1e6},
    {"lidar", "--kidnap-max-overlap", 0, 1},
    {"lidar", "--kidnap-relocate-window", 0, 100},
    {"lidar", "--max-range", 0, 1000},
    {"lidar", "--min-range", 0, 1000},
    {"lidar", "--imu-bias-seconds", 0, 1e6},
    {"lidar", "--imu-rotation-weight", 0, 1e9},
    {"lidar", "--laser-offset", -1000, 1000},
    {"lidar", "--self-check-every", 0, kBig},
    {"lidar", "--progress-every", 0, kBig},
    // lidar-eval
    {"lidar-eval", "--tolerance", 0, 1e6},
    {"lidar-eval", "--time-reference-tolerance", 0, 1e6},
    // lidar-degrade
    {"lidar-degrade", "--beams", 2, 1 << 20},
    {"lidar-degrade", "--max-range", 0.001, 1000},
    {"lidar-degrade", "--noise", 0, 100},
    {"lidar-degrade", "--drop", 0, 1},
    {"lidar-degrade", "--error-share", 0, 1},
    {"lidar-degrade", "--keep-every", 1, kBig},
    {"lidar-degrade", "--first-scan", 0, kBig},
    {"lidar-degrade", "--max-scans", 0, kBig},
    // localize
    {"localize", "--initial-pose", -1e6, 1e6},
    {"localize", "--start-scan", 0, kBig},
    {"localize", "--max-scans", 0, kBig},
    {"localize", "--repeat", 1, 1e6},
    {"localize", "--global-every", 1, kBig},
    {"localize", "--global-min-score", 1e-9, 0.999},
    {"localize", "--global-max-range", 0, 1e6},
    {"localize", "--global-depth", 1, 16},
    {"localize", "--track-min-score", 1e-9, 0.999},
    {"localize", "--lost-after", 1, kBig},
    {"localize", "--keep-submaps", 1, 1e6},
    {"localize", "--max-range", 0, 1000},
    {"localize", "--progress-every", 0, kBig},
};

}  // namespace

const std::vector<OptionRange>& OptionRanges() {
  static const std::vector<OptionRange> ranges(std::begin(kRanges), std::end(kRanges));
  return ranges;
}

void AddOptionChecks(CLI::App* app) {
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
    for (CLI::Option* opt : sub->get_options()) {
      const std::string type = opt->get_type_name();
      if (type != "FLOAT" && type != "INT" && type != "UINT") continue;
      double lo = -std::numeric_limits<double>::max(), hi = std::numeric_limits<double>::max();
      std::string shown;  // the range as --help shows it
      for (const OptionRange& r : OptionRanges()) {
        if (sub->get_name() == r.command && opt->check_name(r.flag)) {
          lo = r.min;
          hi = r.max;
          shown = "in [" + FormatDouble(lo) + ", " + FormatDouble(hi) + "]";
        }
      }
      opt->check(CLI::Validator(
          [lo, hi](std::string& text) -> std::string {
            errno = 0;
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (end == text.c_str() || *end != '\0') return "";  // not a number: the conversion says so
            if (!std::isfinite(v)) return "'" + text + "' is not a finite number";
            if (v < lo || v > hi) {
              return "'" + text + "' is outside its range [" + FormatDouble(lo) + ", " + FormatDouble(hi) + "]";
            }
            return "";
          },
          shown, "range"));
    }
  }
}

}  // namespace tether
