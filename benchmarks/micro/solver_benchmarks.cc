// The solver's per-iteration steps on real-sized graphs: assembling H and g (1 and 2
// threads), linearising, and one CHOLMOD numeric factorisation of H. H is built through
// tether::NormalEquations, the solvers' own assembly behind a public header.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "tether/core/graph_io.h"
#include "tether/core/linear_solver.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/normal_equations.h"

namespace tether {
namespace {

// A graph and its values, built once per process and shared by the benchmarks.
struct Graph {
  FactorGraph graph;
  Values values;
};

const Graph* Manhattan10k() {
  static const Graph* g = [] {
    SimulateOptions o;
    o.poses = 10000;
    o.seed = 1;
    SimulatedGraph sim = Simulate(o);
    return new Graph{std::move(sim.graph), std::move(sim.initial)};
  }();
  return g;
}

// Null (and the benchmark skipped) where ../shared/datasets is absent.
const Graph* Dataset(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Graph>> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    std::unique_ptr<Graph> g;
    const std::string path = std::string(TETHER_DATASETS_G2O) + "/" + name + ".g2o";
    if (std::filesystem::exists(path)) {
      GraphFile f = ReadGraphFile(path, DefaultRegistry());
      g = std::make_unique<Graph>(Graph{std::move(f.graph), std::move(f.values)});
    }
    it = cache.emplace(name, std::move(g)).first;
  }
  return it->second.get();
}

// The solver's set-up for one graph: the first key held (gauge), the H pattern built,
// linearised once.
struct Setup {
  explicit Setup(const Graph& g, int threads) : system(g.graph, g.values, {g.values.keys().front()}, threads) {
    system.Linearize();
  }
  NormalEquations system;
};

void AssembleLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    s.system.Assemble();
    benchmark::ClobberMemory();
  }
  const SparseMatrixView h = s.system.H();
  state.counters["H_nonzeros"] = static_cast<double>(h.colptr[h.cols]);
}

void LinearizeAssembleLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.system.Linearize());
    s.system.Assemble();
    benchmark::ClobberMemory();
  }
}

void BM_AssembleH_Manhattan10k(benchmark::State& state) { AssembleLoop(state, Manhattan10k()); }
BENCHMARK(BM_AssembleH_Manhattan10k)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMicrosecond);

void BM_AssembleH_Ais2klinik(benchmark::State& state) { AssembleLoop(state, Dataset("ais2klinik")); }
BENCHMARK(BM_AssembleH_Ais2klinik)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMicrosecond);

void BM_LinearizeAndAssemble_Manhattan10k(benchmark::State& state) { LinearizeAssembleLoop(state, Manhattan10k()); }
BENCHMARK(BM_LinearizeAndAssemble_Manhattan10k)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

void BM_LinearizeAndAssemble_Ais2klinik(benchmark::State& state) {
  LinearizeAssembleLoop(state, Dataset("ais2klinik"));
}
BENCHMARK(BM_LinearizeAndAssemble_Ais2klinik)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

void BM_Chi2_Ais2klinik(benchmark::State& state) {
  const Graph* g = Dataset("ais2klinik");
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(s.system.Chi2());
}
BENCHMARK(BM_Chi2_Ais2klinik)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMicrosecond);

void FactorizeLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, 1);
  s.system.Assemble();
  LinearSolverEntry cholmod;
  if (!DefaultLinearSolverRegistry().Get("cholmod", &cholmod)) {
    state.SkipWithError("no linear solver named cholmod");
    return;
  }
  std::unique_ptr<LinearSolver> chol = cholmod.make(LinearSolverOptions{});
  chol->Analyze(s.system.H(), {});
  for (auto _ : state) {
    if (chol->Factorize(s.system.H()) != LinearSolverStatus::kOk) {
      state.SkipWithError("H is not positive definite");
      break;
    }
  }
}

void BM_CholmodFactorize_Manhattan10k(benchmark::State& state) { FactorizeLoop(state, Manhattan10k()); }
BENCHMARK(BM_CholmodFactorize_Manhattan10k)->Unit(benchmark::kMicrosecond);

void BM_CholmodFactorize_Intel(benchmark::State& state) { FactorizeLoop(state, Dataset("intel")); }
BENCHMARK(BM_CholmodFactorize_Intel)->Unit(benchmark::kMicrosecond);

void BM_CholmodFactorize_Ais2klinik(benchmark::State& state) { FactorizeLoop(state, Dataset("ais2klinik")); }
BENCHMARK(BM_CholmodFactorize_Ais2klinik)->Unit(benchmark::kMicrosecond);

void BM_CholmodFactorize_Sphere2500(benchmark::State& state) { FactorizeLoop(state, Dataset("sphere2500")); }
BENCHMARK(BM_CholmodFactorize_Sphere2500)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tether
