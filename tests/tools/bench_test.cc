// `tether bench`: rows and columns, agreement with `tether optimize`, the two table formats,
// progress on stderr, bad usage, and failing or crashing runs reported in their rows; and the
// replay mode (--replay).
#include "tether/tools/bench.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "testing/cli.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/tools/replay.h"
#include "tether/tools/replay_bench.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      cells.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  cells.push_back(cur);
  return cells;
}

// A CSV table as rows of name -> value; fails the test if a row's width differs from the header's.
std::vector<std::map<std::string, std::string>> ParseCsv(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = SplitCsvLine(line);
    if (header.empty()) {
      header = cells;
      continue;
    }
    EXPECT_EQ(cells.size(), header.size()) << line;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < cells.size() && i < header.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

std::size_t Count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

class BenchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_bench_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }

  // Writes a simulated graph and returns its path.
  std::string Simulated(const std::string& name, SimWorld world, int poses, std::size_t* factors = nullptr) {
    SimulateOptions so;
    so.world = world;
    so.poses = poses;
    so.seed = 3;
    const SimulatedGraph sim = Simulate(so);
    WriteG2oFile(P(name), sim.initial, sim.graph, DefaultRegistry());
    if (factors != nullptr) *factors = sim.graph.size();
    return P(name);
  }

  int Bench(const BenchCommand& cmd) {
    out_.str("");
    err_.str("");
    return RunBench(cmd, out_, err_);
  }

  fs::path dir_;
  std::ostringstream out_, err_;
};

TEST_F(BenchTest, OneRowPerFileAndConfigurationWithEveryColumn) {
  std::size_t factors_m = 0, factors_s = 0;
  BenchCommand cmd;
  cmd.files = {Simulated("m.g2o", SimWorld::kManhattan, 200, &factors_m),
               Simulated("s.g2o", SimWorld::kSphere, 100, &factors_s)};
  cmd.solvers = "gn,lm";
  cmd.init = "file,chordal";
  cmd.repeat = 3;
  cmd.format = "csv";
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 8u) << out_.str();  // 2 files x 2 solvers x 2 initialisations
  const char* configs[][2] = {{"gn", "file"}, {"gn", "chordal"}, {"lm", "file"}, {"lm", "chordal"}};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const bool first = i < 4;
    EXPECT_EQ(r.at("file"), first ? cmd.files[0] : cmd.files[1]);
    EXPECT_EQ(r.at("solver"), configs[i % 4][0]);
    EXPECT_EQ(r.at("init"), configs[i % 4][1]);
    EXPECT_EQ(r.at("linear"), "auto");
    EXPECT_EQ(r.at("poses"), first ? "200" : "100");
    EXPECT_EQ(r.at("landmarks"), "0");
    EXPECT_EQ(r.at("edges"), std::to_string(first ? factors_m : factors_s));
    EXPECT_EQ(r.at("status"), "converged");
    EXPECT_EQ(r.at("runs"), "3");
    EXPECT_GE(std::stoi(r.at("iterations")), 1);
    EXPECT_GT(std::stod(r.at("initial_chi2")), std::stod(r.at("final_chi2")));
    const double lo = std::stod(r.at("wall_min_s")), med = std::stod(r.at("wall_median_s")),
                 hi = std::stod(r.at("wall_max_s"));
    EXPECT_GT(lo, 0);
    EXPECT_LE(lo, med);
    EXPECT_LE(med, hi);
    // The parts fit inside the whole.
    const double read = std::stod(r.at("read_s")), opt = std::stod(r.at("optimize_s"));
    EXPECT_GT(read, 0);
    EXPECT_GT(opt, 0);
    EXPECT_LT(read, hi);
    EXPECT_LT(opt, hi);
    EXPECT_GT(std::stod(r.at("linearize_s")), 0);
    EXPECT_GT(std::stod(r.at("factorize_s")), 0);
    EXPECT_LT(std::stod(r.at("factorize_s")), opt);
    EXPECT_GT(std::stod(r.at("floor_s")), 0);
    EXPECT_GT(std::stod(r.at("optimize_over_floor")), 0);
    EXPECT_EQ(r.at("threads"), "1");  // the solver's default
    EXPECT_GT(std::stod(r.at("peak_rss_mib")), 1.0);
    EXPECT_FALSE(r.at("blas").empty());
    EXPECT_EQ(r.at("blas"), ActiveBlasLibrary());
  }
  // The file's start does not change with the solver; the chordal start is better.
  EXPECT_EQ(rows[0].at("initial_chi2"), rows[2].at("initial_chi2"));
  EXPECT_LT(std::stod(rows[1].at("initial_chi2")), std::stod(rows[0].at("initial_chi2")));
}

// The final chi2 is what `tether optimize` reports for the same configuration.
// --columns chooses the columns and their order; "÷ best" is 1 for the fastest solved row of
// each file and above 1 for the others; an unknown column is refused with the list, and -q
// leaves out the progress lines.
TEST_F(BenchTest, ColumnsChooseWhatIsShownAndTheBestIsOne) {
  BenchCommand cmd;
  cmd.files = {Simulated("m.g2o", SimWorld::kManhattan, 200, nullptr),
               Simulated("t.g2o", SimWorld::kManhattan, 150, nullptr)};
  cmd.solvers = "gn,lm,dogleg";
  cmd.repeat = 1;
  cmd.format = "csv";
  cmd.quiet = true;
  cmd.columns = "wall_over_best,file,solver,final_chi2";
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  EXPECT_EQ(err_.str(), "");  // -q: no progress
  const std::string header = out_.str().substr(0, out_.str().find('\n'));
  EXPECT_EQ(header, "wall_over_best,file,solver,final_chi2,runs,blas,message");
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 6u) << out_.str();
  for (const std::string& file : cmd.files) {
    int ones = 0;
    for (const auto& r : rows) {
      if (r.at("file") != file) continue;
      const double ratio = std::stod(r.at("wall_over_best"));
      EXPECT_GE(ratio, 1.0) << out_.str();
      ones += ratio == 1.0;
    }
    EXPECT_GE(ones, 1) << file << ":\n" << out_.str();
  }
  BenchCommand bad = cmd;
  bad.columns = "file,speed";
  out_.str("");
  err_.str("");
  EXPECT_EQ(Bench(bad), 2);
  EXPECT_NE(err_.str().find("unknown column 'speed'"), std::string::npos) << err_.str();
  EXPECT_NE(err_.str().find("wall_over_best"), std::string::npos) << err_.str();
}

TEST_F(BenchTest, FinalChi2MatchesTetherOptimize) {
  const std::string file = Simulated("l.g2o", SimWorld::kLandmarks, 120);
  BenchCommand cmd;
  cmd.files = {file};
  cmd.solvers = "gn,lm,ceres";
  cmd.linear = "cholmod,qr";
  cmd.init = "spanning-tree";
  cmd.repeat = 1;
  cmd.format = "csv";
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  EXPECT_NE(err_.str().find("skipping ceres/qr"), std::string::npos) << err_.str();
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 5u) << out_.str();  // gn and lm over two linear solvers, ceres over cholmod
  for (const auto& r : rows) {
    // Ceres times its linear solver as a whole: no factorisation time apart, no floor.
    const bool ceres = r.at("solver") == "ceres";
    EXPECT_EQ(r.at("factorize_s").empty(), ceres) << r.at("solver");
    EXPECT_EQ(r.at("floor_s").empty(), ceres) << r.at("solver");
    EXPECT_EQ(r.at("optimize_over_floor").empty(), ceres) << r.at("solver");
    // The program, not RunOptimize in this process: a process that has solved with CHOLMOD
    // has OpenMP threads, which a forked child (the next bench run) cannot use.
    const std::string args = " optimize " + file + " -q --solver " + r.at("solver") + " --linear " + r.at("linear") +
                             " --init " + r.at("init");
    FILE* p = popen((std::string(TETHER_CLI) + args + " 2>&1").c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string report;
    char buf[4096];
    std::size_t n;
    while ((n = fread(buf, 1, sizeof(buf), p)) > 0) report.append(buf, n);
    ASSERT_EQ(pclose(p), 0) << report;
    const std::size_t at = report.find("final chi2");
    ASSERT_NE(at, std::string::npos) << report;
    const double reported = std::stod(report.substr(at + 10));  // printed to 9 digits
    const double benched = std::stod(r.at("final_chi2"));
    EXPECT_NEAR(benched, reported, 1e-8 * reported) << r.at("solver") << "/" << r.at("linear");
    const std::size_t it = report.find("iterations");
    ASSERT_NE(it, std::string::npos);
    EXPECT_EQ(std::stoi(report.substr(it + 10)), std::stoi(r.at("iterations"))) << r.at("solver");
  }
}

// --threads: one row per thread count, the same result in each (assembly is bit-identical
// for any number of threads).
TEST_F(BenchTest, ThreadCountsAreConfigurations) {
  BenchCommand cmd;
  cmd.files = {Simulated("m.g2o", SimWorld::kManhattan, 300)};
  cmd.solvers = "gn,lm";
  cmd.threads = "1,2";
  cmd.repeat = 1;
  cmd.format = "csv";
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 4u) << out_.str();
  EXPECT_EQ(rows[0].at("threads"), "1");
  EXPECT_EQ(rows[1].at("threads"), "2");
  EXPECT_EQ(rows[2].at("solver"), "lm");
  EXPECT_EQ(rows[3].at("threads"), "2");
  for (int i : {0, 2}) {
    EXPECT_EQ(rows[i].at("final_chi2"), rows[i + 1].at("final_chi2"));
    EXPECT_EQ(rows[i].at("iterations"), rows[i + 1].at("iterations"));
  }
  EXPECT_NE(err_.str().find("gn/auto/chordal/2t: run 1 of 1"), std::string::npos) << err_.str();
}

// The Markdown table: the BLAS line, a header, a rule and one row per configuration, every
// line with the same number of cells; files shown by name.
TEST_F(BenchTest, MarkdownTableParses) {
  BenchCommand cmd;
  cmd.files = {Simulated("m.g2o", SimWorld::kManhattan, 150)};
  cmd.solvers = "gn,lm";
  cmd.repeat = 2;
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  std::istringstream in(out_.str());
  std::string line;
  std::vector<std::vector<std::string>> table;
  std::string preface;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] != '|') {
      preface += line;
      continue;
    }
    ASSERT_EQ(line.back(), '|') << line;
    std::vector<std::string> cells;
    std::istringstream cs(line.substr(1));
    std::string cell;
    while (std::getline(cs, cell, '|')) {
      const std::size_t b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    table.push_back(cells);
  }
  EXPECT_NE(preface.find("`" + ActiveBlasLibrary() + "`"), std::string::npos) << preface;
  EXPECT_NE(preface.find("2 runs per configuration"), std::string::npos) << preface;
  ASSERT_EQ(table.size(), 4u) << out_.str();
  const std::size_t width = table[0].size();
  EXPECT_EQ(width, 29u);  // with "÷ best", start-up and process
  for (const auto& row : table) EXPECT_EQ(row.size(), width);
  EXPECT_EQ(table[0][0], "file");
  EXPECT_EQ(table[0][12], "wall median [s]");
  EXPECT_EQ(table[1][0], "---");
  EXPECT_EQ(table[2][0], "m.g2o");
  EXPECT_EQ(table[2][1], "gn");
  EXPECT_EQ(table[3][1], "lm");
  EXPECT_EQ(table[3][5], "150");
  EXPECT_EQ(table[3][11], "converged");
  EXPECT_EQ(table[0][15], "÷ best");
  EXPECT_EQ(table[0][23], "start-up [s]");
  EXPECT_EQ(table[3][23], "-");             // BenchCommand::program not set: not measured
  EXPECT_GT(std::stod(table[3][28]), 1.0);  // peak RSS
}

// `tether bench` measures its own start-up (the libraries loaded, which the forked runs do not
// pay) and adds it to each row's wall time: the whole process of `tether optimize`.
TEST_F(BenchTest, TheProgramsStartUpIsMeasuredAndAddedToTheWallTime) {
  const std::string file = Simulated("m.g2o", SimWorld::kManhattan, 100);
  const std::string cmd = std::string(TETHER_CLI) + " bench " + file +
                          " -q --repeat 3 --format csv --columns wall_median_s,startup_s,process_s > " + P("out.txt");
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream o(P("out.txt"));
  std::stringstream out;
  out << o.rdbuf();
  const auto rows = ParseCsv(out.str());
  ASSERT_EQ(rows.size(), 1u) << out.str();
  const double wall = std::stod(rows[0].at("wall_median_s"));
  const double startup = std::stod(rows[0].at("startup_s"));
  const double process = std::stod(rows[0].at("process_s"));
  EXPECT_GT(startup, 0);
  EXPECT_LT(startup, 5.0) << "a start-up of seconds means the measurement ran something else";
  EXPECT_NEAR(process, startup + wall, 1e-5 * process) << out.str();
  EXPECT_DOUBLE_EQ(ProgramStartupSeconds("/nonexistent/tether", 2), -1);
}

// Progress goes to stderr, one line per run with the file, the configuration and run k of N;
// the table goes to stdout, or to -o.
TEST_F(BenchTest, ProgressOnStderrTableOnStdoutOrFile) {
  const std::string file = Simulated("m.g2o", SimWorld::kManhattan, 100);
  const std::string cmd = std::string(TETHER_CLI) + " bench " + file + " --solvers gn,lm --repeat 2 --format csv > " +
                          P("out.txt") + " 2> " + P("err.txt");
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::ifstream o(P("out.txt")), e(P("err.txt"));
  std::stringstream out, err;
  out << o.rdbuf();
  err << e.rdbuf();
  EXPECT_EQ(ParseCsv(out.str()).size(), 2u) << out.str();
  EXPECT_EQ(out.str().find("run 1 of 2"), std::string::npos);
  for (const char* line : {"[1/2] ", "[2/2] "}) EXPECT_EQ(Count(err.str(), line), 2u) << err.str();
  EXPECT_NE(err.str().find(file + " gn/auto/chordal: run 1 of 2"), std::string::npos) << err.str();
  EXPECT_NE(err.str().find(file + " lm/auto/chordal: run 2 of 2"), std::string::npos) << err.str();
  EXPECT_EQ(err.str().find("file,solver"), std::string::npos);

  BenchCommand bc;
  bc.files = {file};
  bc.repeat = 1;
  bc.output = P("table.md");
  ASSERT_EQ(Bench(bc), 0) << err_.str();
  EXPECT_TRUE(out_.str().empty()) << out_.str();
  std::ifstream t(P("table.md"));
  std::stringstream table;
  table << t.rdbuf();
  EXPECT_NE(table.str().find("| m.g2o | lm | auto | chordal |"), std::string::npos) << table.str();
}

TEST_F(BenchTest, BadUsageExitsTwoAndRunsNothing) {
  const std::string file = Simulated("m.g2o", SimWorld::kManhattan, 50);
  struct Case {
    const char* what;
    BenchCommand cmd;
    const char* message;
  };
  std::vector<Case> cases;
  const auto with = [&](const char* what, auto change, const char* message) {
    BenchCommand c;
    c.files = {file};
    change(c);
    cases.push_back({what, c, message});
  };
  with(
      "no files", [](BenchCommand& c) { c.files.clear(); }, "no FILES given");
  with(
      "missing file", [&](BenchCommand& c) { c.files.push_back(P("nope.g2o")); }, "no such file: ");
  with(
      "directory", [&](BenchCommand& c) { c.files.push_back(dir_.string()); }, "is a directory");
  with(
      "solver", [](BenchCommand& c) { c.solvers = "lm,newton"; }, "unknown solver 'newton'");
  with(
      "empty item", [](BenchCommand& c) { c.solvers = "lm,,gn"; }, "not a comma-separated list");
  with(
      "trailing comma", [](BenchCommand& c) { c.init = "file,"; }, "not a comma-separated list");
  with(
      "linear", [](BenchCommand& c) { c.linear = "magic"; }, "unknown linear solver 'magic'");
  with(
      "init", [](BenchCommand& c) { c.init = "lago"; }, "unknown initialisation 'lago'");
  with(
      "repeat", [](BenchCommand& c) { c.repeat = 0; }, "--repeat must be at least 1");
  with(
      "format", [](BenchCommand& c) { c.format = "json"; }, "unknown --format 'json'");
  with(
      "output folder", [&](BenchCommand& c) { c.output = P("no/such/table.md"); }, "cannot write");
  with(
      "ceres only with qr",
      [](BenchCommand& c) {
        c.solvers = "ceres";
        c.linear = "qr";
      },
      "no configuration left");
  with(
      "threads", [](BenchCommand& c) { c.threads = "1,0"; }, "bad thread count '0' in --threads");
  with(
      "threads text", [](BenchCommand& c) { c.threads = "two"; }, "bad thread count 'two' in --threads");
  with(
      "too many threads", [](BenchCommand& c) { c.threads = "100000"; }, "num_threads must be between");
  for (const Case& c : cases) {
    EXPECT_EQ(Bench(c.cmd), 2) << c.what;
    EXPECT_NE(err_.str().find(c.message), std::string::npos) << c.what << ": " << err_.str();
    EXPECT_EQ(err_.str().find("run 1 of"), std::string::npos) << c.what;
    EXPECT_TRUE(out_.str().empty()) << c.what;
  }
  // The program itself: usage errors exit 2, including CLI11's own.
  for (const std::string& args :
       std::vector<std::string>{"bench", "bench " + file + " --solvers newton", "bench " + file + " --repeat x",
                                "bench " + file + " " + P("nope.g2o")}) {
    const int status = std::system((std::string(TETHER_CLI) + " " + args + " > /dev/null 2>&1").c_str());
    ASSERT_TRUE(WIFEXITED(status)) << args;
    EXPECT_EQ(WEXITSTATUS(status), 2) << args;
  }
}

// A file that cannot be read is reported in its rows; the other files still run; exit 1.
TEST_F(BenchTest, UnreadableFileIsReportedAndTheOthersRun) {
  const std::string good = Simulated("m.g2o", SimWorld::kManhattan, 100);
  {
    std::ofstream f(P("bad.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 nan 1 0 0 1 0 1\n";
  }
  BenchCommand cmd;
  cmd.files = {P("bad.g2o"), good};
  cmd.solvers = "gn,lm";
  cmd.repeat = 2;
  cmd.format = "csv";
  EXPECT_EQ(Bench(cmd), 1);
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 4u) << out_.str();
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(rows[i].at("file"), P("bad.g2o"));
    EXPECT_EQ(rows[i].at("status"), "bad-input");
    EXPECT_EQ(rows[i].at("poses"), "");
    EXPECT_EQ(rows[i].at("final_chi2"), "");
    EXPECT_NE(rows[i].at("message").find("bad.g2o:3"), std::string::npos) << rows[i].at("message");
  }
  for (int i = 2; i < 4; ++i) {
    EXPECT_EQ(rows[i].at("file"), good);
    EXPECT_EQ(rows[i].at("status"), "converged");
    EXPECT_EQ(rows[i].at("poses"), "100");
  }
  EXPECT_NE(err_.str().find("error: " + P("bad.g2o") + " gn/auto/chordal: bad-input: "), std::string::npos)
      << err_.str();
}

// The children of this process (any thread's).
std::vector<pid_t> Children() {
  std::vector<pid_t> pids;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream in(task.path() / "children");
    pid_t p;
    while (in >> p) pids.push_back(p);
  }
  return pids;
}

// A run whose process dies is reported as crashed, with the signal, and the bench goes on.
// The first file is a FIFO nobody writes to: its child blocks until the test kills it.
TEST_F(BenchTest, CrashedRunIsReportedAndTheOthersRun) {
  const std::string good = Simulated("m.g2o", SimWorld::kManhattan, 100);
  ASSERT_EQ(::mkfifo(P("hang.g2o").c_str(), 0600), 0);
  BenchCommand cmd;
  cmd.files = {P("hang.g2o"), good};
  cmd.repeat = 1;
  cmd.format = "csv";
  int code = -1;
  std::thread bench([&] { code = Bench(cmd); });
  bool killed = false;
  for (int i = 0; i < 500 && !killed; ++i) {
    const std::vector<pid_t> children = Children();
    if (!children.empty()) killed = ::kill(children.front(), SIGKILL) == 0;
    if (!killed) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  bench.join();
  ASSERT_TRUE(killed);
  EXPECT_EQ(code, 3);
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 2u) << out_.str();
  EXPECT_EQ(rows[0].at("status"), "crashed");
  EXPECT_NE(rows[0].at("message").find("killed by signal 9"), std::string::npos) << rows[0].at("message");
  EXPECT_EQ(rows[1].at("status"), "converged");
}

// Each run's peak memory is its own: a small graph benched after a large one in the same
// bench shows the small graph's peak, not the large one's.
TEST_F(BenchTest, PeakMemoryIsPerRun) {
  BenchConfig config;
  config.init = InitMethod::kFile;
  const BenchRun large = RunBenchInChild(Simulated("large.g2o", SimWorld::kManhattan, 6000), config);
  const BenchRun small = RunBenchInChild(Simulated("small.g2o", SimWorld::kManhattan, 50), config);
  ASSERT_EQ(large.outcome, BenchOutcome::kSolved) << large.message;
  ASSERT_EQ(small.outcome, BenchOutcome::kSolved) << small.message;
  EXPECT_GT(small.peak_rss_mib, 0);
  EXPECT_GT(large.peak_rss_mib, small.peak_rss_mib + 5) << large.peak_rss_mib << " " << small.peak_rss_mib;
}

// tether bench --replay: one row per file with the online figures, agreeing with the replay.
TEST_F(BenchTest, ReplayModeTabulatesEachFile) {
  BenchCommand cmd;
  cmd.replay = true;
  cmd.files = {Simulated("m.g2o", SimWorld::kManhattan, 120), Simulated("s.g2o", SimWorld::kSphere, 60)};
  cmd.repeat = 2;
  cmd.format = "csv";
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 2u) << out_.str();
  const long poses[] = {120, 60};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    SCOPED_TRACE(row.at("file"));
    EXPECT_EQ(row.at("file"), cmd.files[i]);
    EXPECT_EQ(row.at("status"), "done") << row.at("message");
    EXPECT_EQ(std::stol(row.at("poses")), poses[i]);
    EXPECT_EQ(std::stol(row.at("updates")), poses[i]);
    EXPECT_EQ(row.at("runs"), "2");
    EXPECT_GT(std::stod(row.at("total_median_s")), 0);
    const double mean = std::stod(row.at("step_mean_ms")), p99 = std::stod(row.at("step_p99_ms")),
                 max = std::stod(row.at("step_max_ms"));
    EXPECT_GT(mean, 0);
    EXPECT_LE(mean, max);
    EXPECT_LE(p99, max);
    const double final_chi2 = std::stod(row.at("final_chi2")), batch = std::stod(row.at("batch_chi2"));
    EXPECT_NEAR(final_chi2, batch, 1e-6 * batch);
    EXPECT_LT(std::abs(std::stod(row.at("relative_gap"))), 1e-6);
    EXPECT_GT(std::stod(row.at("peak_rss_mib")), 0);
  }
  // Progress: one line per run.
  EXPECT_EQ(Count(err_.str(), " replay: run "), 4u) << err_.str();

  // The same replay through the library gives the same figures (the runs are deterministic).
  const ReplayResult direct = ReplayFile(cmd.files[0], ReplayOptions());
  ASSERT_EQ(direct.status, ReplayStatus::kDone);
  EXPECT_NEAR(std::stod(rows[0].at("final_chi2")), direct.final_chi2, 1e-9 * direct.final_chi2);

  cmd.format = "md";
  cmd.repeat = 1;
  cmd.output = P("table.md");
  ASSERT_EQ(Bench(cmd), 0) << err_.str();
  std::ifstream in(cmd.output);
  const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| file | poses | updates | status | total [s] | step mean [ms] | step p99 [ms] | step max [ms] "
                    "| final chi2 | batch optimum | relative gap | peak memory [MiB] |"),
            std::string::npos)
      << md;
  EXPECT_EQ(Count(md, "| m.g2o | 120 | 120 | done |"), 1u) << md;
  EXPECT_EQ(Count(md, "| s.g2o | 60 | 60 | done |"), 1u) << md;
}

TEST_F(BenchTest, ReplayModeBadUsageAndUnreadableFile) {
  const std::string good = Simulated("m.g2o", SimWorld::kManhattan, 30);
  BenchCommand cmd;
  cmd.replay = true;
  cmd.files = {good};
  cmd.solvers = "gn";
  EXPECT_EQ(Bench(cmd), 2);
  EXPECT_NE(err_.str().find("do not apply to replays"), std::string::npos) << err_.str();
  cmd.solvers = BenchCommand().solvers;
  cmd.repeat = 0;
  EXPECT_EQ(Bench(cmd), 2);
  cmd.repeat = 1;
  cmd.files = {P("missing.g2o")};
  EXPECT_EQ(Bench(cmd), 2);
  EXPECT_EQ(out_.str(), "");

  {
    std::ofstream bad(P("bad.g2o"));
    bad << "EDGE_SE2 0 1 nonsense\n";
  }
  cmd.files = {P("bad.g2o"), good};
  cmd.format = "csv";
  EXPECT_EQ(Bench(cmd), 1) << err_.str();
  const auto rows = ParseCsv(out_.str());
  ASSERT_EQ(rows.size(), 2u) << out_.str();
  EXPECT_EQ(rows[0].at("status"), "bad-input");
  EXPECT_FALSE(rows[0].at("message").empty());
  EXPECT_EQ(rows[1].at("status"), "done");
}

TEST_F(BenchTest, ReplayModeFromTheCommandLine) {
  const std::string file = Simulated("m.g2o", SimWorld::kManhattan, 40);
  const testing::CliRun run = testing::Tether("bench --replay " + file + " --repeat 1 --format csv");
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("file,poses,updates,status,total_median_s,step_mean_ms,step_p99_ms,step_max_ms,"
                            "final_chi2,batch_chi2,relative_gap,peak_rss_mib,runs,message"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find(file + ",40,40,done,"), std::string::npos) << run.output;
}

TEST(ReplayBenchSummary, MediansAndWorstOutcome) {
  ReplayBenchRow row;
  for (double t : {0.4, 0.1, 0.3}) {
    ReplayBenchRun r;
    r.outcome = BenchOutcome::kSolved;
    r.status = "done";
    r.total_seconds = t;
    r.mean_ms = 10 * t;
    r.p99_ms = 20 * t;
    r.max_ms = 30 * t;
    r.peak_rss_mib = 100 * t;
    row.runs.push_back(r);
  }
  SummarizeReplayBenchRow(&row);
  EXPECT_EQ(row.outcome, BenchOutcome::kSolved);
  EXPECT_DOUBLE_EQ(row.median_seconds, 0.3);
  EXPECT_DOUBLE_EQ(row.mean_ms, 3);
  EXPECT_DOUBLE_EQ(row.p99_ms, 6);
  EXPECT_DOUBLE_EQ(row.max_ms, 9);
  EXPECT_DOUBLE_EQ(row.peak_rss_mib, 40);
  ReplayBenchRun crashed;
  crashed.outcome = BenchOutcome::kCrashed;
  crashed.status = "crashed";
  crashed.message = "killed";
  row.runs.push_back(crashed);
  SummarizeReplayBenchRow(&row);
  EXPECT_EQ(row.outcome, BenchOutcome::kCrashed);
  EXPECT_EQ(row.message, "killed");
  EXPECT_DOUBLE_EQ(row.median_seconds, 0.3);  // the medians are of the runs that finished
}

TEST(BenchSummary, MedianMinMaxAndWorstOutcome) {
  BenchRow row;
  for (double t : {0.4, 0.1, 0.3, 0.2}) {
    BenchRun r;
    r.outcome = BenchOutcome::kSolved;
    r.status = "converged";
    r.total_seconds = t;
    r.peak_rss_mib = 10 * t;
    row.runs.push_back(r);
  }
  SummarizeBenchRow(&row);
  EXPECT_EQ(row.outcome, BenchOutcome::kSolved);
  EXPECT_EQ(row.status, "converged");
  EXPECT_DOUBLE_EQ(row.median_seconds, 0.25);
  EXPECT_DOUBLE_EQ(row.min_seconds, 0.1);
  EXPECT_DOUBLE_EQ(row.max_seconds, 0.4);
  EXPECT_DOUBLE_EQ(row.peak_rss_mib, 4.0);
  row.runs[2].outcome = BenchOutcome::kSolveFailed;
  row.runs[2].status = "diverged";
  row.runs[3].outcome = BenchOutcome::kCrashed;
  row.runs[3].status = "crashed";
  row.runs[3].message = "killed";
  SummarizeBenchRow(&row);
  EXPECT_EQ(row.outcome, BenchOutcome::kCrashed);
  EXPECT_EQ(row.status, "crashed");
  EXPECT_EQ(row.message, "killed");
}

TEST(BenchBlas, NamesALoadedLibrary) {
  const std::string blas = ActiveBlasLibrary();
  ASSERT_NE(blas, "none");
  EXPECT_TRUE(fs::exists(blas)) << blas;
  std::ifstream maps("/proc/self/maps");
  std::stringstream s;
  s << maps.rdbuf();
  EXPECT_NE(s.str().find(blas), std::string::npos) << blas;
}

TEST(BenchConfigName, ListsTheChoices) {
  BenchConfig c;
  EXPECT_EQ(c.Name(), "lm/auto/chordal");
  c.algorithm = Algorithm::kGaussNewton;
  c.linear = LinearSolverType::kQR;
  c.init = InitMethod::kSpanningTree;
  c.threads = 2;
  EXPECT_EQ(c.Name(), "gn/qr/spanning-tree/2t");
}

}  // namespace
}  // namespace tether
