// The solver's per-iteration steps on real-sized graphs: assembling H and g (1 and 2
// threads), linearising, and one CHOLMOD numeric factorisation of H.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

#include "builtin_linear_solvers.h"
#include "problem.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"

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

// The solver's set-up for one graph: the lowest key fixed (gauge), the H pattern built,
// linearised once.
struct Setup {
  explicit Setup(const Graph& g, int threads)
      : values(g.values), problem(g.graph, &values, {g.values.keys().front()}, threads) {
    problem.BuildNormalStructure(&h, &diagonal);
    gradient.assign(problem.tangent_dim(), 0.0);
    problem.Linearize();
  }
  Values values;
  internal::Problem problem;
  internal::Csc h;
  std::vector<int> diagonal;
  std::vector<double> gradient;
};

void AssembleLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    s.problem.AssembleNormal(&s.h, s.gradient.data());
    benchmark::ClobberMemory();
  }
  state.counters["H_nonzeros"] = static_cast<double>(s.h.values.size());
}

void LinearizeAssembleLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.problem.Linearize());
    s.problem.AssembleNormal(&s.h, s.gradient.data());
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
  for (auto _ : state) benchmark::DoNotOptimize(s.problem.Chi2());
}
BENCHMARK(BM_Chi2_Ais2klinik)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMicrosecond);

void FactorizeLoop(benchmark::State& state, const Graph* g) {
  if (g == nullptr) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  Setup s(*g, 1);
  s.problem.AssembleNormal(&s.h, s.gradient.data());
  std::unique_ptr<LinearSolver> chol = internal::MakeCholmod();
  chol->Analyze(internal::View(s.h), {});
  for (auto _ : state) {
    if (chol->Factorize(internal::View(s.h)) != LinearSolverStatus::kOk) {
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
