#pragma once
// Fields: the whitespace-separated fields of one line of an input file, with number
// parsing (std::from_chars) that reports errors as "file:line: ..." ParseErrors.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "tether/core/error.h"

namespace tether {

/// A token from a file as a message shows it: at most `max_bytes` of it (then "..." and its
/// length), with control bytes, backslashes, quotes and bytes outside printable ASCII written
/// as \xNN, so a binary file or a 10 MB token gives a short, readable line.
std::string QuoteToken(std::string_view token, std::size_t max_bytes = 40);

class Fields {
 public:
  /// Splits `line` at spaces and tabs. fields()[0] is the tag.
  Fields(std::string_view file, long line_number, std::string_view line);
  /// Splits another line of the same file, reusing the storage (a reader that keeps one
  /// Fields for all lines allocates nothing per line).
  void Reset(long line_number, std::string_view line);

  std::size_t size() const { return fields_.size(); }
  std::string_view operator[](std::size_t i) const { return fields_[i]; }
  std::string_view tag() const { return fields_.empty() ? std::string_view() : fields_[0]; }
  std::string_view file() const { return file_; }
  long line_number() const { return line_; }

  /// Throws unless the line has exactly n fields after the tag ("too few"/"too many").
  void ExpectCount(std::size_t n_after_tag, std::string_view layout) const;
  /// Field i as a finite double; throws naming the field when it is not a number, NaN or inf.
  double Double(std::size_t i) const;
  /// Field i as a non-negative integer id.
  std::uint64_t Id(std::size_t i) const;
  /// "file:line: " prefix for messages.
  std::string Where() const;
  [[noreturn]] void Fail(const std::string& message) const;

 private:
  std::string_view file_;
  long line_;
  std::vector<std::string_view> fields_;
};

}  // namespace tether
