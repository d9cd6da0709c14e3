#include "tether/frontends/lidar/sensor/body_mask.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "tether/core/registry.h"

namespace tether {
namespace lidar {

namespace {

constexpr double kTurn = 2 * M_PI;

// `a` in [0, 2 pi).
double Positive(double a) {
  double r = std::fmod(a, kTurn);
  if (r < 0) r += kTurn;
  return r >= kTurn ? 0 : r;
}

// Degrees for messages, rounded to 1e-9 (so that 160 degrees read and shown is "160").
std::string Degrees(double radians) { return FormatDouble(std::round(radians * 180 / M_PI * 1e9) / 1e9); }

// The sector's width counter-clockwise, in [0, 2 pi).
double Width(const AngleSector& s) { return Positive(s.to - s.from); }

bool Fail(std::string* why, const std::string& what) {
  if (why != nullptr) *why = what;
  return false;
}

}  // namespace

bool AngleSector::Contains(double angle) const {
  // Half a microradian of slack: beams written on a sector's edge in degrees stay in it.
  constexpr double kSlack = 5e-7;
  const double offset = Positive(angle - from);
  return offset <= Width(*this) + kSlack || offset >= kTurn - kSlack;
}

bool BodyMask::IsValid(std::string* why) const {
  if (!(std::isfinite(min_range) && min_range >= 0 && min_range <= scan_bounds::kMaxRange)) {
    return Fail(why, "the mask's min_range is " + FormatDouble(min_range) +
                         " m; it must be finite, not negative and "
                         "at most " +
                         FormatDouble(scan_bounds::kMaxRange) + " m");
  }
  for (const AngleSector& s : sectors) {
    if (!std::isfinite(s.from) || !std::isfinite(s.to)) return Fail(why, "a mask sector's ends must be finite");
    if (Width(s) <= 0) {
      return Fail(why, "the mask sector " + FormatAngleSectors({s}) + " (degrees) has no width");
    }
  }
  return true;
}

std::size_t ApplyBodyMask(const BodyMask& mask, LaserScan* scan) {
  if (mask.empty()) return 0;
  std::size_t masked = 0;
  for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
    if (!scan->Valid(i)) continue;
    bool hit = scan->ranges[i] < mask.min_range;
    const double angle = scan->Angle(i);
    for (std::size_t k = 0; !hit && k < mask.sectors.size(); ++k) hit = mask.sectors[k].Contains(angle);
    if (!hit) continue;
    scan->ranges[i] = std::numeric_limits<float>::quiet_NaN();
    ++masked;
  }
  return masked;
}

bool ParseAngleSectors(const std::string& text, std::vector<AngleSector>* out, std::string* why) {
  if (text.empty()) return Fail(why, "no sector (expected a:b[,c:d] in degrees)");
  std::vector<AngleSector> sectors;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t comma = text.find(',', begin);
    const std::string part = text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin);
    const std::size_t colon = part.find(':');
    if (colon == std::string::npos || part.find(':', colon + 1) != std::string::npos) {
      return Fail(why, "'" + part + "' is not a sector from:to (degrees, e.g. 160:200)");
    }
    double ends[2];
    const std::string texts[2] = {part.substr(0, colon), part.substr(colon + 1)};
    for (int k = 0; k < 2; ++k) {
      const char* s = texts[k].c_str();
      char* end = nullptr;
      ends[k] = std::strtod(s, &end);
      if (texts[k].empty() || end == s || *end != '\0' || !std::isfinite(ends[k])) {
        return Fail(why, "'" + texts[k] + "' in the sector '" + part + "' is not a finite number of degrees");
      }
    }
    const AngleSector sector{ends[0] * M_PI / 180, ends[1] * M_PI / 180};
    if (Width(sector) <= 0) {
      return Fail(why, "the sector '" + part + "' has no width (from and to are the same direction)");
    }
    sectors.push_back(sector);
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  *out = std::move(sectors);
  return true;
}

std::string FormatAngleSectors(const std::vector<AngleSector>& sectors) {
  std::ostringstream s;
  for (std::size_t i = 0; i < sectors.size(); ++i) {
    s << (i > 0 ? "," : "") << Degrees(sectors[i].from) << ":" << Degrees(sectors[i].to);
  }
  return s.str();
}

}  // namespace lidar
}  // namespace tether
