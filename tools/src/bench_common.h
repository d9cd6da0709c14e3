#pragma once
// Pieces shared by `tether bench` (bench.cc) and `tether bench --replay` (replay_bench.cc):
// running a measurement in a forked child that reports back over a pipe, the child's report
// format ("key value" lines ending with "end"), medians, number and CSV formatting, checking
// the command's files, and writing the table through a temporary file.
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "tether/tools/bench.h"

namespace tether {
namespace bench {

/// What a forked child sent back and how it ended.
struct ChildResult {
  std::string report;       ///< everything the child wrote to the pipe
  int wait_status = 0;      ///< as from wait4
  double peak_rss_mib = 0;  ///< the child's peak resident set (wait4's ru_maxrss), MiB
  std::string error;        ///< the fork or pipe could not be made (nothing ran)
  bool exited_cleanly() const;
  /// Why the child did not end cleanly: "killed by signal N (name)", or "the run ended (exit
  /// code C) without reporting" where `complete` is false.
  std::string Failure(bool complete) const;
};

/// Forks; the child runs `body`, writes what it returns to a pipe and _exits (an exception
/// that escapes `body` sends nothing: catch inside to report it). The caller must not have
/// started OpenMP threads (see RunBenchInChild in bench.h).
ChildResult RunInChild(const std::function<std::string()>& body);

/// BenchOutcome's names in reports ("solved", "solve-failed", "bad-input", "crashed").
const char* OutcomeName(BenchOutcome o);
bool OutcomeFromName(const std::string& s, BenchOutcome* o);
/// Solved 0 < solve failed 1 < bad input 2 < crashed 3.
int Severity(BenchOutcome o);
/// The bench's exit code for its rows' outcomes: 0 all solved; 1 some file was bad input;
/// 3 otherwise some run failed or crashed.
int ExitCode(const std::vector<BenchOutcome>& outcomes);

/// Parses "key value" lines into `fields` up to the line "end"; false where "end" is missing.
bool ParseReport(const std::string& text, std::map<std::string, std::string>* fields);

std::string OneLine(std::string s);
double Median(std::vector<double> v);
std::string Fmt(const char* format, double v);
std::string CsvField(const std::string& s);
std::string Basename(const std::string& path);

/// The usage error for files that do not exist or are folders, or an -o whose folder does not
/// exist; empty when all is well.
std::string CheckFilesAndOutput(const std::vector<std::string>& files, const std::string& output);

/// Writes `table` to `out`, or to `output` through a temporary name renamed into place
/// ("wrote OUTPUT" on `err`). Returns 0, or 1 with the error on `err`.
int WriteTable(const std::string& table, const std::string& output, std::ostream& out, std::ostream& err);

}  // namespace bench
}  // namespace tether
