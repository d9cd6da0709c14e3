#include "tether/core/format.h"

#include <cstdarg>
#include <cstdio>

namespace tether {

std::string StringPrintf(const char* format, ...) {
  std::va_list args;
  va_start(args, format);
  std::va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  std::string out;
  if (n > 0) {
    out.resize(static_cast<std::size_t>(n));
    std::vsnprintf(&out[0], out.size() + 1, format, again);
  }
  va_end(again);
  return out;
}

}  // namespace tether
