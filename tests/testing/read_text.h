#pragma once
// Shared test helper: reading a graph from text held in the test, and the ParseError it gives.
#include <sstream>
#include <string>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace testing {

/// `text` read as the file `name` (whose name also picks the format where options say kAuto).
inline GraphFile ReadText(const std::string& text, const std::string& name, const ReadOptions& options = {}) {
  std::istringstream in(text);
  return ReadGraph(in, name, DefaultRegistry(), options);
}

/// The ParseError's message reading `text` gives, or "(no error)".
inline std::string ReadTextError(const std::string& text, const std::string& name, const ReadOptions& options = {}) {
  try {
    ReadText(text, name, options);
  } catch (const ParseError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace testing
}  // namespace tether
