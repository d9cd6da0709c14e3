#pragma once
// The body of the graph-reader fuzz targets, shared with the regression test that replays
// their findings in the normal build (tests/factors/fuzz_regression_test.cc).
//
// The first byte of an input picks the read options; the rest is the file:
//   bits 0-1  repair: 0 or 3 none, 1 nearest-pd, 2 isotropic
//   bit 2     allow_partial_vertices
//   bit 3     loop closures: set kNone, clear kNonConsecutive
//   bit 4     FileFormat::kAuto instead of the target's format
//   bit 5     the stream's name ends in ".graph" (what kAuto takes for TORO), else ".g2o"
//   bit 6     iSAM noise read as a covariance (IsamNoise::kCovariance)
//   bit 7     landmark_key_offset 5 instead of 1e9 (landmark keys meet pose ids)
// A file that reads must also be written and read back as the same graph ("whatever tether
// writes, it reads"): the same variables (keys, types, parameters), the same factors (types,
// keys, measurements, information) in the same order, the same fixed ids. Anything but a
// tether::Error escaping, or a round trip that fails, is a finding (abort).
//
// TETHER_FUZZ_ROUNDTRIP=0 in the environment leaves the write and read-back out (to fuzz the
// readers alone).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace fuzz {

inline ReadOptions OptionsFromByte(std::uint8_t b, FileFormat format) {
  ReadOptions o;
  o.format = (b & 16) != 0 ? FileFormat::kAuto : format;
  o.repair = (b & 3) == 1   ? InformationRepair::kNearestPD
             : (b & 3) == 2 ? InformationRepair::kIsotropic
                            : InformationRepair::kNone;
  o.allow_partial_vertices = (b & 4) != 0;
  o.loop_closures = (b & 8) != 0 ? LoopClosureRule::kNone : LoopClosureRule::kNonConsecutive;
  o.isam_noise = (b & 64) != 0 ? IsamNoise::kCovariance : IsamNoise::kSquareRootInformation;
  if ((b & 128) != 0) o.landmark_key_offset = 5;
  return o;
}

inline std::string NameFromByte(std::uint8_t b) { return (b & 32) != 0 ? "fuzz.graph" : "fuzz.g2o"; }

/// False where TETHER_FUZZ_ROUNDTRIP is set to "0" (read once per process).
inline bool RoundTripEnabled() {
  static const bool enabled = [] {
    const char* v = std::getenv("TETHER_FUZZ_ROUNDTRIP");
    return v == nullptr || std::strcmp(v, "0") != 0;
  }();
  return enabled;
}

[[noreturn]] inline void Finding(const std::string& what) {
  std::fprintf(stderr, "finding: %s\n", what.c_str());
  std::abort();
}

// The same number up to the last few bits (a quaternion is normalised again on reading).
inline bool Close(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}); }

// Compares the graph that was read (g) with what its written text read back as (h).
inline void ExpectSameGraph(const GraphFile& g, const GraphFile& h, const std::string& written) {
  const auto fail = [&](const std::string& what) { Finding("the written graph reads back " + what + ":\n" + written); };
  if (h.values.size() != g.values.size() || h.graph.size() != g.graph.size()) {
    fail("with other counts (" + std::to_string(h.values.size()) + " values, " + std::to_string(h.graph.size()) +
         " factors; written from " + std::to_string(g.values.size()) + " values, " + std::to_string(g.graph.size()) +
         " factors)");
  }
  for (std::size_t i = 0; i < g.values.size(); ++i) {
    const Key k = g.values.keys()[i];
    if (h.values.keys()[i] != k || h.values.TypeOf(k) != g.values.TypeOf(k)) {
      fail("with other keys or types (value #" + std::to_string(i) + ", key " + std::to_string(k) + ")");
    }
    const int n = AmbientDim(g.values.TypeOf(k));
    for (int j = 0; j < n; ++j) {
      const double original = g.values.Params(k)[j];
      if (!Close(original, h.values.Params(k)[j])) {
        fail("with another value of key " + std::to_string(k) + " (parameter " + std::to_string(j) + ")");
      }
    }
  }
  for (std::size_t i = 0; i < g.graph.size(); ++i) {
    const Factor& a = g.graph.at(i);
    const Factor& b = h.graph.at(i);
    const std::string which = "factor #" + std::to_string(i) + " (" + a.type_name() + ")";
    if (a.type_name() != b.type_name() || a.keys() != b.keys()) fail("with another type or keys in " + which);
    const std::vector<double> ma = a.Measurement(), mb = b.Measurement();
    if (ma.size() != mb.size()) fail("with another measurement size in " + which);
    for (std::size_t j = 0; j < ma.size(); ++j) {
      if (Close(ma[j], mb[j])) continue;
      fail("with another measurement in " + which + " (number " + std::to_string(j) + ")");
    }
    const Eigen::MatrixXd ia = a.noise().Information(), ib = b.noise().Information();
    if (ia.rows() != ib.rows() || ia.cols() != ib.cols()) fail("with another information size in " + which);
    for (Eigen::Index r = 0; r < ia.rows(); ++r)
      for (Eigen::Index c = 0; c < ia.cols(); ++c)
        if (!Close(ia(r, c), ib(r, c))) fail("with another information in " + which);
  }
  if (h.graph.fixed() != g.graph.fixed()) fail("with other fixed ids");
}

// Writes g as g2o and reads the text back (default options); a failure is a finding.
inline void CheckRoundTrip(const GraphFile& g) {
  std::string written;
  try {
    std::ostringstream out;
    WriteG2o(out, g.values, g.graph, DefaultRegistry());
    written = out.str();
  } catch (const Error& e) {
    Finding(std::string("a graph that was read cannot be written: ") + e.what());
  }
  GraphFile h;
  try {
    std::istringstream in(written);
    ReadOptions again;
    again.format = FileFormat::kG2o;
    h = ReadGraph(in, "fuzz.out.g2o", DefaultRegistry(), again);
  } catch (const Error& e) {
    Finding(std::string("what tether wrote it cannot read: ") + e.what() + "\n" + written);
  }
  ExpectSameGraph(g, h, written);
}

// Reads `data` as a graph file of `format` (see the top of this file); returns 0 (what
// libFuzzer wants) or aborts.
inline int ReadGraphOnce(const std::uint8_t* data, std::size_t size, FileFormat format) {
  if (size == 0) return 0;
  const ReadOptions options = OptionsFromByte(data[0], format);
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  GraphFile g;
  try {
    std::istringstream in(text);
    g = ReadGraph(in, NameFromByte(data[0]), DefaultRegistry(), options);
  } catch (const Error&) {
    return 0;  // a clear refusal is the right answer to a bad file
  }
  if (RoundTripEnabled()) CheckRoundTrip(g);
  return 0;
}

}  // namespace fuzz
}  // namespace tether
