#pragma once
// `tether bench --replay FILES... [--repeat R] [--format md|csv] [-o OUT]`: replays each file
// through the incremental smoother (ReplayFile, replay.h) R times and tabulates the online
// figures: poses, updates, total time (median of the runs), per-step latency mean / p99 / max
// (medians of the runs'), final chi2 after Finish, the batch optimum, their relative gap, and
// the peak memory. docs/benchmarking.md says what every column means.
//
// As with `tether bench`, every run happens in a forked child (RunInChild, bench_common.h), so
// each run's peak memory is its own and a crash is reported in its row.
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/tools/bench.h"
#include "tether/tools/replay.h"

namespace tether {

/// The measurements of one replay run, as the child reports them.
struct ReplayBenchRun {
  BenchOutcome outcome = BenchOutcome::kCrashed;
  std::string status;  ///< done, bad-usage, bad-input, solve-failed or crashed
  std::string message;
  long poses = 0;
  long updates = 0;
  double total_seconds = 0;  ///< the updates and Finish (ReplayResult::total_seconds)
  double mean_ms = 0, p99_ms = 0, max_ms = 0;
  double final_chi2 = 0, batch_chi2 = 0, relative_gap = 0;
  double peak_rss_mib = 0;  ///< ReplayResult::peak_rss_mib, measured in the child after Finish
};

/// One file's runs summarised: medians of the times, the first complete run's chi2 figures,
/// the highest peak memory, the worst outcome.
struct ReplayBenchRow {
  std::string file;
  std::vector<ReplayBenchRun> runs;
  BenchOutcome outcome = BenchOutcome::kCrashed;
  std::string status, message;
  double median_seconds = 0, mean_ms = 0, p99_ms = 0, max_ms = 0;
  double peak_rss_mib = 0;
};

/// One replay of `file` in a forked child (call it from a process that has not solved
/// anything: see RunBenchInChild).
ReplayBenchRun RunReplayBenchInChild(const std::string& file, const ReplayOptions& options);
void SummarizeReplayBenchRow(ReplayBenchRow* row);
std::string FormatReplayBenchMarkdown(const std::vector<ReplayBenchRow>& rows, int repeat);
std::string FormatReplayBenchCsv(const std::vector<ReplayBenchRow>& rows);

/// `tether bench --replay`: cmd.files, cmd.repeat, cmd.format and cmd.output as `tether bench`;
/// the solver lists do not apply (bad usage where they differ from their defaults). Progress
/// on `err`, the table on `out` or in cmd.output. Exit codes as RunBench: 0 every run done;
/// 1 a file could not be read; 2 bad usage, nothing run; 3 otherwise a run failed or crashed.
int RunReplayBench(const BenchCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
