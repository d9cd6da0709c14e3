#pragma once
// The ranges of the `tether` program's numeric options, in one table, and the check that
// applies them: a value outside its option's range, or a number that is not finite, is refused
// while the command line is parsed (exit 2, naming the option), before anything runs.
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace tether {

/// The range one numeric option of one command takes (both ends included).
struct OptionRange {
  const char* command;  ///< "lidar"; several commands may share a flag name with other ranges
  const char* flag;     ///< "--threads"
  double min, max;
};

/// Every numeric option's range (docs/cli.md lists them).
const std::vector<OptionRange>& OptionRanges();

/// Adds the checks to every option of every subcommand of `app` (call after every option was
/// added): every number finite; the range of OptionRanges() where the option has one.
void AddOptionChecks(CLI::App* app);

}  // namespace tether
