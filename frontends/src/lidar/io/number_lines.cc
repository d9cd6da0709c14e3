#include "number_lines.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/fields.h"

namespace tether {
namespace lidar {
namespace internal {

bool ReadNumberLine(std::istream& in, const std::string& name, const char* const* fields, std::size_t n,
                    const char* layout, long* line, double* values) {
  std::string text;
  while (std::getline(in, text)) {
    ++*line;
    const std::size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos || text[first] == '#') continue;
    const auto fail = [&](const std::string& what) {
      throw ParseError(name + ":" + std::to_string(*line) + ": " + what + " (" + layout + ")");
    };
    std::istringstream s(text);
    std::string token;
    std::size_t k = 0;
    while (s >> token) {
      if (k == n) fail("more than " + std::to_string(n) + " fields");
      char* end = nullptr;
      values[k] = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0')
        fail(std::string(fields[k]) + " " + QuoteToken(token) + " is not a number");
      if (!std::isfinite(values[k])) fail(std::string(fields[k]) + " " + QuoteToken(token) + " is not finite");
      ++k;
    }
    if (k < n) fail("found " + std::to_string(k) + " fields, expected " + std::to_string(n));
    return true;
  }
  if (in.bad()) throw IoError(name + ": read error after line " + std::to_string(*line));
  return false;
}

}  // namespace internal
}  // namespace lidar
}  // namespace tether
