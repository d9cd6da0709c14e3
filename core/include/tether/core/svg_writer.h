#pragma once
// Pieces shared by the SVG pictures (svg_plot.cc: trajectories; the tools' latency and filter
// plots): numbers on a 0.01 pixel grid written without the locale, text escaped
// for XML, compact path data, and writing a file through a temporary name.
#include <string>

namespace tether {
namespace svg {

/// Appends v / 100 in decimal with up to two decimals, trailing zeros dropped: 1250 -> "12.5".
void AppendHundredths(long long v, std::string* out);

/// v * 100 rounded to the nearest whole number.
long long ToHundredths(double v);

/// A number for an attribute, rounded to 0.01 (locale-independent).
std::string Num(double v);

/// `s` with &, <, >, " and ' replaced by their XML entities.
std::string Escape(const std::string& s);

/// The largest of 1, 2, 5 times a power of ten not above `v` (v > 0).
double NiceLength(double v);

/// `v` in the classic locale with at most `digits` significant digits ("%g" style).
std::string Label(double v, int digits = 3);

struct Pt {
  double x = 0.0, y = 0.0;
};

/// SVG path data in relative commands on a 0.01 pixel grid. Deltas are taken between rounded
/// points, so rounding never accumulates; command letters are left out where SVG implies them.
class PathData {
 public:
  void MoveTo(const Pt& p);
  void LineTo(const Pt& p);
  void Close();
  bool empty() const { return out_.empty(); }
  const std::string& str() const { return out_; }

 private:
  void Command(char c, long long a, long long b);

  std::string out_;
  bool started_ = false;
  char implicit_ = 0;  // the command a coordinate pair without a letter would continue
  long long cx_ = 0, cy_ = 0, sx_ = 0, sy_ = 0;
};

}  // namespace svg
}  // namespace tether
