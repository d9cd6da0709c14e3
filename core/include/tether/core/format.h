#pragma once
// printf-style formatting into a std::string of whatever length the result needs (a fixed
// buffer would cut a line holding a number such as 1e300 printed with %f).
#include <string>

namespace tether {

/// The text printf(format, ...) would print, whole.
std::string StringPrintf(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace tether
