#include "tether/core/svg_writer.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <locale>
#include <sstream>

#include "tether/core/error.h"

namespace tether {
namespace svg {

void AppendHundredths(long long v, std::string* out) {
  if (v < 0) {
    out->push_back('-');
    v = -v;
  }
  out->append(std::to_string(v / 100));
  const int frac = static_cast<int>(v % 100);
  if (frac != 0) {
    out->push_back('.');
    out->push_back(static_cast<char>('0' + frac / 10));
    if (frac % 10 != 0) out->push_back(static_cast<char>('0' + frac % 10));
  }
}

long long ToHundredths(double v) { return std::llround(v * 100.0); }

std::string Num(double v) {
  std::string s;
  AppendHundredths(ToHundredths(v), &s);
  return s;
}

std::string Escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

double NiceLength(double v) {
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= v) return m * p;
  return p;
}

std::string Label(double v, int digits) {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s.precision(digits);
  s << v;
  return s.str();
}

void PathData::MoveTo(const Pt& p) {
  const long long x = ToHundredths(p.x), y = ToHundredths(p.y);
  if (!started_) {
    Command('M', x, y);
    implicit_ = 'L';
    started_ = true;
  } else {
    Command('m', x - cx_, y - cy_);
    implicit_ = 'l';
  }
  cx_ = sx_ = x;
  cy_ = sy_ = y;
}

void PathData::LineTo(const Pt& p) {
  const long long x = ToHundredths(p.x), y = ToHundredths(p.y);
  Command('l', x - cx_, y - cy_);
  implicit_ = 'l';
  cx_ = x;
  cy_ = y;
}

void PathData::Close() {
  out_.push_back('z');
  implicit_ = 0;
  cx_ = sx_;
  cy_ = sy_;
}

void PathData::Command(char c, long long a, long long b) {
  if (c == implicit_) {
    if (a >= 0) out_.push_back(' ');  // a minus sign separates by itself
  } else {
    out_.push_back(c);
  }
  AppendHundredths(a, &out_);
  if (b >= 0) out_.push_back(' ');
  AppendHundredths(b, &out_);
}

}  // namespace svg
}  // namespace tether
