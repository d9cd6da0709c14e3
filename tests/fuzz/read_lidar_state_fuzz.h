#pragma once
// The body of the LiDAR state reader's fuzz target (read_lidar_state_fuzzer.cc), shared with the
// test that replays its findings and its own mutations in the normal build
// (tests/frontends/lidar_state_test.cc).
//
// The first byte of an input picks what the rest is:
//   0  a whole state file, read as it is (the header, the stream and the CRC are checked first)
//   1  a payload, packed into a file with a correct header and CRC, so that the fuzzer reaches
//      the checks of the contents (counts, indices, grids, numbers)
// A state that reads must have no Problem() and write back to bytes that read back as the same
// bytes again. Anything but a tether::ParseError escaping, or a round trip that differs, is a
// finding (abort).
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "tether/core/error.h"
#include "tether/frontends/lidar/io/lidar_state.h"

namespace tether {
namespace fuzz {

/// A state file around `payload`: the header (version 1, sizes, CRC) and the zlib stream.
inline std::string PackLidarStatePayload(const std::string& payload) {
  uLongf stored = compressBound(static_cast<uLong>(payload.size()));
  std::string packed(stored, '\0');
  compress2(reinterpret_cast<Bytef*>(&packed[0]), &stored, reinterpret_cast<const Bytef*>(payload.data()),
            static_cast<uLong>(payload.size()), 1);
  packed.resize(stored);
  std::string file = "tether lidar state\n";
  const auto put = [&file](const void* v, std::size_t n) { file.append(static_cast<const char*>(v), n); };
  const std::uint32_t version = lidar::kLidarStateVersion;
  const std::uint64_t size = payload.size(), packed_size = packed.size();
  const auto crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())));
  put(&version, 4);
  put(&size, 8);
  put(&packed_size, 8);
  put(&crc, 4);
  return file + packed;
}

/// The payload of a state file this build wrote (the inverse of PackLidarStatePayload).
inline std::string UnpackLidarStatePayload(const std::string& file) {
  constexpr std::size_t kHeader = 19 + 4 + 8 + 8 + 4;
  std::uint64_t size = 0;
  std::memcpy(&size, file.data() + 23, 8);
  std::string payload(size, '\0');
  uLongf got = static_cast<uLongf>(size);
  uncompress(reinterpret_cast<Bytef*>(&payload[0]), &got, reinterpret_cast<const Bytef*>(file.data() + kHeader),
             static_cast<uLong>(file.size() - kHeader));
  return payload;
}

[[noreturn]] inline void LidarStateFinding(const std::string& what) {
  std::fprintf(stderr, "finding: %s\n", what.c_str());
  std::abort();
}

/// Reads one input as the header above says; returns 0 (libFuzzer's convention).
inline int ReadLidarStateOnce(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string file = (data[0] & 1) != 0 ? PackLidarStatePayload(rest) : rest;
  lidar::LidarState state;
  try {
    state = lidar::ParseLidarState(file, "fuzz.tether");
  } catch (const ParseError&) {
    return 0;
  } catch (const std::exception& e) {
    LidarStateFinding(std::string("not a ParseError: ") + e.what());
  }
  const std::string problem = state.Problem();
  if (!problem.empty()) LidarStateFinding("read a state with a problem: " + problem);
  try {
    const std::string again = lidar::LidarStateBytes(state);
    if (lidar::LidarStateBytes(lidar::ParseLidarState(again, "again.tether")) != again) {
      LidarStateFinding("the state read back differs");
    }
  } catch (const std::exception& e) {
    LidarStateFinding(std::string("writing what was read failed: ") + e.what());
  }
  return 0;
}

}  // namespace fuzz
}  // namespace tether
