// Reading g2o: a simulated 10k-pose graph from memory, and the public files where present.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <sstream>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

const std::string& SimulatedText(SimWorld world) {
  static std::string text[3];
  std::string& t = text[static_cast<int>(world)];
  if (t.empty()) {
    SimulateOptions o;
    o.world = world;
    o.poses = 10000;
    o.seed = 1;
    const SimulatedGraph sim = Simulate(o);
    std::ostringstream out;
    WriteG2o(out, sim.initial, sim.graph, DefaultRegistry());
    t = out.str();
  }
  return t;
}

void ParseText(benchmark::State& state, SimWorld world) {
  const std::string& text = SimulatedText(world);
  for (auto _ : state) {
    std::istringstream in(text);
    GraphFile f = ReadGraph(in, "memory.g2o", DefaultRegistry());
    benchmark::DoNotOptimize(f.graph.size());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(text.size()));
}

void BM_ParseG2o_Manhattan10k(benchmark::State& state) { ParseText(state, SimWorld::kManhattan); }
BENCHMARK(BM_ParseG2o_Manhattan10k)->Unit(benchmark::kMillisecond);

void BM_ParseG2o_Sphere10k(benchmark::State& state) { ParseText(state, SimWorld::kSphere); }
BENCHMARK(BM_ParseG2o_Sphere10k)->Unit(benchmark::kMillisecond);

void ParseFile(benchmark::State& state, const std::string& name) {
  const std::string path = std::string(TETHER_DATASETS_G2O) + "/" + name + ".g2o";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("dataset not found in ../shared/datasets/g2o");
    return;
  }
  for (auto _ : state) {
    GraphFile f = ReadGraphFile(path, DefaultRegistry());
    benchmark::DoNotOptimize(f.graph.size());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(std::filesystem::file_size(path)));
}

void BM_ParseG2o_Ais2klinik(benchmark::State& state) { ParseFile(state, "ais2klinik"); }
BENCHMARK(BM_ParseG2o_Ais2klinik)->Unit(benchmark::kMillisecond);

void BM_ParseG2o_Sphere2500(benchmark::State& state) { ParseFile(state, "sphere2500"); }
BENCHMARK(BM_ParseG2o_Sphere2500)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tether
