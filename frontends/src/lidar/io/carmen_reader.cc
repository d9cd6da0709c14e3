#include "tether/frontends/lidar/io/carmen_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/fields.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

namespace {

// The bytes of a plain or a gzip file, read in blocks from any file a path names (a pipe
// too: nothing seeks). A gzip file may hold several members, one after another, as `gzip -d`
// reads them; anything after the last member that is neither another member nor zero padding
// is refused by name (it used to be dropped without a word).
class LogBytes {
 public:
  explicit LogBytes(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "rb")) {
    if (file_ == nullptr) {
      const int err = errno;
      throw IoError(path + ": cannot open the log (" + (err != 0 ? std::strerror(err) : "out of memory") + ")");
    }
    try {
      in_.resize(1 << 17);
      Refill();
    } catch (...) {
      std::fclose(file_);
      throw;
    }
    gzip_ = Starts(kGzipMagic);
    if (gzip_ && inflateInit2(&z_, 15 + 16) != Z_OK) {
      std::fclose(file_);
      throw IoError(path + ": cannot read the log (zlib could not start)");
    }
  }
  ~LogBytes() {
    if (gzip_) inflateEnd(&z_);
    std::fclose(file_);
  }
  LogBytes(const LogBytes&) = delete;
  LogBytes& operator=(const LogBytes&) = delete;

  // Up to `n` bytes of the log into `out`; 0 at its end. `line` is the last line read, for
  // messages. Throws ParseError on damaged or trailing gzip data, IoError where it cannot read.
  std::size_t Read(char* out, std::size_t n, long line) {
    line_ = line;
    if (n == 0) return 0;
    if (!gzip_) {
      if (begin_ == end_ && !Refill()) return 0;
      const std::size_t k = std::min(n, end_ - begin_);
      std::memcpy(out, &in_[begin_], k);
      begin_ += k;
      return k;
    }
    z_.next_out = reinterpret_cast<Bytef*>(out);
    z_.avail_out = static_cast<uInt>(n);
    while (z_.avail_out == n) {
      if (member_done_ && !NextMember(line)) break;
      if (begin_ == end_ && !Refill()) Damaged(line, "unexpected end of file");
      z_.next_in = reinterpret_cast<Bytef*>(&in_[begin_]);
      z_.avail_in = static_cast<uInt>(end_ - begin_);
      const int rc = inflate(&z_, Z_NO_FLUSH);
      begin_ = end_ - z_.avail_in;
      if (rc == Z_STREAM_END) {
        member_done_ = true;
      } else if (rc != Z_OK && !(rc == Z_BUF_ERROR && begin_ == end_)) {
        Damaged(line, z_.msg != nullptr ? z_.msg : "error " + std::to_string(rc));
      }
    }
    return n - z_.avail_out;
  }

 private:
  static constexpr unsigned char kGzipMagic[2] = {0x1f, 0x8b};

  // After a member: true where another one follows (ready to inflate), false at the end of the
  // file (or of its zero padding); throws for other trailing data.
  bool NextMember(long line) {
    while (end_ - begin_ < 2 && Refill(true)) {
    }
    if (begin_ == end_) return false;
    if (Starts(kGzipMagic)) {
      inflateReset(&z_);
      member_done_ = false;
      return true;
    }
    std::size_t trailing = 0, nonzero = 0;
    do {
      for (std::size_t i = begin_; i < end_; ++i) nonzero += in_[i] != '\0';
      trailing += end_ - begin_;
      begin_ = end_;
    } while (Refill());
    if (nonzero == 0) return false;  // zero padding after the last member, as tape blocks leave
    throw ParseError(path_ + ":" + std::to_string(line + 1) + ": " + std::to_string(trailing) +
                     " bytes after the end of the gzip data are not gzip (trailing data: the file was damaged "
                     "or appended to); `gzip -dc` shows what the gzip data holds");
  }

  bool Starts(const unsigned char (&magic)[2]) const {
    return end_ - begin_ >= 2 && static_cast<unsigned char>(in_[begin_]) == magic[0] &&
           static_cast<unsigned char>(in_[begin_ + 1]) == magic[1];
  }

  // Reads more of the file after what is left (kept at the front with `keep`); false at its end.
  bool Refill(bool keep = false) {
    std::size_t left = 0;
    if (keep && begin_ < end_) {
      left = end_ - begin_;
      std::memmove(&in_[0], &in_[begin_], left);
    }
    begin_ = 0;
    end_ = left;
    const std::size_t got = std::fread(&in_[left], 1, in_.size() - left, file_);
    if (got == 0 && std::ferror(file_)) {
      throw IoError(path_ + ": cannot read the log after line " + std::to_string(line_) + " (" + std::strerror(errno) +
                    ")");
    }
    end_ += got;
    return got > 0;
  }

  [[noreturn]] void Damaged(long line, const std::string& what) const {
    throw ParseError(path_ + ":" + std::to_string(line + 1) + ": the compressed data is damaged (zlib: " + what +
                     "); the file is truncated or corrupt");
  }

  std::string path_;
  std::FILE* file_;
  std::string in_;
  std::size_t begin_ = 0, end_ = 0;  // the unread input: in_[begin_, end_)
  bool gzip_ = false;
  bool member_done_ = false;
  z_stream z_{};
  long line_ = 0;  // the last line read, for messages
};

// Lines of a log (LogBytes), of any length: a NUL byte inside a line is an error, not its end.
class GzLines {
 public:
  /// The longest line read: a scan of kMaxBeams ranges and as many remissions fits in it.
  static constexpr std::size_t kMaxLineBytes = std::size_t(32) << 20;

  explicit GzLines(const std::string& path) : path_(path), bytes_(path) {}

  // The next line without its end-of-line; false at the end. Throws ParseError on a damaged
  // gzip stream (truncated, bad checksum, trailing data) or a NUL byte, naming the line;
  // IoError where the file cannot be read.
  bool Next(std::string* line) {
    line->clear();
    for (;;) {
      // A line ends at LF, CR LF or a lone CR (old Mac files).
      if (skip_lf_ && begin_ < buffer_.size()) {
        if (buffer_[begin_] == '\n') ++begin_;
        skip_lf_ = false;
      }
      const std::size_t eol = buffer_.find_first_of("\r\n", begin_);
      if (eol != std::string::npos) {
        line->append(buffer_, begin_, eol - begin_);
        begin_ = eol + 1;
        skip_lf_ = buffer_[eol] == '\r';
        break;
      }
      line->append(buffer_, begin_, std::string::npos);
      buffer_.clear();
      begin_ = 0;
      if (line->size() > kMaxLineBytes) {
        throw ParseError(path_ + ":" + std::to_string(line_ + 1) + ": the line is longer than " +
                         std::to_string(kMaxLineBytes >> 20) + " MB (a million beams with remissions fit in " +
                         "less); is this a text log?");
      }
      if (!Fill()) {
        if (line->empty()) return false;
        break;
      }
    }
    ++line_;
    if (line->find('\0') != std::string::npos) {
      throw ParseError(path_ + ":" + std::to_string(line_) + ": a NUL byte in the line; is this a text log?");
    }
    while (!line->empty() && line->back() == '\r') line->pop_back();
    return true;
  }
  long line() const { return line_; }

 private:
  // Reads the next block into buffer_; false at the end of the data.
  bool Fill() {
    if (eof_) return false;
    buffer_.resize(1 << 16);
    const std::size_t n = bytes_.Read(&buffer_[0], buffer_.size(), line_);
    buffer_.resize(n);
    if (n == 0) eof_ = true;
    return n > 0;
  }

  std::string path_;
  LogBytes bytes_;
  std::string buffer_;
  std::size_t begin_ = 0;
  bool eof_ = false;
  bool skip_lf_ = false;  // the last line ended at a CR: an LF right after it belongs to it
  long line_ = 0;
};

// One line split into fields, with typed access that names the field in every message.
class Fields {
 public:
  Fields(const std::string& path, long line, const std::string& text) : path_(path), line_(line) {
    std::size_t i = 0;
    while (i < text.size()) {
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r')) ++i;
      const std::size_t start = i;
      while (i < text.size() && text[i] != ' ' && text[i] != '\t' && text[i] != '\r') ++i;
      if (i > start) fields_.emplace_back(text, start, i - start);
    }
  }
  std::size_t size() const { return fields_.size(); }
  const std::string& operator[](std::size_t i) const { return fields_[i]; }

  [[noreturn]] void Fail(const std::string& what) const {
    throw ParseError(path_ + ":" + std::to_string(line_) + ": " + fields_[0] + ": " + what);
  }
  void NeedCount(std::size_t n, const std::string& layout) const {
    if (fields_.size() != n) {
      Fail("expected " + std::to_string(n) + " fields (" + layout + "), found " + std::to_string(fields_.size()));
    }
  }
  void NeedAtLeast(std::size_t n, const std::string& layout) const {
    if (fields_.size() < n) {
      Fail("expected at least " + std::to_string(n) + " fields (" + layout + "), found " +
           std::to_string(fields_.size()));
    }
  }
  double Number(std::size_t i, const char* name) const {
    const std::string& s = fields_[i];
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0') Fail(Where(i, name) + " " + QuoteToken(s) + " is not a number");
    if (!std::isfinite(v)) Fail(Where(i, name) + " " + QuoteToken(s) + " is not finite");
    return v;
  }
  long Count(std::size_t i, const char* name, long max) const {
    const std::string& s = fields_[i];
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(s.c_str(), &end, 10);
    if (end == s.c_str() || *end != '\0' || errno == ERANGE)
      Fail(Where(i, name) + " " + QuoteToken(s) + " is not an integer");
    if (v < 0 || v > max) Fail(Where(i, name) + " " + s + " is outside [0, " + std::to_string(max) + "]");
    return v;
  }
  static std::string Where(std::size_t i, const char* name) { return "field " + std::to_string(i) + " (" + name + ")"; }

 private:
  std::string path_;
  long line_;
  std::vector<std::string> fields_;
};

constexpr long kMaxBeams = 1 << 20;

// CARMEN message names: a capital letter, then capitals, digits, '_' or '-' (FLASER, NMEA-GGA).
bool MessageName(const std::string& s) {
  if (s.empty() || s[0] < 'A' || s[0] > 'Z') return false;
  for (char c : s) {
    if (!((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-')) return false;
  }
  return true;
}

// The ranges in fields [first, first + n), each finite and not negative.
std::vector<float> Ranges(const Fields& f, std::size_t first, std::size_t n) {
  std::vector<float> r(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::string name = "range " + std::to_string(k);
    const double v = f.Number(first + k, name.c_str());
    if (v < 0) f.Fail(Fields::Where(first + k, name.c_str()) + " " + f[first + k] + " is negative");
    // Beyond float's range: no return (any range above the maximum is one).
    r[k] = v > std::numeric_limits<float>::max() ? std::numeric_limits<float>::infinity() : static_cast<float>(v);
  }
  return r;
}

SE2<double> Pose(const Fields& f, std::size_t first, const char* x, const char* y, const char* theta) {
  const double px = f.Number(first, x), py = f.Number(first + 1, y), pt = f.Number(first + 2, theta);
  const std::string why = PoseProblem(px, py, pt);
  if (!why.empty())
    f.Fail("fields " + std::to_string(first) + "-" + std::to_string(first + 2) + " (" + x + " " + y + " " + theta +
           "): " + why);
  return SE2<double>(px, py, pt);
}

double Stamp(const Fields& f, std::size_t i, const char* name) {
  const double v = f.Number(i, name);
  const std::string why = StampProblem(v);
  if (!why.empty()) f.Fail(Fields::Where(i, name) + ": " + why);
  return v;
}

// Refuses a scan whose geometry or values cannot be used (ScanProblem), naming the line.
void CheckScan(const Fields& f, const LaserScan& s) {
  const std::string why = ScanProblem(s);
  if (!why.empty()) f.Fail(why);
}

void ParseOdom(const Fields& f, LidarLog* log) {
  f.NeedCount(10, "ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp");
  const SE2<double> pose = Pose(f, 1, "x", "y", "theta");
  for (std::size_t i = 4; i <= 6; ++i) f.Number(i, i == 4 ? "tv" : i == 5 ? "rv" : "accel");
  log->odometry.Add(Stamp(f, 7, "ipc_timestamp"), pose);
  Stamp(f, 9, "logger_timestamp");
}

void ParseFlaser(const Fields& f, long line, const LidarReadOptions& o, LidarLog* log) {
  const char* layout = "FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp";
  f.NeedAtLeast(2, layout);
  const std::size_t n = static_cast<std::size_t>(f.Count(1, "number of readings", kMaxBeams));
  if (n < 2) f.Fail("a scan needs at least 2 readings, the line says " + f[1]);
  f.NeedCount(n + 11, layout);
  LaserScan s;
  s.ranges = Ranges(f, 2, n);
  const SE2<double> laser = Pose(f, n + 2, "x", "y", "theta");
  s.odometry = Pose(f, n + 5, "odom_x", "odom_y", "odom_theta");
  s.odometry_origin = OdometryOrigin::kScanLine;
  s.laser_in_robot = s.odometry.Inverse() * laser;
  s.stamp = Stamp(f, n + 8, "ipc_timestamp");
  s.logger_stamp = Stamp(f, n + 10, "logger_timestamp");
  s.angle_min = -o.flaser_fov / 2;
  s.angle_increment = o.flaser_fov / static_cast<double>(n - 1);
  s.range_min = 0;
  s.range_max = o.flaser_max_range;
  s.source_index = line;
  CheckScan(f, s);
  log->scans.push_back(std::move(s));
}

// The fields ROBOTLASER1 and RAWLASER1 share: laser_type start_angle fov angular_resolution
// max_range accuracy remission_mode n r1..rn m e1..em. Checks the line has exactly
// `tail` fields after the remissions; returns the index of the first of them.
std::size_t ParseLaserFields(const Fields& f, const char* layout, std::size_t tail, LaserScan* s) {
  f.NeedAtLeast(9, layout);
  f.Count(1, "laser_type", 1000);
  s->angle_min = f.Number(2, "start_angle");
  const double fov = f.Number(3, "field_of_view");
  s->angle_increment = f.Number(4, "angular_resolution");
  s->range_max = f.Number(5, "maximum_range");
  f.Number(6, "accuracy");
  f.Count(7, "remission_mode", 1000);
  const std::size_t n = static_cast<std::size_t>(f.Count(8, "number of readings", kMaxBeams));
  if (n < 2) f.Fail("a scan needs at least 2 readings, the line says " + f[8]);
  if (!(s->angle_increment > 0)) f.Fail(Fields::Where(4, "angular_resolution") + " must be positive");
  if (!(s->range_max > 0)) f.Fail(Fields::Where(5, "maximum_range") + " must be positive");
  if (!(fov > 0)) f.Fail(Fields::Where(3, "field_of_view") + " must be positive");
  // Writers give the field of view as (n - 1) or n steps; anything else is another scan's.
  const double span = static_cast<double>(n - 1) * s->angle_increment;
  if (std::abs(fov - span) > 1.5 * s->angle_increment + 1e-3) {
    f.Fail(Fields::Where(3, "field_of_view") + " " + f[3] + " rad does not match " + std::to_string(n) + " readings " +
           f[4] + " rad apart (they span " + FormatDouble(span) + " rad)");
  }
  f.NeedAtLeast(n + 10, layout);
  const std::size_t m = static_cast<std::size_t>(f.Count(n + 9, "number of remissions", kMaxBeams));
  f.NeedCount(n + m + 10 + tail, layout);
  s->ranges = Ranges(f, 9, n);
  for (std::size_t k = 0; k < m; ++k) f.Number(n + 10 + k, "remission");
  s->range_min = 0;
  return n + m + 10;
}

void ParseRobotLaser1(const Fields& f, long line, LidarLog* log) {
  const char* layout =
      "ROBOTLASER1 laser_type start_angle fov angular_resolution max_range accuracy remission_mode n r1..rn m "
      "e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety_dist side_safety_dist "
      "turn_axis ipc_timestamp host logger_timestamp";
  LaserScan s;
  const std::size_t p = ParseLaserFields(f, layout, 14, &s);
  const SE2<double> laser = Pose(f, p, "laser_x", "laser_y", "laser_theta");
  s.odometry = Pose(f, p + 3, "robot_x", "robot_y", "robot_theta");
  s.odometry_origin = OdometryOrigin::kScanLine;
  s.laser_in_robot = s.odometry.Inverse() * laser;
  const char* names[] = {"tv", "rv", "forward_safety_dist", "side_safety_dist", "turn_axis"};
  for (std::size_t k = 0; k < 5; ++k) f.Number(p + 6 + k, names[k]);
  s.stamp = Stamp(f, p + 11, "ipc_timestamp");
  s.logger_stamp = Stamp(f, p + 13, "logger_timestamp");
  s.source_index = line;
  CheckScan(f, s);
  log->scans.push_back(std::move(s));
}

// The laser alone: no pose on the line (odometry from ODOM lines, if any) and the laser at the
// robot's origin.
void ParseRawLaser1(const Fields& f, long line, LidarLog* log) {
  const char* layout =
      "RAWLASER1 laser_type start_angle fov angular_resolution max_range accuracy remission_mode n r1..rn m "
      "e1..em ipc_timestamp host logger_timestamp";
  LaserScan s;
  const std::size_t p = ParseLaserFields(f, layout, 3, &s);
  s.odometry_origin = OdometryOrigin::kNone;
  s.stamp = Stamp(f, p, "ipc_timestamp");
  s.logger_stamp = Stamp(f, p + 2, "logger_timestamp");
  s.source_index = line;
  CheckScan(f, s);
  log->scans.push_back(std::move(s));
}

}  // namespace

LidarLog ReadCarmenLog(const std::string& path, const LidarReadOptions& options) {
  CheckReadOptions(options);
  LidarLog log;
  log.path = path;
  log.format = LogFormat::kCarmen;
  GzLines lines(path);
  std::string text;
  while (lines.Next(&text)) {
    const Fields f(path, lines.line(), text);
    if (f.size() == 0 || f[0][0] == '#') continue;
    if (!MessageName(f[0])) {
      throw ParseError(path + ":" + std::to_string(lines.line()) +
                       ": not a CARMEN message (a line starts with a name in capitals such as ODOM or FLASER, or #); "
                       "is this a CARMEN log?");
    }
    if (f[0] == "ODOM") {
      ParseOdom(f, &log);
    } else if (f[0] == "FLASER") {
      ParseFlaser(f, lines.line(), options, &log);
    } else if (f[0] == "ROBOTLASER1") {
      ParseRobotLaser1(f, lines.line(), &log);
    } else if (f[0] == "RAWLASER1") {
      ParseRawLaser1(f, lines.line(), &log);
    }
  }
  if (log.scans.empty()) {
    throw ParseError(path + ": no FLASER, ROBOTLASER1 or RAWLASER1 line in " + std::to_string(lines.line()) +
                     " lines: not a laser log");
  }
  FinishLog(options, &log);
  return log;
}

}  // namespace lidar
}  // namespace tether
