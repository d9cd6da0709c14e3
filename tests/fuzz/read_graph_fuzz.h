#pragma once
// The body of the graph-reader fuzz targets, shared with the regression test that replays
// their findings in the normal build (tests/core/fuzz_regression_test.cc).
//
// The first byte of an input picks the read options (repair mode, partial vertices, loop
// closure rule); the rest is the file. A file that reads must also be written and read back
// with as many values and factors ("whatever tether writes, it reads"); anything but a
// tether::Error escaping, or a round trip that fails, is a finding (abort).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace fuzz {

inline ReadOptions OptionsFromByte(std::uint8_t b, FileFormat format) {
  ReadOptions o;
  o.format = format;
  o.repair = (b & 3) == 1   ? InformationRepair::kNearestPD
             : (b & 3) == 2 ? InformationRepair::kIsotropic
                            : InformationRepair::kNone;
  o.allow_partial_vertices = (b & 4) != 0;
  o.loop_closures = (b & 8) != 0 ? LoopClosureRule::kNone : LoopClosureRule::kNonConsecutive;
  return o;
}

[[noreturn]] inline void Finding(const std::string& what) {
  std::fprintf(stderr, "finding: %s\n", what.c_str());
  std::abort();
}

// Reads `data` as a graph file of `format`; returns 0 (what libFuzzer wants) or aborts.
inline int ReadGraphOnce(const std::uint8_t* data, std::size_t size, FileFormat format) {
  if (size == 0) return 0;
  const ReadOptions options = OptionsFromByte(data[0], format);
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  GraphFile g;
  try {
    std::istringstream in(text);
    g = ReadGraph(in, "fuzz.in", DefaultRegistry(), options);
  } catch (const Error&) {
    return 0;  // a clear refusal is the right answer to a bad file
  }
  std::string written;
  try {
    std::ostringstream out;
    WriteG2o(out, g.values, g.graph, DefaultRegistry());
    written = out.str();
  } catch (const Error& e) {
    Finding(std::string("a graph that was read cannot be written: ") + e.what());
  }
  ReadOptions again;
  again.format = FileFormat::kG2o;
  try {
    std::istringstream in(written);
    const GraphFile h = ReadGraph(in, "fuzz.out.g2o", DefaultRegistry(), again);
    if (h.values.size() != g.values.size() || h.graph.size() != g.graph.size()) {
      Finding("the written graph reads back with other counts");
    }
  } catch (const Error& e) {
    Finding(std::string("what tether wrote it cannot read: ") + e.what());
  }
  return 0;
}

}  // namespace fuzz
}  // namespace tether
