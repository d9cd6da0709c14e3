#include "tether/frontends/lidar/io/lidar_state.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <utility>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

namespace {

constexpr char kMagic[] = "tether lidar state\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
constexpr std::size_t kHeaderSize = kMagicSize + 4 + 8 + 8 + 4;
// zlib expands at most about 1032:1; a payload stated beyond that is not what the stream holds.
constexpr std::uint64_t kMaxRatio = 1100;

// Little-endian writing.
class Writer {
 public:
  template <class T>
  void Put(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    bytes_.append(reinterpret_cast<const char*>(b), sizeof(T));
  }
  void Pose(const SE2d& p) {
    Put(p.x());
    Put(p.y());
    Put(p.theta());
  }
  void Grid(const ProbabilityGrid& g) {
    Put(g.resolution());
    Put(g.origin().x());
    Put(g.origin().y());
    Put(g.min_probability());
    Put(g.max_probability());
    Put<std::int32_t>(g.min_cell().x());
    Put<std::int32_t>(g.min_cell().y());
    Put<std::int32_t>(g.size().x());
    Put<std::int32_t>(g.size().y());
    for (std::uint16_t v : g.values()) Put<std::uint16_t>(v & ProbabilityGrid::kMaxValue);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

// Little-endian reading that checks every size against the bytes left.
class Reader {
 public:
  Reader(const std::string& bytes, std::string name) : bytes_(bytes), name_(std::move(name)) {}
  [[noreturn]] void Fail(const std::string& what) const {
    throw ParseError(name_ + ": " + what + " (payload byte " + std::to_string(at_) +
                     "); the file is damaged or not a state: write it again with `tether lidar LOG -o DIR "
                     "--save-state`");
  }
  template <class T>
  T Get(const char* what) {
    if (bytes_.size() - at_ < sizeof(T)) Fail(std::string("the data ends inside ") + what);
    T v;
    std::memcpy(&v, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  double Finite(const char* what) {
    const double v = Get<double>(what);
    if (!std::isfinite(v)) Fail(std::string(what) + " is not finite");
    return v;
  }
  SE2d Pose(const char* what) {
    const double x = Finite(what), y = Finite(what), theta = Finite(what);
    return SE2d(x, y, theta);
  }
  // A count of items of at least `item_bytes` each, checked against the bytes left.
  std::size_t Count(const char* what, std::size_t item_bytes) {
    const std::uint64_t n = Get<std::uint64_t>(what);
    if (item_bytes > 0 && n > (bytes_.size() - at_) / item_bytes) {
      Fail(std::string(what) + ": " + std::to_string(n) + " stated, more than the remaining " +
           std::to_string(bytes_.size() - at_) + " bytes hold");
    }
    return static_cast<std::size_t>(n);
  }
  int Index(const char* what, long limit) {
    const std::int32_t v = Get<std::int32_t>(what);
    if (v < 0 || v >= limit)
      Fail(std::string(what) + " " + std::to_string(v) + " is out of range [0, " + std::to_string(limit) + ")");
    return v;
  }
  std::shared_ptr<const ProbabilityGrid> Grid(const std::string& what);
  bool done() const { return at_ == bytes_.size(); }
  std::size_t at() const { return at_; }

 private:
  const std::string& bytes_;
  std::string name_;
  std::size_t at_ = 0;
};

std::shared_ptr<const ProbabilityGrid> Reader::Grid(const std::string& what) {
  const char* w = what.c_str();
  const double resolution = Finite(w), ox = Finite(w), oy = Finite(w), lo = Finite(w), hi = Finite(w);
  // One value after the other (a constructor's arguments are read in no set order).
  const std::int32_t x0 = Get<std::int32_t>(w), y0 = Get<std::int32_t>(w);
  const std::int32_t sx = Get<std::int32_t>(w), sy = Get<std::int32_t>(w);
  const ProbabilityGrid::Cell min_cell(x0, y0), size(sx, sy);
  if (size.x() < 0 || size.y() < 0) Fail(what + ": a negative size");
  const auto count = static_cast<std::uint64_t>(size.x()) * static_cast<std::uint64_t>(size.y());
  if (count > (bytes_.size() - at_) / 2) {
    Fail(what + ": " + std::to_string(size.x()) + " x " + std::to_string(size.y()) +
         " cells stated, more than the remaining bytes hold");
  }
  std::vector<std::uint16_t> values(static_cast<std::size_t>(count));
  for (std::uint16_t& v : values) v = Get<std::uint16_t>(w);
  try {
    auto grid = std::make_shared<ProbabilityGrid>(resolution, Eigen::Vector2d(ox, oy), lo, hi);
    grid->Restore(min_cell, size, std::move(values));
    return grid;
  } catch (const InvalidArgument& e) {
    Fail(what + ": " + e.what());
  }
}

std::string CheckGrid(const std::shared_ptr<const ProbabilityGrid>& g, const std::string& what) {
  if (g == nullptr) return what + " has no grid";
  if (g->pending_updates() > 0) return what + "'s grid has updates pending (FinishUpdate)";
  return "";
}

bool Finite(const SE2d& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.theta()); }

}  // namespace

std::string LidarState::Problem() const {
  if (trajectories < 1) return "no trajectory";
  const long n_submaps = static_cast<long>(submaps.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const SavedScan& s = scans[i];
    const std::string what = "scan " + std::to_string(i);
    if (s.trajectory < 0 || s.trajectory >= trajectories) return what + ": trajectory out of range";
    if (!std::isfinite(s.stamp) || !Finite(s.pose) || !Finite(s.local_pose) || !Finite(s.laser_in_robot)) {
      return what + ": a number is not finite";
    }
    for (int j : s.submaps) {
      if (j < 0 || j >= n_submaps) return what + ": submap " + std::to_string(j) + " out of range";
    }
    for (const Eigen::Vector2d& p : s.points) {
      if (!p.allFinite() || std::abs(p.x()) > std::numeric_limits<float>::max() ||
          std::abs(p.y()) > std::numeric_limits<float>::max()) {
        return what + ": a point is not finite as a float";
      }
    }
  }
  for (std::size_t j = 0; j < submaps.size(); ++j) {
    const SavedSubmap& m = submaps[j];
    const std::string what = "submap " + std::to_string(j);
    if (m.trajectory < 0 || m.trajectory >= trajectories) return what + ": trajectory out of range";
    if (!Finite(m.pose) || !Finite(m.local_pose)) return what + ": a number is not finite";
    if (m.num_scans < 0) return what + ": a negative scan count";
    if (const std::string why = CheckGrid(m.grid, what); !why.empty()) return why;
  }
  for (std::size_t c = 0; c < closures.size(); ++c) {
    const SavedClosure& l = closures[c];
    const std::string what = "loop closure " + std::to_string(c);
    if (l.scan < 0 || l.scan >= static_cast<long>(scans.size()) || l.submap < 0 || l.submap >= n_submaps) {
      return what + ": scan or submap out of range";
    }
    if (!Finite(l.relative) || !std::isfinite(l.score)) return what + ": a number is not finite";
  }
  return CheckGrid(map, "the map");
}

std::string LidarStateBytes(const LidarState& state) {
  if (const std::string why = state.Problem(); !why.empty()) throw InvalidArgument("LidarStateBytes: " + why);
  Writer w;
  w.Put<std::int32_t>(state.trajectories);
  w.Put<std::uint64_t>(state.scans.size());
  for (const SavedScan& s : state.scans) {
    w.Put(s.stamp);
    w.Put<std::int32_t>(s.trajectory);
    w.Pose(s.pose);
    w.Pose(s.local_pose);
    w.Pose(s.laser_in_robot);
    w.Put<std::uint64_t>(s.submaps.size());
    for (int j : s.submaps) w.Put<std::int32_t>(j);
    w.Put<std::uint64_t>(s.points.size());
    for (const Eigen::Vector2d& p : s.points) {
      w.Put(static_cast<float>(p.x()));
      w.Put(static_cast<float>(p.y()));
    }
  }
  w.Put<std::uint64_t>(state.submaps.size());
  for (const SavedSubmap& m : state.submaps) {
    w.Put<std::int32_t>(m.trajectory);
    w.Pose(m.pose);
    w.Pose(m.local_pose);
    w.Put<std::int32_t>(m.num_scans);
    w.Grid(*m.grid);
  }
  w.Put<std::uint64_t>(state.closures.size());
  for (const SavedClosure& l : state.closures) {
    w.Put<std::int32_t>(l.scan);
    w.Put<std::int32_t>(l.submap);
    w.Pose(l.relative);
    w.Put(l.score);
  }
  w.Grid(*state.map);
  const std::string& payload = w.bytes();

  uLongf stored = compressBound(static_cast<uLong>(payload.size()));
  std::string packed(stored, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&packed[0]), &stored, reinterpret_cast<const Bytef*>(payload.data()),
                static_cast<uLong>(payload.size()), Z_BEST_SPEED) != Z_OK) {
    throw Error("LidarStateBytes: zlib could not compress the state");
  }
  packed.resize(stored);
  Writer file;
  file.bytes() = kMagic;
  file.Put<std::uint32_t>(kLidarStateVersion);
  file.Put<std::uint64_t>(payload.size());
  file.Put<std::uint64_t>(packed.size());
  file.Put<std::uint32_t>(static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size()))));
  file.bytes() += packed;
  return std::move(file.bytes());
}

namespace {

// The payload of a state file, unpacked and checked against its header.
std::string Unpack(const std::string& bytes, const std::string& name) {
  const auto fail = [&name](const std::string& what) {
    throw ParseError(name + ": " + what + "; write it again with `tether lidar LOG -o DIR --save-state`");
  };
  if (bytes.size() < kMagicSize || bytes.compare(0, kMagicSize, kMagic) != 0) {
    fail("not a tether LiDAR state (it does not begin with \"tether lidar state\")");
  }
  if (bytes.size() < kHeaderSize) fail("the header is cut short (" + std::to_string(bytes.size()) + " bytes)");
  const std::string header = bytes.substr(kMagicSize, kHeaderSize - kMagicSize);
  Reader h(header, name);
  const auto version = h.Get<std::uint32_t>("the version");
  if (version != kLidarStateVersion) {
    fail("version " + std::to_string(version) + "; this tether reads version " + std::to_string(kLidarStateVersion));
  }
  const auto size = h.Get<std::uint64_t>("the payload size");
  const auto stored = h.Get<std::uint64_t>("the stored size");
  const auto crc = h.Get<std::uint32_t>("the CRC");
  if (stored != bytes.size() - kHeaderSize) {
    fail("the header states " + std::to_string(stored) + " stored bytes; the file holds " +
         std::to_string(bytes.size() - kHeaderSize) + " (cut short or grown)");
  }
  if (size > kMaxRatio * stored + 64 || size > std::numeric_limits<uLongf>::max()) {
    fail("the header states a payload of " + std::to_string(size) + " bytes, more than " + std::to_string(stored) +
         " stored bytes can unpack to");
  }
  std::string payload(static_cast<std::size_t>(size), '\0');
  uLongf got = static_cast<uLongf>(size);
  const int rc = uncompress(reinterpret_cast<Bytef*>(&payload[0]), &got,
                            reinterpret_cast<const Bytef*>(bytes.data() + kHeaderSize), static_cast<uLong>(stored));
  if (rc != Z_OK || got != size) fail("the compressed payload is damaged (it does not unpack to the stated size)");
  if (crc32(0L, reinterpret_cast<const Bytef*>(payload.data()), static_cast<uInt>(payload.size())) != crc) {
    fail("the payload does not match its CRC");
  }
  return payload;
}

SavedScan ReadScan(Reader* r, int trajectories) {
  SavedScan s;
  s.stamp = r->Finite("a scan's stamp");
  s.trajectory = r->Index("a scan's trajectory", trajectories);
  s.pose = r->Pose("a scan's pose");
  s.local_pose = r->Pose("a scan's local pose");
  s.laser_in_robot = r->Pose("a scan's laser pose");
  s.submaps.resize(r->Count("a scan's submaps", 4));
  for (int& j : s.submaps) j = r->Get<std::int32_t>("a scan's submap");  // checked once submaps are known
  s.points.resize(r->Count("a scan's points", 8));
  for (Eigen::Vector2d& p : s.points) {
    const auto x = r->Get<float>("a point"), y = r->Get<float>("a point");
    if (!std::isfinite(x) || !std::isfinite(y)) r->Fail("a scan's point is not finite");
    p = Eigen::Vector2d(x, y);
  }
  return s;
}

}  // namespace

LidarState ParseLidarState(const std::string& bytes, const std::string& name) {
  const std::string payload = Unpack(bytes, name);
  Reader r(payload, name);
  LidarState state;
  state.trajectories = r.Get<std::int32_t>("the trajectory count");
  if (state.trajectories < 1) r.Fail("the trajectory count is " + std::to_string(state.trajectories));
  state.scans.resize(r.Count("the scan count", 84));
  for (SavedScan& s : state.scans) s = ReadScan(&r, state.trajectories);
  state.submaps.resize(r.Count("the submap count", 104));
  for (std::size_t j = 0; j < state.submaps.size(); ++j) {
    SavedSubmap& m = state.submaps[j];
    m.trajectory = r.Index("a submap's trajectory", state.trajectories);
    m.pose = r.Pose("a submap's pose");
    m.local_pose = r.Pose("a submap's local pose");
    m.num_scans = r.Get<std::int32_t>("a submap's scan count");
    if (m.num_scans < 0) r.Fail("submap " + std::to_string(j) + " holds a negative number of scans");
    m.grid = r.Grid("submap " + std::to_string(j) + "'s grid");
  }
  for (std::size_t i = 0; i < state.scans.size(); ++i) {
    for (int j : state.scans[i].submaps) {
      if (j < 0 || j >= static_cast<long>(state.submaps.size())) {
        r.Fail("scan " + std::to_string(i) + " went into submap " + std::to_string(j) + ", of " +
               std::to_string(state.submaps.size()));
      }
    }
  }
  state.closures.resize(r.Count("the loop closure count", 40));
  for (SavedClosure& l : state.closures) {
    l.scan = r.Index("a loop closure's scan", static_cast<long>(state.scans.size()));
    l.submap = r.Index("a loop closure's submap", static_cast<long>(state.submaps.size()));
    l.relative = r.Pose("a loop closure's pose");
    l.score = r.Finite("a loop closure's score");
  }
  state.map = r.Grid("the map");
  if (!r.done()) r.Fail("bytes are left after the map");
  return state;
}

LidarState ReadLidarState(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open the state file");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw IoError(path + ": reading the state file failed");
  return ParseLidarState(s.str(), path);
}

}  // namespace lidar
}  // namespace tether
