#include "tether/solvers/chunked_solve.h"

#include <algorithm>
#include <chrono>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "minimizer.h"
#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/solvers/optimizer.h"

namespace tether {

ChunkedSolveOptions::ChunkedSolveOptions() { solver.max_iterations = 30; }

bool ChunkedSolveOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (chunks < 1) return fail("chunks must be at least 1");
  if (free_chunks < 0) return fail("free_chunks must be at least 0");
  if (min_chunk_poses < 1) return fail("min_chunk_poses must be at least 1");
  if (!(interim_function_tolerance >= 0 && interim_function_tolerance < 1)) {
    return fail("interim_function_tolerance must be in [0, 1)");
  }
  std::string reason;
  if (!solver.IsValid(&reason)) return fail("solver: " + reason);
  return true;
}

namespace {

// Grows the subgraph as variables enter: a factor joins once every key of it is present.
class Growing {
 public:
  Growing(const FactorGraph& graph, const Values& given) : graph_(graph), given_(given) {
    missing_.resize(graph.size());
    for (std::size_t i = 0; i < graph.size(); ++i) {
      missing_[i] = static_cast<int>(graph.at(i).keys().size());
      for (Key k : graph.at(i).keys()) incident_[k].push_back(i);
    }
  }

  bool Present(Key k) const { return current_.Has(k); }
  Values& current() { return current_; }
  FactorGraph& sub() { return sub_; }

  // Places pose p from a present neighbour through an odometry factor (one that is not a
  // loop closure), else from the given start's step from `previous`; then adds it. A pose the
  // graph fixes stays where it is given.
  void AddPose(Key p, Key previous) {
    std::vector<double> out(AmbientDim(given_.TypeOf(p)));
    const bool fixed = graph_.IsFixed(p);
    bool placed = false;
    for (std::size_t i : Incident(p)) {
      if (fixed) break;
      const Factor& f = graph_.at(i);
      if (f.loop_closure() || f.keys().size() != 2) continue;
      const std::size_t at = f.keys()[0] == p ? 0 : 1, other = 1 - at;
      const Key o = f.keys()[other];
      if (o == p || !Present(o) || !IsPose(current_.TypeOf(o))) continue;
      if (f.Predict(other, current_.Params(o), at, out.data())) {
        placed = true;
        break;
      }
    }
    if (!fixed && !placed && Present(previous) && given_.TypeOf(previous) == given_.TypeOf(p)) {
      std::vector<double> delta(TangentDim(given_.TypeOf(p)));
      LocalParams(given_.TypeOf(p), given_.Params(previous), given_.Params(p), delta.data());
      RetractParams(given_.TypeOf(p), current_.Params(previous), delta.data(), out.data());
      placed = true;
    }
    Enter(p, placed ? out.data() : given_.Params(p));
    // Other variables (landmarks) tied to it enter at their given values.
    for (std::size_t i : Incident(p)) {
      for (Key k : graph_.at(i).keys()) {
        if (!Present(k) && !IsPose(given_.TypeOf(k))) Enter(k, given_.Params(k));
      }
    }
  }

 private:
  const std::vector<std::size_t>& Incident(Key k) const {
    static const std::vector<std::size_t> kNone;
    const auto it = incident_.find(k);
    return it == incident_.end() ? kNone : it->second;
  }

  void Enter(Key k, const double* params) {
    current_.InsertParams(k, given_.TypeOf(k), params);
    if (graph_.IsFixed(k)) sub_.Fix(k);
    for (std::size_t i : Incident(k)) {
      // A factor may name a key twice; count each occurrence.
      for (Key key : graph_.at(i).keys()) missing_[i] -= key == k ? 1 : 0;
      if (missing_[i] == 0) sub_.Add(graph_.at(i).Clone());
    }
  }

  const FactorGraph& graph_;
  const Values& given_;
  std::unordered_map<Key, std::vector<std::size_t>> incident_;
  std::vector<int> missing_;
  Values current_;
  FactorGraph sub_;
};

}  // namespace

ChunkedSolveSummary SolveInChunks(const FactorGraph& graph, Values* values, const ChunkedSolveOptions& options) {
  if (values == nullptr) throw InvalidArgument("SolveInChunks: values must not be null");
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("invalid chunked-solve options: " + why);
  const auto t0 = std::chrono::steady_clock::now();
  ChunkedSolveSummary r;
  // A factor whose variable has no value: not usable, as Optimize reports it (no exception).
  for (std::size_t i = 0; i < graph.size(); ++i) {
    for (Key k : graph.at(i).keys()) {
      if (values->Has(k)) continue;
      r.message = "factor " + std::to_string(i) + " (" + graph.at(i).Describe() + ") uses variable " +
                  std::to_string(k) + ", which has no value; give every variable an initial value";
      r.seconds = SecondsSince(t0);
      return r;
    }
  }
  std::vector<Key> poses;
  for (Key k : values->keys()) {
    if (IsPose(values->TypeOf(k))) poses.push_back(k);
  }
  std::sort(poses.begin(), poses.end());
  const int n = static_cast<int>(poses.size());
  if (n == 0) {  // nothing to grow by: one solve of the whole graph
    r.last = Optimize(graph, values, options.solver);
    r.chunks = 1;
    r.iterations = r.last.iterations;
    r.usable = r.last.IsSolutionUsable();
    if (!r.usable) r.message = "the solve failed: " + r.last.message;
    r.seconds = SecondsSince(t0);
    return r;
  }
  const int chunks = std::max(1, std::min(options.chunks, n / options.min_chunk_poses));
  Growing grow(graph, *values);
  int next = 0;
  std::size_t solved = 0;
  // With a window (free_chunks less than chunks), each chunk's solve moves the poses of the
  // newest free_chunks chunks only, the older ones held where the earlier solves left them;
  // then one more solve moves every pose. Without one, the last chunk's solve is the whole
  // graph's.
  const bool windowed = options.free_chunks > 0 && chunks > options.free_chunks;
  const int solves = chunks + (windowed ? 1 : 0);
  for (int c = 0; c < solves; ++c) {
    const int end = c + 1 >= chunks ? n : static_cast<int>((static_cast<long long>(n) * (c + 1)) / chunks);
    for (; next < end; ++next) grow.AddPose(poses[next], next > 0 ? poses[next - 1] : poses[next]);
    if (grow.sub().empty()) continue;
    if (options.before_solve) options.before_solve(c, solved, &grow.sub(), grow.current());
    solved = grow.sub().size();
    SolverOptions solver = options.solver;
    const bool last = c + 1 == solves;
    if (!last) solver.function_tolerance = std::max(solver.function_tolerance, options.interim_function_tolerance);
    const int first_free = !last && windowed && c + 1 > options.free_chunks
                               ? static_cast<int>((static_cast<long long>(n) * (c + 1 - options.free_chunks)) / chunks)
                               : 0;
    if (first_free == 0) {
      r.last = Optimize(grow.sub(), &grow.current(), solver);
    } else {
      // The window: the factors that touch a pose that moves (or a variable that is not a
      // pose); a factor among held poses alone is constant and left out.
      std::unordered_set<Key> held(poses.begin(), poses.begin() + first_free);
      FactorGraph window;
      for (std::size_t i = 0; i < grow.sub().size(); ++i) {
        const Factor& f = grow.sub().at(i);
        if (std::all_of(f.keys().begin(), f.keys().end(), [&held](Key k) { return held.count(k) != 0; })) continue;
        window.Add(f.Clone());
        for (Key k : f.keys()) {
          if (held.count(k)) window.Fix(k);
        }
      }
      for (Key k : grow.sub().fixed()) window.Fix(k);
      r.last = Optimize(window, &grow.current(), solver);
    }
    ++r.chunks;
    r.iterations += r.last.iterations;
    if (!r.last.IsSolutionUsable()) {
      r.message = (c < chunks ? "chunk " + std::to_string(c + 1) + " of " + std::to_string(chunks)
                              : std::string("the whole graph after the last chunk")) +
                  " (" + std::to_string(end) + " poses) failed: " + r.last.message;
      r.seconds = SecondsSince(t0);
      return r;
    }
  }
  for (Key k : grow.current().keys()) {
    const double* p = grow.current().Params(k);
    std::copy(p, p + AmbientDim(values->TypeOf(k)), values->Params(k));
  }
  r.usable = true;
  r.seconds = SecondsSince(t0);
  return r;
}

}  // namespace tether
