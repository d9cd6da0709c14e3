#include "tether/frontends/lidar/io/rosbag_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/registry.h"

#ifdef TETHER_HAVE_ROSBAG
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/LaserScan.h>
#endif

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

double Yaw(double x, double y, double z, double w) { return std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)); }

std::string MessageWhere(const std::string& path, long index, const std::string& topic) {
  return path + ": message " + std::to_string(index) + " on " + topic + ": ";
}

// /tf_static is a tf2_msgs/TFMessage: a sequence of geometry_msgs/TransformStamped, read here
// without tf2_msgs' headers. Returns the first transform whose child frame is `child`.
bool FindStaticTransform(const rosbag::MessageInstance& m, const std::string& child, SE2<double>* out) {
  std::vector<std::uint8_t> buf(m.size());
  ros::serialization::OStream os(buf.data(), static_cast<std::uint32_t>(buf.size()));
  m.write(os);
  ros::serialization::IStream is(buf.data(), static_cast<std::uint32_t>(buf.size()));
  std::uint32_t n = 0;
  is >> n;
  for (std::uint32_t i = 0; i < n; ++i) {
    geometry_msgs::TransformStamped t;
    ros::serialization::deserialize(is, t);
    if (t.child_frame_id == child || (!child.empty() && child[0] != '/' && t.child_frame_id == "/" + child)) {
      const auto& q = t.transform.rotation;
      *out = SE2<double>(t.transform.translation.x, t.transform.translation.y, Yaw(q.x, q.y, q.z, q.w));
      return true;
    }
  }
  return false;
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
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw ParseError(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
  std::string laser_frame;
  long index = 0;
  try {
    std::vector<std::string> topics = {options.scan_topic, options.odom_topic, "/tf_static"};
    if (!options.imu_topic.empty()) topics.push_back(options.imu_topic);
    rosbag::View view(bag, rosbag::TopicQuery(topics));
    bool scan_topic_seen = false, imu_topic_seen = false;
    for (const rosbag::ConnectionInfo* c : view.getConnections()) {
      if (!options.imu_topic.empty() && c->topic == options.imu_topic) {
        imu_topic_seen = true;
        if (c->datatype != "sensor_msgs/Imu") {
          throw ParseError(path + ": topic " + options.imu_topic + " holds " + c->datatype + ", not sensor_msgs/Imu");
        }
      }
      if (c->topic == options.scan_topic) {
        scan_topic_seen = true;
        if (c->datatype != "sensor_msgs/LaserScan") {
          throw ParseError(path + ": topic " + options.scan_topic + " holds " + c->datatype +
                           ", not sensor_msgs/LaserScan");
        }
      }
      if (c->topic == options.odom_topic && c->datatype != "nav_msgs/Odometry") {
        throw ParseError(path + ": topic " + options.odom_topic + " holds " + c->datatype + ", not nav_msgs/Odometry");
      }
    }
    if (!scan_topic_seen || (!options.imu_topic.empty() && !imu_topic_seen)) {
      std::string have;
      rosbag::View all(bag);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) have += " " + c->topic + " (" + c->datatype + ")";
      const bool scan = !scan_topic_seen;
      throw ParseError(path + ": no topic " + (scan ? options.scan_topic : options.imu_topic) + "; the bag has" +
                       (have.empty() ? " none" : have) + (scan ? "; choose the scan topic" : "; choose the IMU topic"));
    }
    std::vector<std::pair<long, rosbag::MessageInstance>> statics;
    for (const rosbag::MessageInstance& m : view) {
      ++index;
      if (m.getTopic() == options.scan_topic) {
        const sensor_msgs::LaserScan::ConstPtr msg = m.instantiate<sensor_msgs::LaserScan>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a sensor_msgs/LaserScan");
        LaserScan s;
        s.stamp = msg->header.stamp.toSec();
        s.logger_stamp = s.stamp;
        s.angle_min = msg->angle_min;
        s.angle_increment = msg->angle_increment;
        s.range_min = msg->range_min;
        s.range_max = msg->range_max;
        s.ranges = msg->ranges;
        s.source_index = index;
        const std::string why = ScanProblem(s);
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        if (laser_frame.empty()) laser_frame = msg->header.frame_id;
        log.scans.push_back(std::move(s));
      } else if (m.getTopic() == options.odom_topic) {
        const nav_msgs::Odometry::ConstPtr msg = m.instantiate<nav_msgs::Odometry>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a nav_msgs/Odometry");
        const auto& p = msg->pose.pose.position;
        const auto& q = msg->pose.pose.orientation;
        const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !(std::abs(norm - 1) < 0.1)) {
          throw ParseError(MessageWhere(path, index, m.getTopic()) +
                           "non-finite position or a quaternion far from unit length");
        }
        const double yaw = Yaw(q.x, q.y, q.z, q.w);
        std::string why = PoseProblem(p.x, p.y, yaw);
        if (why.empty()) why = StampProblem(msg->header.stamp.toSec());
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        log.odometry.Add(msg->header.stamp.toSec(), SE2<double>(p.x, p.y, yaw));
      } else if (!options.imu_topic.empty() && m.getTopic() == options.imu_topic) {
        const sensor_msgs::Imu::ConstPtr msg = m.instantiate<sensor_msgs::Imu>();
        if (!msg) throw ParseError(MessageWhere(path, index, m.getTopic()) + "not a sensor_msgs/Imu");
        const double stamp = msg->header.stamp.toSec();
        std::string why = StampProblem(stamp);
        // A gyro reads a few rad/s at most; beyond 1000 rad/s a message is damaged.
        if (why.empty() && !(std::abs(msg->angular_velocity.z) <= 1000)) {
          why = "angular_velocity.z " + FormatDouble(msg->angular_velocity.z) + " rad/s is not finite or beyond 1000";
        }
        if (!why.empty()) throw ParseError(MessageWhere(path, index, m.getTopic()) + why);
        log.imu.samples.push_back(ImuSample{stamp, msg->angular_velocity.z});
      } else {
        statics.emplace_back(index, m);
      }
    }
    if (log.scans.empty()) throw ParseError(path + ": no message on " + options.scan_topic + ": not a laser log");
    SE2<double> laser_in_robot;
    for (const auto& [static_index, m] : statics) {
      if (!FindStaticTransform(m, laser_frame, &laser_in_robot)) continue;
      const std::string why = PoseProblem(laser_in_robot.x(), laser_in_robot.y(), laser_in_robot.theta());
      if (!why.empty()) {
        throw ParseError(MessageWhere(path, static_index, m.getTopic()) + "the transform to the laser frame '" +
                         laser_frame + "': " + why);
      }
      break;
    }
    for (LaserScan& s : log.scans) s.laser_in_robot = laser_in_robot;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw ParseError(path + ": reading message " + std::to_string(index) + ": " + e.what());
  }
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
