#pragma once
// `tether bench`: runs files through every configuration of solver, linear solver,
// initialisation and thread count, several times each, and tabulates chi2, iterations, wall
// times, the time split, the factorisation floor and peak memory. docs/benchmarking.md says
// what every column means.
//
// Every run happens in a forked child process that reads the file, initialises, solves and
// writes the result to a temporary file, and sends its measurements back over a pipe. So each
// run's peak resident memory (the child's, from wait4) is its own, earlier runs cannot warm
// caches inside the process, and a run that crashes is reported in its row without stopping
// the others.
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/solvers/initialize.h"
#include "tether/solvers/solver_options.h"

namespace tether {

struct BenchCommand {
  std::vector<std::string> files;
  bool quiet = false;            ///< no progress lines (errors still go to the error stream)
  std::string columns;           ///< comma-separated CSV column names to show, in that order; empty: all
  std::string solvers = "lm";    ///< comma-separated: gn, lm, ceres
  std::string linear = "auto";   ///< comma-separated: auto, block, cholmod, ldlt, qr
  std::string init = "chordal";  ///< comma-separated: file, spanning-tree, chordal
  std::string threads;           ///< comma-separated thread counts; empty: the solver's default
  int repeat = 5;                ///< runs per configuration
  std::string format = "md";     ///< md | csv
  std::string output;            ///< table to this file instead of `out`
  /// Factor plugins (paths or names) loaded into the default registry before any file is
  /// read, as `tether optimize --plugin` does; one that fails to load: exit code 1, nothing run.
  std::vector<std::string> plugins;
  /// Replay each file through the incremental smoother instead (`tether bench --replay`,
  /// replay_bench.h): the solver lists and plugins do not apply.
  bool replay = false;
  /// The outlier benchmark instead (outlier_bench.h): comma-separated rates of false loop
  /// closures (e.g. "0.1,0.3,0.5"); empty: not run.
  std::string outliers;
  std::string seeds = "1,2,3,4,5";             ///< with outliers: the seeds
  std::string methods = "none,huber,dcs,gnc";  ///< with outliers: the methods
  bool grouped = false;                        ///< with outliers: clusters of 5 consistent false closures
  /// The tether program whose start-up (ProgramStartupSeconds) the table adds to each row's wall
  /// time; `tether bench` sets it to itself. Empty: not measured.
  std::string program;
};

/// One configuration: the cross product of the command's lists gives them.
struct BenchConfig {
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  LinearSolverType linear = LinearSolverType::kAuto;
  InitMethod init = InitMethod::kChordal;
  int threads = 0;  ///< SolverOptions::num_threads; 0: the solver's default

  /// "lm/cholmod/chordal", with "/2t" appended where threads are set.
  std::string Name() const;
};

/// How a run ended.
enum class BenchOutcome {
  kSolved,       ///< the solver returned a usable solution (converged, max-iterations, time-limit)
  kSolveFailed,  ///< the solver's status says it failed (diverged, rank-deficient, invalid-input)
  kBadInput,     ///< the file could not be read or initialised
  kCrashed,      ///< the child died (signal) or returned nothing
};

/// The measurements of one run. Times are wall-clock seconds; a negative value means the
/// quantity is not available in this build (the solver does not report it).
struct BenchRun {
  BenchOutcome outcome = BenchOutcome::kCrashed;
  std::string status;   ///< the solver's status name, or bad-input, crashed
  std::string message;  ///< why it ended (solver message, read error, signal)
  long poses = 0;       ///< SE2 and SE3 variables
  long landmarks = 0;   ///< Point2 and Point3 variables
  long edges = 0;       ///< factors
  int iterations = 0;
  double initial_chi2 = 0;  ///< after initialisation, where the solve starts
  double final_chi2 = 0;
  double total_seconds = 0;  ///< read + initialise + solve + write
  double read_seconds = 0;
  double init_seconds = 0;
  double optimize_seconds = 0;  ///< the whole Optimize call (SolverSummary::total_seconds)
  double setup_seconds = 0;     ///< symbolic analysis and structure
  double linearize_seconds = 0;
  double factorize_seconds = -1;  ///< numeric factorisations (-1: not apart, as with ceres)
  double solve_seconds = 0;       ///< triangular solves (ceres: its whole linear solver time)
  double write_seconds = 0;
  /// The last numeric factorisation (of the final H's pattern) times the iterations: what
  /// the factorisations alone would cost (-1: not available, as with ceres).
  double floor_seconds = -1;
  double peak_rss_mib = 0;  ///< the child's peak resident set (wait4), MiB
};

/// One row of the table: a file, a configuration and its runs summarised.
struct BenchRow {
  std::string file;  ///< as given on the command line
  BenchConfig config;
  std::vector<BenchRun> runs;
  /// The worst outcome of the runs (crashed > bad input > solve failed > solved), and the
  /// status and message of the first run with it.
  BenchOutcome outcome = BenchOutcome::kCrashed;
  std::string status;
  std::string message;
  double median_seconds = 0, min_seconds = 0, max_seconds = 0;  ///< of total_seconds
  double peak_rss_mib = 0;                                      ///< the highest of the runs
  /// The program's start-up and exit, which the forked runs do not pay: ProgramStartupSeconds
  /// (-1: not measured). The whole process of `tether optimize FILE` is about this plus
  /// median_seconds.
  double startup_seconds = -1;
};

/// The wall seconds `program --version` takes from the fork to its exit, the median of `runs`:
/// exec, loading and relocating the shared libraries, their constructors, the flags' parser,
/// and the exit. -1 where the program cannot be run.
double ProgramStartupSeconds(const std::string& program, int runs);

/// Runs one configuration on `file` in this process (what the forked child does).
BenchRun RunBenchOnce(const std::string& file, const BenchConfig& config);
/// Runs one configuration on `file` in a forked child and collects its measurements and peak
/// memory; a child that dies is reported as kCrashed with the signal in the message.
/// Call it from a process that has not solved anything itself (as `tether bench` does): CHOLMOD
/// runs on OpenMP, and a forked child of a process whose OpenMP threads exist waits for them
/// forever (libgomp is not fork-safe). The child's peak memory starts from the caller's
/// resident memory at the fork.
BenchRun RunBenchInChild(const std::string& file, const BenchConfig& config);
/// Fills the summary fields of `row` from its runs.
void SummarizeBenchRow(BenchRow* row);

/// The library the dgemm_ symbol (BLAS), which CHOLMOD's supernodal factorisation calls,
/// resolves to in this process, with symbolic links resolved, after loading the solver
/// back-ends that bring it (tether/solvers/backends.h); "none" where they cannot be loaded.
std::string ActiveBlasLibrary();

/// The table's columns by their CSV names ("file", "wall_median_s", "wall_over_best", ...), in
/// order.
std::vector<std::string> BenchColumnNames();
/// The indices of the comma-separated column names in `names` (CSV names), in the order given;
/// every column where `names` is empty. Throws InvalidArgument naming an unknown column and
/// listing the known ones.
std::vector<std::size_t> SelectBenchColumns(const std::string& names);

/// The table as Markdown (a line naming the BLAS, then the table) or CSV (a header row, then
/// one row per configuration; numbers not available are empty fields). `columns`: the indices
/// of the columns to show (SelectBenchColumns); empty: all. The "÷ best" column
/// (wall_over_best) is a row's median wall time over the least median wall time of the solved
/// rows of the same file.
std::string FormatBenchMarkdown(const std::vector<BenchRow>& rows, int repeat, const std::string& blas,
                                const std::vector<std::size_t>& columns = {});
std::string FormatBenchCsv(const std::vector<BenchRow>& rows, const std::string& blas,
                           const std::vector<std::size_t>& columns = {});

/// `tether bench`. Progress (plugins loaded, file, configuration, run k of N) goes to `err`, the table to
/// `out` or cmd.output. Exit codes: 0 every run solved; 1 some file could not be read or
/// initialised (its rows say so; the other rows are complete); 2 bad usage, nothing run;
/// 3 otherwise some run failed (a solver status that is not usable, or a crash).
int RunBench(const BenchCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
