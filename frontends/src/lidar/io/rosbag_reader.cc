#include "tether/frontends/lidar/io/rosbag_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/module.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

namespace {

// Bag records are length-prefixed; a damaged length would have the bag library allocate and
// read gigabytes. Every record (and every record inside an uncompressed chunk) is checked to
// lie within its file or chunk before the library opens the bag.
class BagRecordCheck {
 public:
  explicit BagRecordCheck(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    in_.seekg(0, std::ios::end);
    size_ = static_cast<std::uint64_t>(std::max<std::streamoff>(in_.tellg(), 0));
  }

  void Run() {
    if (!in_) return;        // the reader reports it
    Records(13, size_, "");  // after "#ROSBAG V2.0\n"
  }

 private:
  [[noreturn]] void Fail(std::uint64_t at, const std::string& what) const {
    throw ParseError(path_ + ": not a readable ROS 1 bag (byte " + std::to_string(at) + ": " + what +
                     "; the bag is damaged: truncated or corrupt)");
  }
  std::uint32_t U32(std::uint64_t at) {
    unsigned char b[4] = {};
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(reinterpret_cast<char*>(b), 4);
    if (in_.gcount() != 4) Fail(at, "a record is cut short");
    return std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24;
  }
  // The records in [begin, end), `within` naming the chunk for messages.
  void Records(std::uint64_t begin, std::uint64_t end, const std::string& within) {
    std::uint64_t at = begin;
    while (at < end) {
      if (end - at < 8) Fail(at, "a record" + within + " is cut short");
      const std::uint64_t header_len = U32(at);
      if (header_len > end - at - 8) {
        Fail(at, "a record header" + within + " claims " + std::to_string(header_len) + " bytes, past its end");
      }
      // The header's fields: op and, for a chunk, compression and the uncompressed size.
      std::string header(header_len, '\0');
      in_.read(&header[0], static_cast<std::streamsize>(header_len));
      char op = 0;
      std::string compression;
      std::uint64_t unpacked = 0;
      for (std::size_t f = 0; f < header.size();) {
        if (header.size() - f < 4) Fail(at, "a header field is cut short");
        std::uint32_t n = 0;
        std::memcpy(&n, &header[f], 4);
        if (n > header.size() - f - 4) Fail(at, "a header field claims " + std::to_string(n) + " bytes, past its end");
        const std::string field = header.substr(f + 4, n);
        const std::size_t eq = field.find('=');
        const std::string name = field.substr(0, eq);
        const std::string value = eq == std::string::npos ? "" : field.substr(eq + 1);
        if (name == "op" && value.size() == 1) op = value[0];
        if (name == "compression") compression = value;
        if (name == "size" && value.size() == 4) {
          std::uint32_t v = 0;
          std::memcpy(&v, value.data(), 4);
          unpacked = v;
        }
        f += 4 + n;
      }
      const std::uint64_t data_at = at + 4 + header_len;
      const std::uint64_t data_len = U32(data_at);
      if (data_len > end - data_at - 4) {
        Fail(data_at, "a record's data" + within + " claims " + std::to_string(data_len) + " bytes, past its end");
      }
      if (op == 0x05) {
        if (unpacked > (std::uint64_t(1) << 30)) {
          Fail(at, "a chunk claims " + std::to_string(unpacked) + " bytes uncompressed (over 1 GB)");
        }
        if (compression == "none")
          Records(data_at + 4, data_at + 4 + data_len, " in the chunk at byte " + std::to_string(at));
      }
      at = data_at + 4 + data_len;
    }
  }

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

}  // namespace

void CheckBagRecords(const std::string& path) { BagRecordCheck(path).Run(); }

#ifdef TETHER_HAVE_ROSBAG

namespace {

using BagEntry = void (*)(const std::string&, const LidarReadOptions&, LidarLog*);
constexpr const char* kRosBagModule = "libtether_rosbag.so";
constexpr const char* kRosBagEntry = "tether_rosbag_read_v1";

// The module beside this library (where both are built and installed), else wherever the
// dynamic loader finds it. Loaded once, never unloaded; a failure is kept and reported at
// every read.
BagEntry LoadBagModule() {
  static const LoadedModule loaded = LoadModuleBeside(reinterpret_cast<const void*>(&CheckBagRecords), kRosBagModule,
                                                      kRosBagEntry, ModuleScope::kLocal);
  const BagEntry entry = reinterpret_cast<BagEntry>(loaded.entry);
  const std::string& failure = loaded.failure;
  if (entry == nullptr) {
    throw IoError("ROS 1 bag support could not be loaded: " + failure +
                  "; rebuild tether (the module is built beside libtether_frontends) or configure with "
                  "-DTETHER_WITH_ROSBAG=OFF");
  }
  return entry;
}

}  // namespace

bool RosBagSupported() { return true; }

LidarLog ReadRosBag(const std::string& path, const LidarReadOptions& options) {
  CheckReadOptions(options);
  if (!std::ifstream(path).good()) throw IoError(path + ": cannot open the bag (" + std::strerror(errno) + ")");
  LidarLog log;
  log.path = path;
  log.format = LogFormat::kRosBag;
  CheckBagRecords(path);
  LoadBagModule()(path, options, &log);
  FinishLog(options, &log);
  return log;
}

#else

bool RosBagSupported() { return false; }

LidarLog ReadRosBag(const std::string& path, const LidarReadOptions&) {
  throw InvalidArgument(path +
                        ": this tether was built without ROS 1 bag support (TETHER_WITH_ROSBAG=OFF); install "
                        "librosbag-storage-dev libsensor-msgs-dev libnav-msgs-dev (scripts/install_deps.sh) and "
                        "rebuild");
}

#endif

}  // namespace lidar
}  // namespace tether
