#pragma once
// A scratch file of this process for fuzz targets whose reader takes a path: $TMPDIR (or /tmp)
// /tether_fuzz_STEM_PID.EXT.
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace tether {
namespace fuzz {

inline std::string ScratchPath(const std::string& stem, const std::string& ext) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir != nullptr && *dir != '\0' ? dir : "/tmp") + "/tether_fuzz_" + stem + "_" +
         std::to_string(::getpid()) + "." + ext;
}

}  // namespace fuzz
}  // namespace tether
