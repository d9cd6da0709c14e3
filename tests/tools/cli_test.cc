// The tether program end to end: exit codes, the iteration table and summary, files written
// only on success, simulate's determinism.
#include "testing/cli.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

namespace fs = std::filesystem;

using tether::testing::CliRun;
using tether::testing::Tether;

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(CliTest, SimulateThenOptimizeWritesGraphAndPlot) {
  CliRun sim = Tether("simulate manhattan --poses 400 --seed 5 -o " + P("m.g2o") + " --ground-truth " + P("gt.g2o"));
  ASSERT_EQ(sim.code, 0) << sim.output;
  ASSERT_TRUE(fs::exists(P("m.g2o")));
  ASSERT_TRUE(fs::exists(P("gt.g2o")));
  CliRun opt = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --plot " + P("out.svg"));
  ASSERT_EQ(opt.code, 0) << opt.output;
  // The live table's header and rows, then the summary.
  EXPECT_NE(opt.output.find("iter              chi2    rel.decr     lambda   step norm   time [s]"), std::string::npos);
  EXPECT_NE(opt.output.find("    0  "), std::string::npos);
  EXPECT_NE(opt.output.find("initial chi2"), std::string::npos);
  EXPECT_NE(opt.output.find("final chi2"), std::string::npos);
  EXPECT_NE(opt.output.find("status             converged"), std::string::npos);
  EXPECT_NE(opt.output.find("held 0 fixed"), std::string::npos);
  const std::string svg = ReadAll(P("out.svg"));
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  // The optimised file re-reads and is already at the optimum: another run from the file's
  // values stops at once.
  CliRun again = Tether("optimize " + P("out.g2o") + " -q --init file");
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("iterations         1 "), std::string::npos) << again.output;
}

// The summary ends with the whole process's time split into its phases: the start-up before
// main (the libraries loaded), read, initialise, optimise, write and the rest. The parts add up
// to the total, each is a time (not negative), and the total is no more than the wall time
// measured outside the program.
TEST_F(CliTest, TheSummarySaysWhereTheWholeProcessTimeWent) {
  ASSERT_EQ(Tether("simulate manhattan --poses 300 --seed 3 -q -o " + P("m.g2o")).code, 0);
  const auto t0 = std::chrono::steady_clock::now();
  CliRun run = Tether("optimize " + P("m.g2o") + " -q -o " + P("r.g2o"));
  const double outside = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(run.code, 0) << run.output;
  const std::size_t at = run.output.find("whole process ");
  ASSERT_NE(at, std::string::npos) << run.output;
  double total = -1, startup = -1, read = -1, init = -1, opt = -1, write = -1, other = -1;
  ASSERT_EQ(std::sscanf(run.output.c_str() + at,
                        "whole process %lf s: start-up %lf, read %lf, initialise %lf, optimise %lf, write %lf, "
                        "other %lf",
                        &total, &startup, &read, &init, &opt, &write, &other),
            7)
      << run.output.substr(at);
  for (double part : {startup, read, init, opt, write, other}) EXPECT_GE(part, 0) << run.output.substr(at);
  EXPECT_GT(startup, 0) << "loading the shared libraries takes time";
  EXPECT_GT(total, 0);
  // Each figure is rounded to 1 ms: seven of them differ from their sum by at most 3.5 ms.
  EXPECT_NEAR(startup + read + init + opt + write + other, total, 0.0035) << run.output.substr(at);
  EXPECT_LE(total, outside + 0.001) << "the program cannot take longer than its run";
  // The optimise phase holds the solver's own total.
  double solver_total = -1;
  const std::size_t time_at = run.output.find("  time ");
  ASSERT_NE(time_at, std::string::npos);
  ASSERT_EQ(std::sscanf(run.output.c_str() + time_at, "  time %lf s", &solver_total), 1);
  EXPECT_LE(solver_total, opt + 0.0015);
}

// The program builds only the flags of the command it is asked for, and all of them where no
// command is named: the top-level help lists every command, --version answers, a misspelt
// command is a usage error (exit 2), and each command's own help and a bad flag of it behave
// as they did.
TEST_F(CliTest, TheTopLevelKnowsEveryCommandAndEachCommandItsFlags) {
  CliRun help = Tether("--help");
  EXPECT_EQ(help.code, 0) << help.output;
  for (const char* command : {"optimize", "simulate", "plugins", "check-plugin", "bench", "replay", "ekf-demo", "lidar",
                              "lidar-eval", "lidar-degrade", "localize", "mcl", "mcl-demo", "mcl-bench", "odometry"}) {
    EXPECT_NE(help.output.find(std::string("  ") + command + " "), std::string::npos) << command;
    CliRun own = Tether(std::string(command) + " --help");
    EXPECT_EQ(own.code, 0) << command << ": " << own.output;
    EXPECT_NE(own.output.find(std::string("tether ") + command), std::string::npos) << own.output;
  }
  CliRun version = Tether("--version");
  EXPECT_EQ(version.code, 0);
  EXPECT_EQ(version.output.rfind("tether ", 0), 0u) << version.output;
  CliRun typo = Tether("optimise " + P("m.g2o"));
  EXPECT_EQ(typo.code, 2) << typo.output;
  CliRun bad_flag = Tether("optimize " + P("m.g2o") + " --no-such-flag");
  EXPECT_EQ(bad_flag.code, 2) << bad_flag.output;
  EXPECT_NE(bad_flag.output.find("--no-such-flag"), std::string::npos) << bad_flag.output;
}

// --init: chordal by default (and said so), file and spanning-tree on request, all reaching
// the same optimum here; an unknown name is bad usage.
// -q is quiet in every command that reports progress or what it wrote: the help lists it, and
// simulate, lidar-degrade and lidar-eval print nothing but their results with it.
TEST_F(CliTest, QuietMeansQuietEverywhere) {
  for (const char* command : {"optimize", "simulate", "check-plugin", "bench", "replay", "ekf-demo", "lidar",
                              "lidar-eval", "lidar-degrade"}) {
    CliRun help = Tether(std::string(command) + " --help");
    EXPECT_NE(help.output.find("-q,--quiet"), std::string::npos) << command << ":\n" << help.output;
  }
  CliRun sim = Tether("simulate manhattan --poses 50 -q -o " + P("q.g2o"));
  EXPECT_EQ(sim.code, 0) << sim.output;
  EXPECT_EQ(sim.output, "");
  EXPECT_TRUE(fs::exists(P("q.g2o")));
  CliRun loud = Tether("simulate manhattan --poses 50 -o " + P("l.g2o"));
  EXPECT_NE(loud.output.find("wrote "), std::string::npos) << loud.output;
  CliRun log = Tether("simulate lidar --scans 40 -q -o " + P("q.log") + " --truth " + P("q.tum"));
  EXPECT_EQ(log.code, 0) << log.output;
  EXPECT_EQ(log.output, "");
  CliRun degrade = Tether("lidar-degrade " + P("q.log") + " --preset lds -q -o " + P("d.log"));
  EXPECT_EQ(degrade.code, 0) << degrade.output;
  EXPECT_EQ(degrade.output, "");
  // Errors are never quiet.
  CliRun bad = Tether("simulate city -q -o " + P("c.g2o"));
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("unknown world 'city'"), std::string::npos) << bad.output;
}

TEST_F(CliTest, InitChoosesTheInitialGuess) {
  ASSERT_EQ(Tether("simulate sphere --poses 300 --seed 4 -o " + P("s.g2o")).code, 0);
  CliRun byDefault = Tether("optimize " + P("s.g2o") + " -q -o " + P("d.g2o"));
  ASSERT_EQ(byDefault.code, 0) << byDefault.output;
  EXPECT_NE(byDefault.output.find("initialisation 'chordal': 299 poses"), std::string::npos) << byDefault.output;
  CliRun file = Tether("optimize " + P("s.g2o") + " -q --init file -o " + P("f.g2o"));
  ASSERT_EQ(file.code, 0) << file.output;
  EXPECT_EQ(file.output.find("initialisation"), std::string::npos) << file.output;
  CliRun tree = Tether("optimize " + P("s.g2o") + " -q --init spanning-tree -o " + P("t.g2o"));
  ASSERT_EQ(tree.code, 0) << tree.output;
  EXPECT_NE(tree.output.find("initialisation 'spanning-tree'"), std::string::npos) << tree.output;
  const auto final_chi2 = [](const std::string& out) {
    const std::size_t at = out.find("final chi2");
    return at == std::string::npos ? -1.0 : std::stod(out.substr(at + 10));
  };
  const double reference = final_chi2(file.output);
  ASSERT_GT(reference, 0);
  EXPECT_NEAR(final_chi2(byDefault.output), reference, 1e-6 * reference);
  EXPECT_NEAR(final_chi2(tree.output), reference, 1e-6 * reference);
  CliRun bad = Tether("optimize " + P("s.g2o") + " --init lago");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("--init: lago not in {file,spanning-tree,chordal}"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(P("lago.g2o")));
}

// The table marks the steps solved with an earlier factorisation, the summary counts the
// factorisations, and --max-reuse-iterations 0 factorises every step.
TEST_F(CliTest, ReusedFactorisationsAreShownAndCanBeSwitchedOff) {
  ASSERT_EQ(Tether("simulate sphere --poses 300 --seed 4 -o " + P("s.g2o")).code, 0);
  CliRun reuse = Tether("optimize " + P("s.g2o") + " -o " + P("a.g2o"));
  ASSERT_EQ(reuse.code, 0) << reuse.output;
  EXPECT_NE(reuse.output.find("reused factorisation ("), std::string::npos) << reuse.output;
  CliRun every = Tether("optimize " + P("s.g2o") + " --max-reuse-iterations 0 -o " + P("b.g2o"));
  ASSERT_EQ(every.code, 0) << every.output;
  EXPECT_EQ(every.output.find("reused factorisation"), std::string::npos) << every.output;
  const auto counts = [](const std::string& out, int* iterations, int* factorisations) {
    const std::size_t at = out.find("  iterations  ");
    ASSERT_NE(at, std::string::npos) << out;
    int accepted = 0;
    ASSERT_EQ(std::sscanf(out.c_str() + at, " iterations %d (%d accepted, %d factorisations)", iterations, &accepted,
                          factorisations),
              3)
        << out.substr(at, 80);
  };
  int it_reuse = 0, f_reuse = 0, it_every = 0, f_every = 0;
  counts(reuse.output, &it_reuse, &f_reuse);
  counts(every.output, &it_every, &f_every);
  EXPECT_LT(f_reuse, it_reuse);
  EXPECT_EQ(f_every, it_every);
  CliRun bad = Tether("optimize " + P("s.g2o") + " --max-reuse-iterations -1 -o " + P("c.g2o"));
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--max-reuse-iterations: '-1' is outside its range"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(P("c.g2o")));
}

TEST_F(CliTest, SimulateIsDeterministic) {
  ASSERT_EQ(Tether("simulate sphere --poses 200 --seed 9 -o " + P("a.g2o")).code, 0);
  ASSERT_EQ(Tether("simulate sphere --poses 200 --seed 9 -o " + P("b.g2o")).code, 0);
  ASSERT_EQ(Tether("simulate sphere --poses 200 --seed 10 -o " + P("c.g2o")).code, 0);
  EXPECT_EQ(ReadAll(P("a.g2o")), ReadAll(P("b.g2o")));
  EXPECT_NE(ReadAll(P("a.g2o")), ReadAll(P("c.g2o")));
  ASSERT_EQ(Tether("simulate landmarks --poses 100 --seed 1 -o " + P("l.g2o")).code, 0);
  const std::string l = ReadAll(P("l.g2o"));
  EXPECT_NE(l.find("VERTEX_XY"), std::string::npos);
  EXPECT_NE(l.find("EDGE_SE2_XY"), std::string::npos);
}

TEST_F(CliTest, BadInputNamesFileAndLineAndWritesNothing) {
  {
    std::ofstream f(P("bad.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 nan 1 0 0 1 0 1\n";
  }
  CliRun r = Tether("optimize " + P("bad.g2o") + " -o " + P("out.g2o") + " --plot " + P("out.svg"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find(P("bad.g2o") + ":3"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(P("out.g2o")));
  EXPECT_FALSE(fs::exists(P("out.svg")));
  CliRun missing = Tether("optimize " + P("nope.g2o") + " -o " + P("out.g2o"));
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.output.find("nope.g2o"), std::string::npos) << missing.output;
  EXPECT_FALSE(fs::exists(P("out.g2o")));
}

TEST_F(CliTest, UsageErrorsExitTwo) {
  ASSERT_EQ(Tether("simulate manhattan --poses 50 -o " + P("m.g2o")).code, 0);
  CliRun r = Tether("optimize " + P("m.g2o") + " --solver newton");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("newton"), std::string::npos);
  EXPECT_EQ(Tether("optimize " + P("m.g2o") + " --linear magic").code, 2);
  EXPECT_EQ(Tether("simulate moon -o " + P("x.g2o")).code, 2);
  EXPECT_EQ(Tether("frobnicate").code, 2);
}

TEST_F(CliTest, EveryLinearSolverAndAlgorithmRuns) {
  ASSERT_EQ(Tether("simulate landmarks --poses 150 --seed 2 -o " + P("l.g2o")).code, 0);
  std::string reference;
  for (const char* lin : {"cholmod", "ldlt", "qr"}) {
    for (const char* alg : {"gn", "lm", "dogleg"}) {
      CliRun r = Tether("optimize " + P("l.g2o") + " -q --solver " + alg + " --linear " + lin);
      ASSERT_EQ(r.code, 0) << lin << " " << alg << "\n" << r.output;
      EXPECT_NE(r.output.find(std::string(alg) + " / " + lin), std::string::npos);
      EXPECT_EQ(r.output.find("iter     "), std::string::npos);  // -q: no table
    }
  }
}

// A linear solver from a plugin: --linear pcg is known once --plugin pcg.so is loaded.
TEST_F(CliTest, LinearSolverFromAPlugin) {
  ASSERT_EQ(Tether("simulate manhattan --poses 100 --seed 4 -o " + P("m.g2o")).code, 0);
  CliRun without = Tether("optimize " + P("m.g2o") + " -q --linear pcg");
  EXPECT_EQ(without.code, 2);
  EXPECT_NE(without.output.find("unknown --linear 'pcg'"), std::string::npos) << without.output;
  const std::string pcg = std::string(TETHER_PLUGIN_BUILD_DIR) + "/pcg.so";
  CliRun r = Tether("optimize " + P("m.g2o") + " -q --plugin " + pcg + " --linear pcg");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("(0 factor types, 1 linear solver)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("lm / pcg"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("status             converged"), std::string::npos) << r.output;
}

// --solver ceres: Ceres' Levenberg-Marquardt through the adapter, with the same table and
// summary; the file it writes holds the optimum the native LM reaches; only --linear cholmod.
TEST_F(CliTest, SolverCeresMatchesNativeLm) {
  ASSERT_EQ(Tether("simulate sphere --poses 200 --seed 6 -o " + P("s.g2o")).code, 0);
  CliRun ceres = Tether("optimize " + P("s.g2o") + " --solver ceres -o " + P("c.g2o"));
  ASSERT_EQ(ceres.code, 0) << ceres.output;
  EXPECT_NE(ceres.output.find("algorithm          ceres: Ceres Levenberg-Marquardt / SPARSE_NORMAL_CHOLESKY"),
            std::string::npos)
      << ceres.output;
  EXPECT_NE(ceres.output.find("iter              chi2"), std::string::npos);
  EXPECT_NE(ceres.output.find("\n    1  "), std::string::npos) << ceres.output;
  EXPECT_NE(ceres.output.find("status             converged"), std::string::npos) << ceres.output;
  ASSERT_TRUE(fs::exists(P("c.g2o")));
  CliRun lm = Tether("optimize " + P("s.g2o") + " -q --solver lm");
  ASSERT_EQ(lm.code, 0) << lm.output;
  const auto chi2 = [](const std::string& out, const std::string& what) {
    const std::size_t at = out.find(what);
    return at == std::string::npos ? -1.0 : std::stod(out.substr(at + what.size()));
  };
  const double c = chi2(ceres.output, "final chi2"), l = chi2(lm.output, "final chi2");
  ASSERT_GT(l, 0);
  EXPECT_NEAR(c, l, 2e-8 * l);  // each stops within function_tolerance (1e-8) of the optimum
  // The written file starts where Ceres ended.
  CliRun again = Tether("optimize " + P("c.g2o") + " -q --init file --solver lm");
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NEAR(chi2(again.output, "initial chi2"), c, 1e-8 * c);
  CliRun qr = Tether("optimize " + P("s.g2o") + " --solver ceres --linear qr -o " + P("q.g2o"));
  EXPECT_EQ(qr.code, 2);
  EXPECT_NE(qr.output.find("use the auto or cholmod linear solver"), std::string::npos) << qr.output;
  EXPECT_FALSE(fs::exists(P("q.g2o")));
}

}  // namespace

namespace tether {
namespace {

// The result's absolute trajectory error as `optimize --ground-truth` prints it ("result X m").
double ResultAte(const std::string& output) {
  const std::size_t at = output.find(", result ");
  return at == std::string::npos ? -1 : std::stod(output.substr(at + 9));
}

TEST_F(CliTest, RobustLoopClosuresKeepTheMapWhenSomeAreWrong) {
  CliRun sim = Tether("simulate manhattan --poses 200 --seed 3 -o " + P("m.g2o") + " --ground-truth " + P("gt.g2o"));
  ASSERT_EQ(sim.code, 0) << sim.output;
  {  // three wrong loop closures, as precise as the true ones
    std::ofstream add(P("m.g2o"), std::ios::app);
    add << "EDGE_SE2 20 150 4 3 1.5 100 0 0 100 0 400\n"
           "EDGE_SE2 60 180 -5 2 -2 100 0 0 100 0 400\n"
           "EDGE_SE2 5 120 3 -4 0.5 100 0 0 100 0 400\n";
  }
  const std::string common = "optimize " + P("m.g2o") + " -o " + P("out.g2o") + " -q --ground-truth " + P("gt.g2o");
  CliRun plain = Tether(common);
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_EQ(plain.output.find("robust"), std::string::npos) << plain.output;
  // Measured: 1.72 m without a loss; 0.083 (huber), 0.099 (cauchy) and 0.108 m (dcs) with one
  // on the loop closures; the graph without the wrong closures gives 0.092 m.
  EXPECT_GT(ResultAte(plain.output), 1.0) << plain.output;
  for (const char* rule : {"loop=huber:1", "loop=cauchy:1", "loop=dcs:1"}) {
    CliRun robust = Tether(common + " --robust " + rule);
    ASSERT_EQ(robust.code, 0) << robust.output;
    EXPECT_NE(robust.output.find("robust losses: 135 of 334 factors (135 loop closures"), std::string::npos)
        << robust.output;
    EXPECT_NE(robust.output.find("robust cost"), std::string::npos) << robust.output;
    const double ate = ResultAte(robust.output);
    EXPECT_GT(ate, 0) << robust.output;
    EXPECT_LT(ate, 0.15) << rule << ": " << robust.output;
  }
  // GNC rejects exactly the three wrong closures and writes them beside the output.
  CliRun gnc = Tether(common + " --gnc");
  ASSERT_EQ(gnc.code, 0) << gnc.output;
  EXPECT_NE(gnc.output.find("gnc (gm, from chunked): "), std::string::npos) << gnc.output;
  EXPECT_NE(gnc.output.find("3 of 135 loop closures rejected"), std::string::npos) << gnc.output;
  EXPECT_LT(ResultAte(gnc.output), 0.1) << gnc.output;  // measured 0.092 m, as without them
  const std::string rejected = ReadAll(P("out.g2o.rejected.g2o"));
  for (const char* line : {"EDGE_SE2 20 150 4 3 1.5 ", "EDGE_SE2 60 180 -5 2 -2 ", "EDGE_SE2 5 120 3 -4 0.5 "}) {
    EXPECT_NE(rejected.find(line), std::string::npos) << line << " not in\n" << rejected;
  }
  EXPECT_EQ(Tether(common + " --gnc --gnc-kernel nope").code, 2);
  EXPECT_EQ(Tether(common + " --gnc --gnc-start nope").code, 2);
  CliRun classic = Tether(common + " --gnc --gnc-start least-squares");
  ASSERT_EQ(classic.code, 0) << classic.output;
  EXPECT_NE(classic.output.find("gnc (gm, from least-squares): "), std::string::npos) << classic.output;
  EXPECT_NE(classic.output.find("3 of 135 loop closures rejected"), std::string::npos) << classic.output;
  const CliRun no_rejects = Tether(common + " --rejected-out " + P("r.g2o"));
  EXPECT_EQ(no_rejects.code, 2);
  EXPECT_NE(no_rejects.output.find("rejected_output (--rejected-out) needs gnc (--gnc) or switchable (--switchable)"),
            std::string::npos)
      << no_rejects.output;
  // Switchable constraints switch off the same three and write them where asked.
  CliRun sc = Tether(common + " --switchable --rejected-out " + P("sc.g2o"));
  ASSERT_EQ(sc.code, 0) << sc.output;
  EXPECT_NE(sc.output.find("switchable constraints: 3 of 135 loop closures rejected"), std::string::npos) << sc.output;
  EXPECT_LT(ResultAte(sc.output), 0.1) << sc.output;  // the same inlier set as GNC's: 0.092 m
  const std::string switched = ReadAll(P("sc.g2o"));
  for (const char* line : {"EDGE_SE2 20 150 4 3 1.5 ", "EDGE_SE2 60 180 -5 2 -2 ", "EDGE_SE2 5 120 3 -4 0.5 "}) {
    EXPECT_NE(switched.find(line), std::string::npos) << line << " not in\n" << switched;
  }
  EXPECT_EQ(Tether(common + " --switchable --gnc").code, 2);
  EXPECT_EQ(Tether(common + " --switchable --switch-prior-sigma -1").code, 2);
  EXPECT_EQ(Tether(common + " --switch-prior-sigma 1").code, 2);
  // A rule that cannot be used: exit 2 and what is wrong, before anything is read or written.
  CliRun bad = Tether(common + " --robust loop=welsch:1");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("unknown kernel 'welsch'"), std::string::npos) << bad.output;
  CliRun tag = Tether(common + " --robust EDGE_NOPE=huber:1");
  EXPECT_EQ(tag.code, 2);
  EXPECT_NE(tag.output.find("'EDGE_NOPE'"), std::string::npos) << tag.output;
}

TEST_F(CliTest, VertigoSwitchableFilesAreSolvedAndWrittenBack) {
  {  // three poses in a line and a fourth; a switchable closure that agrees, one that does not
    std::ofstream f(P("v.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0.1 0.05\nVERTEX_SE2 3 2.9 0.1 0.05\n"
         "VERTEX_SWITCH 10 1\nVERTEX_SWITCH 11 1\n"
         "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 0 100 0 0 100 0 400\n"
         "EDGE_SE2 2 3 1 0 0 100 0 0 100 0 400\n"
         "EDGE_SE2_SWITCHABLE 0 2 10 2 0 0 100 0 0 100 0 400\n"
         "EDGE_SE2_SWITCHABLE 0 3 11 1 5 2 100 0 0 100 0 400\n"
         "EDGE_SWITCH_PRIOR 10 1 1\nEDGE_SWITCH_PRIOR 11 1 1\n";
  }
  CliRun run = Tether("optimize " + P("v.g2o") + " -o " + P("vo.g2o") + " -q");
  ASSERT_EQ(run.code, 0) << run.output;
  std::istringstream out(ReadAll(P("vo.g2o")));
  std::string line;
  double s10 = -1, s11 = -1;
  int switchable = 0;
  while (std::getline(out, line)) {
    if (line.rfind("VERTEX_SWITCH 10 ", 0) == 0) s10 = std::stod(line.substr(17));
    if (line.rfind("VERTEX_SWITCH 11 ", 0) == 0) s11 = std::stod(line.substr(17));
    switchable += line.rfind("EDGE_SE2_SWITCHABLE ", 0) == 0;
  }
  EXPECT_EQ(switchable, 2);
  EXPECT_GT(s10, 0.99);  // the closure that agrees stays on (measured 1 - 3e-11)
  EXPECT_LT(s11, 0.01);  // the one 5 m off is switched off (measured 2e-4)
}

}  // namespace
}  // namespace tether

// The solver back-ends (CHOLMOD, SuiteSparseQR and Ceres, with the BLAS and LAPACK they run on)
// live in libtether_backends.so, loaded at their first use: a graph the block Cholesky solves
// never loads them (nor their libraries), a solve with cholmod does, to the same optimum.
TEST_F(CliTest, TheSolverBackEndsAreLoadedOnlyWhenUsed) {
  ASSERT_EQ(Tether("simulate manhattan --poses 300 --seed 3 -q -o " + P("m.g2o")).code, 0);
  const CliRun block = Tether("optimize " + P("m.g2o") + " -q -o " + P("b.g2o"), "LD_DEBUG=files");
  ASSERT_EQ(block.code, 0) << block.output;
  ASSERT_NE(block.output.find("libtether_solvers.so"), std::string::npos) << "LD_DEBUG=files lists no library";
  EXPECT_NE(block.output.find("block Cholesky"), std::string::npos) << block.output;
  EXPECT_EQ(block.output.find("libtether_backends.so"), std::string::npos);
  EXPECT_EQ(block.output.find("libcholmod"), std::string::npos);
  EXPECT_EQ(block.output.find("libopenblas"), std::string::npos);
  EXPECT_EQ(block.output.find("libceres"), std::string::npos);
  const CliRun cholmod = Tether("optimize " + P("m.g2o") + " -q --linear cholmod -o " + P("c.g2o"), "LD_DEBUG=files");
  ASSERT_EQ(cholmod.code, 0) << cholmod.output;
  EXPECT_NE(cholmod.output.find("libtether_backends.so"), std::string::npos);
  EXPECT_NE(cholmod.output.find("libcholmod"), std::string::npos);
  const auto chi2 = [](const std::string& out) {
    const std::size_t at = out.find("final chi2");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  EXPECT_FALSE(chi2(block.output).empty());
  EXPECT_EQ(chi2(block.output), chi2(cholmod.output));
}

// Where the module is missing (libtether_solvers.so copied alone into a folder), a solver that
// needs it is refused with the file it looked for and what to do; the native solvers still run.
TEST_F(CliTest, AMissingBackEndModuleIsAClearError) {
  const fs::path lib = fs::path(TETHER_CLI).parent_path().parent_path() / "solvers" / "libtether_solvers.so";
  if (!fs::exists(lib)) GTEST_SKIP() << lib << " absent (not a build tree)";
  const fs::path lone = P("lone");
  fs::create_directories(lone);
  fs::copy_file(lib, lone / lib.filename());
  ASSERT_EQ(Tether("simulate manhattan --poses 100 --seed 3 -q -o " + P("m.g2o")).code, 0);
  const std::string env = "LD_LIBRARY_PATH=" + lone.string();
  const CliRun cholmod = Tether("optimize " + P("m.g2o") + " -q --linear cholmod -o " + P("c.g2o"), env);
  EXPECT_EQ(cholmod.code, 3) << cholmod.output;  // the solve failed
  EXPECT_NE(cholmod.output.find("the solver back-ends (CHOLMOD, SuiteSparseQR, Ceres) could not be loaded: " +
                                (lone / "libtether_backends.so").string()),
            std::string::npos)
      << cholmod.output;
  EXPECT_NE(cholmod.output.find("reinstall tether"), std::string::npos) << cholmod.output;
  EXPECT_FALSE(fs::exists(P("c.g2o")));
  const CliRun ceres = Tether("optimize " + P("m.g2o") + " -q --solver ceres -o " + P("e.g2o"), env);
  EXPECT_EQ(ceres.code, 3) << ceres.output;
  EXPECT_NE(ceres.output.find("could not be loaded"), std::string::npos) << ceres.output;
  const CliRun block = Tether("optimize " + P("m.g2o") + " -q -o " + P("b.g2o"), env);
  EXPECT_EQ(block.code, 0) << block.output;
  EXPECT_TRUE(fs::exists(P("b.g2o")));
}
