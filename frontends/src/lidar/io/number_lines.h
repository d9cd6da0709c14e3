#pragma once
// Internal: text files whose lines are a fixed number of numbers (TUM trajectories, relations).
#include <cstddef>
#include <istream>
#include <string>

namespace tether {
namespace lidar {
namespace internal {

/// Reads the next line of `in` that is neither blank nor a `#` comment as exactly `n` finite
/// numbers into `values` (`*line` counts the lines read); false at the end of the stream.
/// Throws ParseError "name:line: ... (layout)" naming the field, IoError on a read error.
bool ReadNumberLine(std::istream& in, const std::string& name, const char* const* fields, std::size_t n,
                    const char* layout, long* line, double* values);

}  // namespace internal
}  // namespace lidar
}  // namespace tether
