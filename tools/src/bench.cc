#include "tether/tools/bench.h"

#include <dlfcn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <map>
#include <ostream>
#include <sstream>
#include <utility>

#include "bench_common.h"
#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/timing.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/backends.h"
#include "tether/solvers/optimizer.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"
#include "tether/tools/outlier_bench.h"
#include "tether/tools/replay_bench.h"

namespace tether {

namespace {

namespace fs = std::filesystem;
using bench::Basename;
using bench::CsvField;
using bench::Fmt;
using bench::Median;
using bench::OneLine;
using bench::OutcomeFromName;
using bench::OutcomeName;
using bench::Severity;
using Clock = std::chrono::steady_clock;

// The time split from the summary. The native solvers keep the numeric factorisations apart
// from the triangular solves and time the last one (the floor); Ceres reports its linear
// solver's time as one figure, so there the factorisation and the floor are not available.
void FillSplit(const SolverSummary& s, BenchRun* r) {
  r->setup_seconds = s.setup_seconds;
  r->linearize_seconds = s.linearize_seconds;
  r->solve_seconds = s.solve_seconds;
  if (s.algorithm != Algorithm::kCeres) {
    r->factorize_seconds = s.factorize_seconds;
    r->floor_seconds = s.last_factorize_seconds * s.iterations;
  }
}

// The child's report: one "key value" line per field, then "end".
std::string Serialize(const BenchRun& r) {
  std::ostringstream o;
  o.precision(17);
  o << "outcome " << OutcomeName(r.outcome) << "\n"
    << "status " << OneLine(r.status) << "\n"
    << "message " << OneLine(r.message) << "\n"
    << "poses " << r.poses << "\nlandmarks " << r.landmarks << "\nedges " << r.edges << "\n"
    << "iterations " << r.iterations << "\n"
    << "initial_chi2 " << r.initial_chi2 << "\nfinal_chi2 " << r.final_chi2 << "\n"
    << "total " << r.total_seconds << "\nread " << r.read_seconds << "\ninit " << r.init_seconds << "\n"
    << "optimize " << r.optimize_seconds << "\nsetup " << r.setup_seconds << "\n"
    << "linearize " << r.linearize_seconds << "\nfactorize " << r.factorize_seconds << "\n"
    << "solve " << r.solve_seconds << "\nwrite " << r.write_seconds << "\nfloor " << r.floor_seconds << "\n"
    << "end\n";
  return o.str();
}

// Returns false unless the text is a complete report.
bool Deserialize(const std::string& text, BenchRun* r) {
  std::map<std::string, std::string> fields;
  if (!bench::ParseReport(text, &fields)) return false;
  std::map<std::string, double*> numbers = {
      {"initial_chi2", &r->initial_chi2}, {"final_chi2", &r->final_chi2},       {"total", &r->total_seconds},
      {"read", &r->read_seconds},         {"init", &r->init_seconds},           {"optimize", &r->optimize_seconds},
      {"setup", &r->setup_seconds},       {"linearize", &r->linearize_seconds}, {"factorize", &r->factorize_seconds},
      {"solve", &r->solve_seconds},       {"write", &r->write_seconds},         {"floor", &r->floor_seconds}};
  std::map<std::string, long*> counts = {{"poses", &r->poses}, {"landmarks", &r->landmarks}, {"edges", &r->edges}};
  bool outcome = false;
  for (const auto& [key, value] : fields) {
    if (key == "outcome") {
      outcome = OutcomeFromName(value, &r->outcome);
    } else if (key == "status") {
      r->status = value;
    } else if (key == "message") {
      r->message = value;
    } else if (key == "iterations") {
      r->iterations = std::atoi(value.c_str());
    } else if (auto n = numbers.find(key); n != numbers.end()) {
      *n->second = std::strtod(value.c_str(), nullptr);
    } else if (auto c = counts.find(key); c != counts.end()) {
      *c->second = std::strtol(value.c_str(), nullptr, 10);
    }
  }
  return outcome;
}

// The median over the runs of one field; negative (not available) if any run lacks it.
double MedianOf(const std::vector<BenchRun>& runs, double BenchRun::*field) {
  std::vector<double> v;
  for (const BenchRun& r : runs) {
    if (r.*field < 0) return -1;
    v.push_back(r.*field);
  }
  return Median(v);
}

// The first run that got as far as solving, whose problem figures the row shows.
const BenchRun* Representative(const BenchRow& row) {
  for (const BenchRun& r : row.runs) {
    if (r.outcome == BenchOutcome::kSolved || r.outcome == BenchOutcome::kSolveFailed) return &r;
  }
  return nullptr;
}

// Seconds for Markdown: three significant digits, or whole seconds from 100 s.
std::string Seconds(double s) {
  if (s < 0) return "n/a";
  return s >= 100 ? Fmt("%.0f", s) : Fmt("%.3g", s);
}

std::string CsvNumber(const char* format, double v) { return v < 0 ? "" : Fmt(format, v); }

std::string ThreadsText(const BenchConfig& c) {
  return std::to_string(c.threads > 0 ? c.threads : SolverOptions{}.num_threads);
}

// Splits "a,b,c"; returns false on an empty item.
bool SplitList(const std::string& s, std::vector<std::string>* items) {
  items->clear();
  std::string cur;
  std::istringstream in(s);
  while (std::getline(in, cur, ',')) {
    if (cur.empty()) return false;
    items->push_back(cur);
  }
  return !items->empty() && s.back() != ',';
}

// The table's columns: the Markdown header and the CSV header.
struct Column {
  const char* md;
  const char* csv;
};

const Column kColumns[] = {
    {"file", "file"},
    {"solver", "solver"},
    {"linear", "linear"},
    {"init", "init"},
    {"threads", "threads"},
    {"poses", "poses"},
    {"landmarks", "landmarks"},
    {"edges", "edges"},
    {"initial chi2", "initial_chi2"},
    {"final chi2", "final_chi2"},
    {"iterations", "iterations"},
    {"status", "status"},
    {"wall median [s]", "wall_median_s"},
    {"wall min [s]", "wall_min_s"},
    {"wall max [s]", "wall_max_s"},
    {"÷ best", "wall_over_best"},
    {"read [s]", "read_s"},
    {"init [s]", "init_s"},
    {"setup [s]", "setup_s"},
    {"linearize [s]", "linearize_s"},
    {"factorize [s]", "factorize_s"},
    {"solve [s]", "solve_s"},
    {"write [s]", "write_s"},
    {"start-up [s]", "startup_s"},
    {"process [s]", "process_s"},
    {"optimize [s]", "optimize_s"},
    {"floor [s]", "floor_s"},
    {"optimize/floor", "optimize_over_floor"},
    {"peak RSS [MiB]", "peak_rss_mib"},
};

// The least median wall time of the solved rows of each file.
std::map<std::string, double> BestWall(const std::vector<BenchRow>& rows) {
  std::map<std::string, double> best;
  for (const BenchRow& r : rows) {
    if (r.outcome != BenchOutcome::kSolved) continue;
    const auto it = best.find(r.file);
    if (it == best.end() || r.median_seconds < it->second) best[r.file] = r.median_seconds;
  }
  return best;
}

// One row's cells; `csv` chooses the number format and how missing numbers look; `best` is the
// least median wall time of the row's file (0: none solved).
std::vector<std::string> Cells(const BenchRow& row, bool csv, double best) {
  const auto sec = [csv](double s) { return csv ? CsvNumber("%.6g", s) : Seconds(s); };
  const std::string none = csv ? "" : "-";
  const BenchRun* rep = Representative(row);
  std::vector<std::string> c;
  c.push_back(csv ? row.file : Basename(row.file));
  c.push_back(ToString(row.config.algorithm));
  c.push_back(ToString(row.config.linear));
  c.push_back(ToString(row.config.init));
  c.push_back(ThreadsText(row.config));
  if (rep != nullptr) {
    c.push_back(std::to_string(rep->poses));
    c.push_back(std::to_string(rep->landmarks));
    c.push_back(std::to_string(rep->edges));
    c.push_back(Fmt(csv ? "%.12g" : "%.9g", rep->initial_chi2));
    c.push_back(Fmt(csv ? "%.12g" : "%.9g", rep->final_chi2));
    c.push_back(std::to_string(rep->iterations));
  } else {
    for (int i = 0; i < 6; ++i) c.push_back(none);
  }
  c.push_back(row.status);
  c.push_back(sec(row.median_seconds));
  c.push_back(sec(row.min_seconds));
  c.push_back(sec(row.max_seconds));
  if (best > 0 && row.outcome == BenchOutcome::kSolved) {
    c.push_back(Fmt(csv ? "%.4g" : "%.2f", row.median_seconds / best));
  } else {
    c.push_back(none);
  }
  for (double BenchRun::*f :
       {&BenchRun::read_seconds, &BenchRun::init_seconds, &BenchRun::setup_seconds, &BenchRun::linearize_seconds,
        &BenchRun::factorize_seconds, &BenchRun::solve_seconds, &BenchRun::write_seconds}) {
    c.push_back(rep != nullptr ? sec(MedianOf(row.runs, f)) : none);
  }
  c.push_back(row.startup_seconds >= 0 ? sec(row.startup_seconds) : none);
  c.push_back(row.startup_seconds >= 0 && rep != nullptr ? sec(row.startup_seconds + row.median_seconds) : none);
  for (double BenchRun::*f : {&BenchRun::optimize_seconds, &BenchRun::floor_seconds}) {
    c.push_back(rep != nullptr ? sec(MedianOf(row.runs, f)) : none);
  }
  const double floor = rep != nullptr ? MedianOf(row.runs, &BenchRun::floor_seconds) : -1;
  const double optimize = rep != nullptr ? MedianOf(row.runs, &BenchRun::optimize_seconds) : -1;
  if (floor > 0 && optimize >= 0) {
    c.push_back(Fmt(csv ? "%.4g" : "%.2f", optimize / floor));
  } else {
    c.push_back(csv ? "" : "n/a");
  }
  c.push_back(Fmt(csv ? "%.4g" : "%.1f", row.peak_rss_mib));
  return c;
}

}  // namespace

std::string BenchConfig::Name() const {
  std::string s = std::string(ToString(algorithm)) + "/" + ToString(linear) + "/" + ToString(init);
  if (threads > 0) s += "/" + std::to_string(threads) + "t";
  return s;
}

std::string ActiveBlasLibrary() {
  try {
    LoadSolverBackends();  // the BLAS comes with them
  } catch (const Error&) {
    return "none";
  }
  void* sym = ::dlsym(RTLD_DEFAULT, "dgemm_");
  if (sym == nullptr) return "none";
  Dl_info info;
  if (::dladdr(sym, &info) == 0 || info.dli_fname == nullptr) return "unknown";
  char resolved[PATH_MAX];
  if (::realpath(info.dli_fname, resolved) != nullptr) return resolved;
  return info.dli_fname;
}

BenchRun RunBenchOnce(const std::string& file, const BenchConfig& config) {
  BenchRun r;
  const Clock::time_point t0 = Clock::now();
  const Registry& registry = DefaultRegistry();
  GraphFile gf;
  try {
    gf = ReadGraphFile(file, registry);
  } catch (const std::exception& e) {
    r.outcome = BenchOutcome::kBadInput;
    r.status = "bad-input";
    r.message = e.what();
    r.total_seconds = SecondsSince(t0);
    return r;
  }
  r.read_seconds = SecondsSince(t0);
  r.poses = static_cast<long>(gf.values.Count(VarType::kSE2) + gf.values.Count(VarType::kSE3));
  r.landmarks = static_cast<long>(gf.values.Count(VarType::kPoint2) + gf.values.Count(VarType::kPoint3));
  r.edges = static_cast<long>(gf.graph.size());

  const Clock::time_point ti = Clock::now();
  try {
    Initialize(gf.graph, &gf.values, config.init, config.linear);  // the chordal start through petsc where it is that
  } catch (const std::exception& e) {
    r.outcome = BenchOutcome::kBadInput;
    r.status = "bad-input";
    r.message = std::string("initialisation: ") + e.what();
    r.total_seconds = SecondsSince(t0);
    return r;
  }
  r.init_seconds = SecondsSince(ti);

  SolverOptions options;
  options.algorithm = config.algorithm;
  options.linear_solver = config.linear;
  if (config.threads > 0) options.num_threads = config.threads;
  const SolverSummary s = Optimize(gf.graph, &gf.values, options);
  r.status = ToString(s.status);
  r.message = s.message;
  r.iterations = s.iterations;
  r.initial_chi2 = s.initial_chi2;
  r.final_chi2 = s.final_chi2;
  r.optimize_seconds = s.total_seconds;
  FillSplit(s, &r);
  if (!s.IsSolutionUsable()) {
    r.outcome = BenchOutcome::kSolveFailed;
    r.total_seconds = SecondsSince(t0);
    return r;
  }

  // Written as `tether optimize -o` would, to a file removed afterwards.
  const Clock::time_point tw = Clock::now();
  const fs::path out = fs::temp_directory_path() / ("tether_bench_" + std::to_string(::getpid()) + ".g2o");
  try {
    WriteG2oFile(out.string(), gf.values, gf.graph, registry);
  } catch (const std::exception& e) {
    r.outcome = BenchOutcome::kSolveFailed;
    r.status = "write-failed";
    r.message = e.what();
    r.total_seconds = SecondsSince(t0);
    return r;
  }
  r.write_seconds = SecondsSince(tw);
  r.total_seconds = SecondsSince(t0);
  std::error_code ec;
  fs::remove(out, ec);
  r.outcome = BenchOutcome::kSolved;
  return r;
}

BenchRun RunBenchInChild(const std::string& file, const BenchConfig& config) {
  const bench::ChildResult child = bench::RunInChild([&file, &config] {
    try {
      return Serialize(RunBenchOnce(file, config));
    } catch (const std::exception& e) {
      BenchRun failed;
      failed.status = "crashed";
      failed.message = std::string("uncaught exception: ") + e.what();
      return Serialize(failed);
    } catch (...) {
      BenchRun failed;
      failed.status = "crashed";
      failed.message = "uncaught exception";
      return Serialize(failed);
    }
  });
  BenchRun r;
  r.status = "crashed";
  const bool complete = Deserialize(child.report, &r);
  r.peak_rss_mib = child.peak_rss_mib;
  if (!complete || !child.exited_cleanly()) {
    r.outcome = BenchOutcome::kCrashed;
    r.status = "crashed";
    const std::string why = child.Failure(complete);
    if (!why.empty()) r.message = why;
  }
  return r;
}

void SummarizeBenchRow(BenchRow* row) {
  row->outcome = BenchOutcome::kSolved;
  row->status.clear();
  row->message.clear();
  row->peak_rss_mib = 0;
  std::vector<double> totals;
  int worst = -1;
  for (const BenchRun& r : row->runs) {
    if (Severity(r.outcome) > worst) {
      worst = Severity(r.outcome);
      row->outcome = r.outcome;
      row->status = r.status;
      row->message = r.message;
    }
    totals.push_back(r.total_seconds);
    row->peak_rss_mib = std::max(row->peak_rss_mib, r.peak_rss_mib);
  }
  if (totals.empty()) {
    row->outcome = BenchOutcome::kCrashed;
    row->status = "crashed";
    row->message = "no runs";
    row->median_seconds = row->min_seconds = row->max_seconds = 0;
    return;
  }
  row->median_seconds = Median(totals);
  row->min_seconds = *std::min_element(totals.begin(), totals.end());
  row->max_seconds = *std::max_element(totals.begin(), totals.end());
}

std::vector<std::string> BenchColumnNames() {
  std::vector<std::string> names;
  for (const Column& c : kColumns) names.emplace_back(c.csv);
  return names;
}

std::vector<std::size_t> SelectBenchColumns(const std::string& names) {
  std::vector<std::size_t> out;
  if (names.empty()) return out;
  std::vector<std::string> items;
  if (!SplitList(names, &items)) throw InvalidArgument("--columns '" + names + "' is not a comma-separated list");
  for (const std::string& n : items) {
    std::size_t i = 0;
    while (i < std::size(kColumns) && n != kColumns[i].csv) ++i;
    if (i == std::size(kColumns)) {
      std::string known;
      for (const Column& c : kColumns) known += (known.empty() ? "" : ", ") + std::string(c.csv);
      throw InvalidArgument("unknown column '" + n + "' in --columns; the columns are " + known);
    }
    out.push_back(i);
  }
  return out;
}

namespace {

// The indices shown: `columns`, or every column where it is empty.
std::vector<std::size_t> Shown(const std::vector<std::size_t>& columns) {
  if (!columns.empty()) return columns;
  std::vector<std::size_t> all(std::size(kColumns));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  return all;
}

}  // namespace

std::string FormatBenchMarkdown(const std::vector<BenchRow>& rows, int repeat, const std::string& blas,
                                const std::vector<std::size_t>& columns) {
  std::ostringstream o;
  o << "CHOLMOD's BLAS (where dgemm_ resolves): `" << blas << "`. " << repeat << (repeat == 1 ? " run" : " runs")
    << " per configuration, each in a fresh child process; wall = read + initialise + solve + write; the "
       "split and the floor are medians over the runs, the ratio is that of the medians; ÷ best: the median wall "
       "over the least of the file's solved rows; start-up: `tether --version` from fork to exit (the libraries "
       "loaded), which the forked runs do not pay; process = start-up + wall median, the whole `tether optimize` "
       "run; n/a: not measured apart (Ceres times its linear solver as a whole).\n\n";
  const std::vector<std::size_t> shown = Shown(columns);
  std::string header = "|", rule = "|";
  for (std::size_t i : shown) {
    header += std::string(" ") + kColumns[i].md + " |";
    rule += "---|";
  }
  o << header << "\n" << rule << "\n";
  const std::map<std::string, double> best = BestWall(rows);
  for (const BenchRow& row : rows) {
    const auto b = best.find(row.file);
    const std::vector<std::string> cells = Cells(row, false, b == best.end() ? 0 : b->second);
    o << "|";
    for (std::size_t i : shown) o << " " << cells[i] << " |";
    o << "\n";
  }
  return o.str();
}

std::string FormatBenchCsv(const std::vector<BenchRow>& rows, const std::string& blas,
                           const std::vector<std::size_t>& columns) {
  std::ostringstream o;
  const std::vector<std::size_t> shown = Shown(columns);
  for (std::size_t i : shown) o << kColumns[i].csv << ",";
  o << "runs,blas,message\n";
  const std::map<std::string, double> best = BestWall(rows);
  for (const BenchRow& row : rows) {
    const auto b = best.find(row.file);
    const std::vector<std::string> cells = Cells(row, true, b == best.end() ? 0 : b->second);
    for (std::size_t i : shown) o << CsvField(cells[i]) << ",";
    o << row.runs.size() << "," << CsvField(blas) << "," << CsvField(OneLine(row.message)) << "\n";
  }
  return o.str();
}

namespace {

// tether bench --outliers (outlier_bench.h).
int RunOutliers(const BenchCommand& cmd, std::ostream& out, std::ostream& err) {
  OutlierBenchOptions o;
  o.files = cmd.files;
  o.grouped = cmd.grouped;
  std::vector<std::string> items;
  auto numbers = [&](const std::string& text, const char* what, auto* into) {
    if (!SplitList(text, &items)) return false;
    into->clear();
    for (const std::string& s : items) {
      char* end = nullptr;
      const double x = std::strtod(s.c_str(), &end);
      if (end != s.c_str() + s.size() || !std::isfinite(x) || x < 0) {
        err << "tether bench: " << what << " '" << s << "' is not a number of 0 or more\n";
        return false;
      }
      into->push_back(static_cast<typename std::decay_t<decltype(*into)>::value_type>(x));
    }
    return !into->empty();
  };
  if (cmd.files.empty()) {
    err << "tether bench: no FILES given\n";
    return 2;
  }
  if (const std::string why = bench::CheckFilesAndOutput(cmd.files, cmd.output); !why.empty()) {
    err << "tether bench: " << why << "\n";
    return 2;
  }
  if (!numbers(cmd.outliers, "--outliers", &o.rates) || !numbers(cmd.seeds, "--seeds", &o.seeds) ||
      !SplitList(cmd.methods, &o.methods)) {
    err << "tether bench: --outliers, --seeds and --methods take comma-separated lists\n";
    return 2;
  }
  std::vector<OutlierBenchRow> rows;
  try {
    rows = RunOutlierBench(o, err);
  } catch (const InvalidArgument& e) {
    err << "tether bench: " << e.what() << "\n";
    return 2;
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 1;
  }
  return bench::WriteTable(FormatOutlierBenchMarkdown(rows), cmd.output, out, err);
}

}  // namespace

namespace {

// The configurations --solvers x --linear x --init x --threads name; "" or why not.
std::string ParseConfigs(const BenchCommand& cmd, std::vector<BenchConfig>* configs, std::ostream& err) {
  std::vector<std::string> items;
  std::vector<Algorithm> algorithms;
  if (!SplitList(cmd.solvers, &items)) return "--solvers '" + cmd.solvers + "' is not a comma-separated list";
  for (const std::string& s : items) {
    Algorithm a;
    if (!FromString(s, &a)) return "unknown solver '" + s + "' in --solvers; use " + AlgorithmNames();
    algorithms.push_back(a);
  }
  std::vector<LinearSolverType> linears;
  if (!SplitList(cmd.linear, &items)) return "--linear '" + cmd.linear + "' is not a comma-separated list";
  for (const std::string& s : items) {
    LinearSolverType t;
    if (!FromString(s, &t)) return "unknown linear solver '" + s + "' in --linear; use " + LinearSolverNames();
    linears.push_back(t);
  }
  std::vector<InitMethod> inits;
  if (!SplitList(cmd.init, &items)) return "--init '" + cmd.init + "' is not a comma-separated list";
  for (const std::string& s : items) {
    InitMethod m;
    if (!FromString(s, &m)) return "unknown initialisation '" + s + "' in --init; use " + EnumNameList<InitMethod>();
    inits.push_back(m);
  }
  std::vector<int> threads = {0};
  if (!cmd.threads.empty()) {
    if (!SplitList(cmd.threads, &items)) return "--threads '" + cmd.threads + "' is not a comma-separated list";
    threads.clear();
    for (const std::string& s : items) {
      char* end = nullptr;
      errno = 0;
      const long k = std::strtol(s.c_str(), &end, 10);
      SolverOptions check;
      check.num_threads = k < 1 || k > 1 << 20 ? 0 : static_cast<int>(k);
      std::string why;
      if (end == s.c_str() || *end != '\0' || errno != 0 || !check.IsValid(&why)) {
        return "bad thread count '" + s +
               "' in --threads: " + (why.empty() ? std::string("num_threads must be a whole number") : why);
      }
      threads.push_back(check.num_threads);
    }
  }
  for (Algorithm a : algorithms) {
    for (LinearSolverType l : linears) {
      if (a == Algorithm::kCeres && !CeresRunsWith(l)) {
        err << "tether bench: skipping ceres/" << ToString(l)
            << ": Ceres solves with SPARSE_NORMAL_CHOLESKY over CHOLMOD only\n";
        continue;
      }
      for (InitMethod m : inits) {
        for (int k : threads) {
          BenchConfig c;
          c.algorithm = a;
          c.linear = l;
          c.init = m;
          c.threads = k;
          configs->push_back(c);
        }
      }
    }
  }
  if (configs->empty()) return "no configuration left to run (ceres runs with --linear auto or cholmod only)";
  return "";
}

// Every file under every configuration, --repeat times each, in child processes.
std::vector<BenchRow> RunConfigs(const BenchCommand& cmd, const std::vector<BenchConfig>& configs,
                                 const std::string& blas, std::ostream& err) {
  std::ostream none(nullptr);  // -q: no progress lines
  std::ostream& progress = cmd.quiet ? none : err;
  const std::size_t total_rows = cmd.files.size() * configs.size();
  progress << "tether bench: " << cmd.files.size() << (cmd.files.size() == 1 ? " file" : " files") << " x "
           << configs.size() << (configs.size() == 1 ? " configuration" : " configurations") << " x " << cmd.repeat
           << (cmd.repeat == 1 ? " run" : " runs") << "; BLAS " << blas << "\n";
  std::vector<BenchRow> rows;
  for (const std::string& file : cmd.files) {
    for (const BenchConfig& config : configs) {
      BenchRow row;
      row.file = file;
      row.config = config;
      for (int k = 1; k <= cmd.repeat; ++k) {
        progress << "[" << rows.size() + 1 << "/" << total_rows << "] " << file << " " << config.Name() << ": run " << k
                 << " of " << cmd.repeat << " ... " << std::flush;
        const BenchRun r = RunBenchInChild(file, config);
        progress << Fmt("%.3f s, ", r.total_seconds) << r.status << std::endl;
        row.runs.push_back(r);
      }
      SummarizeBenchRow(&row);
      if (row.outcome != BenchOutcome::kSolved) {
        err << "error: " << file << " " << config.Name() << ": " << row.status << ": " << row.message << "\n";
      }
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

}  // namespace

double ProgramStartupSeconds(const std::string& program, int runs) {
  std::vector<double> seconds;
  for (int i = 0; i < runs; ++i) {
    const auto t0 = Clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) return -1;
    if (pid == 0) {
      // The child: its output goes nowhere; exec or die without running the parent's exit code.
      if (FILE* null = std::fopen("/dev/null", "w"); null != nullptr) {
        ::dup2(::fileno(null), STDOUT_FILENO);
        ::dup2(::fileno(null), STDERR_FILENO);
      }
      ::execl(program.c_str(), "tether", "--version", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    int status = 0;
    if (::waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
    seconds.push_back(SecondsSince(t0));
  }
  return seconds.empty() ? -1 : Median(seconds);
}

int RunBench(const BenchCommand& cmd, std::ostream& out, std::ostream& err) {
  if (cmd.replay) return RunReplayBench(cmd, out, err);
  if (!cmd.outliers.empty()) return RunOutliers(cmd, out, err);
  const auto usage = [&err](const std::string& what) {
    err << "tether bench: " << what << "\n";
    return kExitUsage;
  };
  if (cmd.files.empty()) return usage("no FILES given; name one or more graph files (.g2o, .graph)");
  if (cmd.repeat < 1) return usage("--repeat must be at least 1; got " + std::to_string(cmd.repeat));
  if (cmd.format != "md" && cmd.format != "csv") return usage("unknown --format '" + cmd.format + "'; use md or csv");
  if (const std::string why = bench::CheckFilesAndOutput(cmd.files, cmd.output); !why.empty()) return usage(why);
  // Plugins first, into the registry the runs read with (the forked children inherit them);
  // a plugin's step strategy or linear solver is known once it is loaded.
  PluginLoader loader(DefaultRegistry());
  std::ostream none(nullptr);
  if (!LoadPlugins(cmd.plugins, &loader, cmd.quiet ? none : err, err)) return kExitPluginFailed;
  std::vector<BenchConfig> configs;
  if (const std::string why = ParseConfigs(cmd, &configs, err); !why.empty()) return usage(why);
  std::vector<std::size_t> columns;
  try {
    columns = SelectBenchColumns(cmd.columns);
  } catch (const InvalidArgument& e) {
    return usage(e.what());
  }

  const std::string blas = ActiveBlasLibrary();
  // The program's start-up, measured before any run (a child forked later would inherit
  // OpenMP's threads; see RunBenchInChild).
  const double startup = cmd.program.empty() ? -1 : ProgramStartupSeconds(cmd.program, cmd.repeat);
  std::vector<BenchRow> rows = RunConfigs(cmd, configs, blas, err);
  for (BenchRow& row : rows) row.startup_seconds = startup;
  const std::string table =
      cmd.format == "csv" ? FormatBenchCsv(rows, blas, columns) : FormatBenchMarkdown(rows, cmd.repeat, blas, columns);
  if (const int rc = bench::WriteTable(table, cmd.output, out, err); rc != 0) return rc;

  std::vector<BenchOutcome> outcomes;
  for (const BenchRow& row : rows) outcomes.push_back(row.outcome);
  return bench::ExitCode(outcomes);
}

namespace {

class BenchCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override {
    cmd_.program = "/proc/self/exe";
    return RunBench(cmd_, out, err);
  }

 private:
  BenchCommand cmd_;
};

void BenchCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand(
      "bench", "Time solver configurations on graph files, or replays (--replay) (docs/benchmarking.md)");
  sub->add_option("files", cmd_.files, "Graph files (.g2o, TORO .graph, or iSAM landmark text)");
  sub->add_option("--solvers", cmd_.solvers, "Comma-separated: gn, lm, dogleg, ceres")->capture_default_str();
  sub->add_option("--linear", cmd_.linear,
                  "Comma-separated: auto, block, cholmod, ldlt, qr, petsc, petsc-iterative (built with "
                  "TETHER_WITH_MPI; one process here, docs/distributed.md)")
      ->capture_default_str();
  sub->add_option("--init", cmd_.init, "Comma-separated: file, spanning-tree, chordal")->capture_default_str();
  sub->add_option("--threads", cmd_.threads, "Comma-separated thread counts (default: the solver's)");
  sub->add_option("--repeat", cmd_.repeat, "Runs per configuration")->capture_default_str();
  sub->add_option("--format", cmd_.format, "md | csv")->capture_default_str();
  AddPath(sub, "-o,--output", &cmd_.output, "Write the table here instead of stdout");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No progress lines (the table and errors only)");
  sub->add_option("--columns", cmd_.columns,
                  "Comma-separated columns to show, in that order (CSV names: file, solver, linear, init, threads, "
                  "final_chi2, iterations, status, wall_median_s, wall_over_best, ...; default: all)");
  sub->add_flag("--replay", cmd_.replay,
                "Replay each file through the incremental smoother (as tether replay) and tabulate update "
                "latencies, chi2 and peak memory");
  sub->add_option("--outliers", cmd_.outliers,
                  "Outlier benchmark: comma-separated rates of false loop closures (0.1,0.3,0.5)");
  sub->add_option("--seeds", cmd_.seeds, "With --outliers: comma-separated seeds")->capture_default_str();
  sub->add_option("--methods", cmd_.methods,
                  "With --outliers: none, huber, dcs, cdcs (DCS in chunks), gnc, gnc-ls (GNC from least squares), sc "
                  "(switchable constraints), sc:SIGMA (switch prior sigma)")
      ->capture_default_str();
  sub->add_flag("--grouped", cmd_.grouped, "With --outliers: false closures in consistent clusters of 5");
  sub->add_option("--plugin", cmd_.plugins, "Load a factor plugin (.so path or name) first; repeatable")
      ->allow_extra_args(false);
}

}  // namespace

std::unique_ptr<Command> MakeBenchCommand() { return std::make_unique<BenchCli>(); }

}  // namespace tether
