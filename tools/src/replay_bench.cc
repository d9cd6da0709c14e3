#include "tether/tools/replay_bench.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <ostream>
#include <sstream>
#include <utility>

#include "bench_common.h"

namespace tether {

namespace {

using bench::CsvField;
using bench::Fmt;
using bench::OneLine;

const char* StatusName(ReplayStatus s) {
  switch (s) {
    case ReplayStatus::kDone:
      return "done";
    case ReplayStatus::kBadUsage:
      return "bad-usage";
    case ReplayStatus::kBadInput:
      return "bad-input";
    case ReplayStatus::kSolveFailed:
      return "solve-failed";
    case ReplayStatus::kWriteFailed:
      return "write-failed";
  }
  return "crashed";
}

BenchOutcome OutcomeOf(ReplayStatus s) {
  switch (s) {
    case ReplayStatus::kDone:
      return BenchOutcome::kSolved;
    case ReplayStatus::kBadInput:
      return BenchOutcome::kBadInput;
    case ReplayStatus::kBadUsage:
    case ReplayStatus::kSolveFailed:
    case ReplayStatus::kWriteFailed:
      return BenchOutcome::kSolveFailed;
  }
  return BenchOutcome::kCrashed;
}

ReplayBenchRun FromResult(const ReplayResult& r) {
  ReplayBenchRun run;
  run.outcome = OutcomeOf(r.status);
  run.status = StatusName(r.status);
  run.message = r.message;
  run.poses = static_cast<long>(r.poses);
  run.updates = static_cast<long>(r.latencies.size());
  run.total_seconds = r.total_seconds();
  run.mean_ms = 1e3 * r.mean_seconds;
  run.p99_ms = 1e3 * r.p99_seconds;
  run.max_ms = 1e3 * r.max_seconds;
  run.final_chi2 = r.final_chi2;
  run.batch_chi2 = r.batch_chi2;
  run.relative_gap = r.relative_gap;
  run.peak_rss_mib = r.peak_rss_mib;
  return run;
}

// The child's report: "key value" lines, then "end" (bench_common.h).
std::string Serialize(const ReplayBenchRun& r) {
  std::ostringstream o;
  o.precision(17);
  o << "outcome " << bench::OutcomeName(r.outcome) << "\nstatus " << OneLine(r.status) << "\nmessage "
    << OneLine(r.message) << "\nposes " << r.poses << "\nupdates " << r.updates << "\ntotal " << r.total_seconds
    << "\nmean_ms " << r.mean_ms << "\np99_ms " << r.p99_ms << "\nmax_ms " << r.max_ms << "\nfinal_chi2 "
    << r.final_chi2 << "\nbatch_chi2 " << r.batch_chi2 << "\nrelative_gap " << r.relative_gap << "\npeak_rss_mib "
    << r.peak_rss_mib << "\nend\n";
  return o.str();
}

bool Deserialize(const std::string& text, ReplayBenchRun* r) {
  std::map<std::string, std::string> f;
  if (!bench::ParseReport(text, &f) || !bench::OutcomeFromName(f["outcome"], &r->outcome)) return false;
  r->status = f["status"];
  r->message = f["message"];
  r->poses = std::strtol(f["poses"].c_str(), nullptr, 10);
  r->updates = std::strtol(f["updates"].c_str(), nullptr, 10);
  const std::pair<const char*, double*> numbers[] = {{"total", &r->total_seconds},
                                                     {"mean_ms", &r->mean_ms},
                                                     {"p99_ms", &r->p99_ms},
                                                     {"max_ms", &r->max_ms},
                                                     {"final_chi2", &r->final_chi2},
                                                     {"batch_chi2", &r->batch_chi2},
                                                     {"relative_gap", &r->relative_gap},
                                                     {"peak_rss_mib", &r->peak_rss_mib}};
  for (const auto& [key, field] : numbers) *field = std::strtod(f[key].c_str(), nullptr);
  return true;
}

// The first run that finished, whose chi2 figures the row shows (the runs are deterministic).
const ReplayBenchRun* Representative(const ReplayBenchRow& row) {
  for (const ReplayBenchRun& r : row.runs) {
    if (r.outcome == BenchOutcome::kSolved) return &r;
  }
  return nullptr;
}

struct Column {
  const char* md;
  const char* csv;
};

const Column kColumns[] = {
    {"file", "file"},
    {"poses", "poses"},
    {"updates", "updates"},
    {"status", "status"},
    {"total [s]", "total_median_s"},
    {"step mean [ms]", "step_mean_ms"},
    {"step p99 [ms]", "step_p99_ms"},
    {"step max [ms]", "step_max_ms"},
    {"final chi2", "final_chi2"},
    {"batch optimum", "batch_chi2"},
    {"relative gap", "relative_gap"},
    {"peak memory [MiB]", "peak_rss_mib"},
};

std::vector<std::string> Cells(const ReplayBenchRow& row, bool csv) {
  const ReplayBenchRun* rep = Representative(row);
  const std::string none = csv ? "" : "-";
  std::vector<std::string> c;
  c.push_back(csv ? row.file : bench::Basename(row.file));
  c.push_back(rep != nullptr ? std::to_string(rep->poses) : none);
  c.push_back(rep != nullptr ? std::to_string(rep->updates) : none);
  c.push_back(row.status);
  if (rep == nullptr) {
    for (int i = 0; i < 8; ++i) c.push_back(none);
    return c;
  }
  c.push_back(Fmt(csv ? "%.6g" : "%.3f", row.median_seconds));
  for (double ms : {row.mean_ms, row.p99_ms, row.max_ms}) c.push_back(Fmt(csv ? "%.6g" : "%.3f", ms));
  c.push_back(Fmt(csv ? "%.12g" : "%.9g", rep->final_chi2));
  c.push_back(Fmt(csv ? "%.12g" : "%.9g", rep->batch_chi2));
  c.push_back(Fmt("%.3e", rep->relative_gap));
  c.push_back(Fmt(csv ? "%.4g" : "%.1f", row.peak_rss_mib));
  return c;
}

}  // namespace

ReplayBenchRun RunReplayBenchInChild(const std::string& file, const ReplayOptions& options) {
  const bench::ChildResult child = bench::RunInChild([&file, &options] {
    ReplayBenchRun run;
    try {
      run = FromResult(ReplayFile(file, options));
    } catch (const std::exception& e) {
      run.status = "crashed";
      run.message = std::string("uncaught exception: ") + e.what();
    }
    return Serialize(run);
  });
  ReplayBenchRun r;
  r.status = "crashed";
  const bool complete = Deserialize(child.report, &r);
  if (!complete || !child.exited_cleanly()) {
    r.outcome = BenchOutcome::kCrashed;
    r.status = "crashed";
    const std::string why = child.Failure(complete);
    if (!why.empty()) r.message = why;
  }
  return r;
}

void SummarizeReplayBenchRow(ReplayBenchRow* row) {
  row->outcome = BenchOutcome::kSolved;
  row->status.clear();
  row->message.clear();
  row->peak_rss_mib = 0;
  int worst = -1;
  std::vector<double> totals, means, p99s, maxes;
  for (const ReplayBenchRun& r : row->runs) {
    if (bench::Severity(r.outcome) > worst) {
      worst = bench::Severity(r.outcome);
      row->outcome = r.outcome;
      row->status = r.status;
      row->message = r.message;
    }
    row->peak_rss_mib = std::max(row->peak_rss_mib, r.peak_rss_mib);
    if (r.outcome != BenchOutcome::kSolved) continue;
    totals.push_back(r.total_seconds);
    means.push_back(r.mean_ms);
    p99s.push_back(r.p99_ms);
    maxes.push_back(r.max_ms);
  }
  if (row->runs.empty()) {
    row->outcome = BenchOutcome::kCrashed;
    row->status = "crashed";
    row->message = "no runs";
  }
  row->median_seconds = bench::Median(totals);
  row->mean_ms = bench::Median(means);
  row->p99_ms = bench::Median(p99s);
  row->max_ms = bench::Median(maxes);
}

std::string FormatReplayBenchMarkdown(const std::vector<ReplayBenchRow>& rows, int repeat) {
  std::ostringstream o;
  o << "`tether replay` through the incremental smoother, one update per pose; " << repeat
    << (repeat == 1 ? " run" : " runs")
    << " per file, each in a fresh child process; total = the updates and Finish, the per-step figures are "
       "medians over the runs of each run's mean, p99 and max update latency; peak memory: the highest of the "
       "runs, measured after Finish.\n\n";
  std::string header = "|", rule = "|";
  for (const Column& c : kColumns) {
    header += std::string(" ") + c.md + " |";
    rule += "---|";
  }
  o << header << "\n" << rule << "\n";
  for (const ReplayBenchRow& row : rows) {
    o << "|";
    for (const std::string& cell : Cells(row, false)) o << " " << cell << " |";
    o << "\n";
  }
  return o.str();
}

std::string FormatReplayBenchCsv(const std::vector<ReplayBenchRow>& rows) {
  std::ostringstream o;
  for (const Column& c : kColumns) o << c.csv << ",";
  o << "runs,message\n";
  for (const ReplayBenchRow& row : rows) {
    for (const std::string& cell : Cells(row, true)) o << CsvField(cell) << ",";
    o << row.runs.size() << "," << CsvField(OneLine(row.message)) << "\n";
  }
  return o.str();
}

int RunReplayBench(const BenchCommand& cmd, std::ostream& out, std::ostream& err) {
  const auto usage = [&err](const std::string& what) {
    err << "tether bench --replay: " << what << "\n";
    return 2;
  };
  const BenchCommand defaults;
  if (cmd.solvers != defaults.solvers || cmd.linear != defaults.linear || cmd.init != defaults.init ||
      !cmd.threads.empty() || !cmd.plugins.empty()) {
    return usage("--solvers, --linear, --init, --threads and --plugin do not apply to replays; leave them out");
  }
  if (cmd.files.empty()) return usage("no FILES given; name one or more graph files (.g2o, .graph)");
  if (cmd.repeat < 1) return usage("--repeat must be at least 1; got " + std::to_string(cmd.repeat));
  if (cmd.format != "md" && cmd.format != "csv") return usage("unknown --format '" + cmd.format + "'; use md or csv");
  if (const std::string why = bench::CheckFilesAndOutput(cmd.files, cmd.output); !why.empty()) return usage(why);

  err << "tether bench --replay: " << cmd.files.size() << (cmd.files.size() == 1 ? " file" : " files") << " x "
      << cmd.repeat << (cmd.repeat == 1 ? " run" : " runs") << "\n";
  const ReplayOptions options;
  std::vector<ReplayBenchRow> rows;
  for (const std::string& file : cmd.files) {
    ReplayBenchRow row;
    row.file = file;
    for (int k = 1; k <= cmd.repeat; ++k) {
      err << "[" << rows.size() + 1 << "/" << cmd.files.size() << "] " << file << " replay: run " << k << " of "
          << cmd.repeat << " ... " << std::flush;
      const ReplayBenchRun r = RunReplayBenchInChild(file, options);
      err << Fmt("%.3f s, ", r.total_seconds) << r.status << std::endl;
      row.runs.push_back(r);
    }
    SummarizeReplayBenchRow(&row);
    if (row.outcome != BenchOutcome::kSolved)
      err << "error: " << file << ": " << row.status << ": " << row.message << "\n";
    rows.push_back(std::move(row));
  }
  const std::string table =
      cmd.format == "csv" ? FormatReplayBenchCsv(rows) : FormatReplayBenchMarkdown(rows, cmd.repeat);
  if (const int rc = bench::WriteTable(table, cmd.output, out, err); rc != 0) return rc;
  std::vector<BenchOutcome> outcomes;
  for (const ReplayBenchRow& row : rows) outcomes.push_back(row.outcome);
  return bench::ExitCode(outcomes);
}

}  // namespace tether
