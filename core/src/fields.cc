#include "tether/core/fields.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <system_error>

namespace tether {

namespace {

// One table look-up per character: the split runs over every byte of a file.
struct SeparatorTable {
  bool is[256] = {};
  constexpr SeparatorTable() {
    for (unsigned char c : {' ', '\t', '\r', '\n', '\v', '\f'}) is[c] = true;
  }
};
constexpr SeparatorTable kSeparators;

bool IsSeparator(char c) { return kSeparators.is[static_cast<unsigned char>(c)]; }

}  // namespace

std::string QuoteToken(std::string_view token, std::size_t max_bytes) {
  std::string out = "'";
  const std::size_t shown = std::min(token.size(), max_bytes);
  for (std::size_t i = 0; i < shown; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\' && c != '\'') {
      out.push_back(static_cast<char>(c));
    } else {
      static constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  out.push_back('\'');
  if (shown < token.size()) out += "... (" + std::to_string(token.size()) + " bytes)";
  return out;
}

Fields::Fields(std::string_view file, long line_number, std::string_view line) : file_(file), line_(line_number) {
  Reset(line_number, line);
}

void Fields::Reset(long line_number, std::string_view line) {
  line_ = line_number;
  fields_.clear();
  // Carriage returns (files written on Windows) and other blanks separate fields like spaces.
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && IsSeparator(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !IsSeparator(line[i])) ++i;
    if (i > start) fields_.push_back(line.substr(start, i - start));
  }
}

std::string Fields::Where() const {
  std::string s(file_);
  if (line_ > 0) s += ":" + std::to_string(line_);
  return s + ": ";
}

void Fields::Fail(const std::string& message) const { throw ParseError(Where() + message); }

void Fields::ExpectCount(std::size_t n_after_tag, std::string_view layout) const {
  const std::size_t found = fields_.empty() ? 0 : fields_.size() - 1;
  if (found == n_after_tag) return;
  std::string m = found < n_after_tag ? "too few fields: " : "too many fields: ";
  m += std::string(tag()) + " needs " + std::to_string(n_after_tag) + " after the tag";
  if (!layout.empty()) m += " (" + std::string(layout) + ")";
  m += ", found " + std::to_string(found) + "; fix or remove the line";
  Fail(m);
}

double Fields::Double(std::size_t i) const {
  if (i >= fields_.size()) {
    Fail(std::string(tag()) + " field " + std::to_string(i) + " is missing (the line has " +
         std::to_string(fields_.empty() ? 0 : fields_.size() - 1) + " fields after the tag); fix or remove the line");
  }
  std::string_view s = fields_[i];
  const auto describe = [&] { return std::string(tag()) + " field " + std::to_string(i) + " (" + QuoteToken(s) + ")"; };
  // std::from_chars accepts neither a leading '+' nor leading blanks; tolerate the former.
  std::string_view digits = s;
  if (digits.size() > 1 && digits[0] == '+' && digits[1] != '-' && digits[1] != '+') digits.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (ec == std::errc::result_out_of_range) {
    Fail(describe() +
         " is out of the range of a double (about 2.2e-308 to 1.8e308 in magnitude); fix or remove the line");
  }
  if (ec != std::errc() || end != digits.data() + digits.size()) {
    Fail(describe() + " is not a number; fix or remove the line");
  }
  if (std::isnan(v)) Fail(describe() + " is NaN; every number must be finite, fix or remove the line");
  if (std::isinf(v)) Fail(describe() + " is inf; every number must be finite, fix or remove the line");
  return v;
}

std::uint64_t Fields::Id(std::size_t i) const {
  if (i >= fields_.size()) {
    Fail(std::string(tag()) + " id field " + std::to_string(i) + " is missing (the line has " +
         std::to_string(fields_.empty() ? 0 : fields_.size() - 1) + " fields after the tag); fix or remove the line");
  }
  const std::string_view s = fields_[i];
  const auto describe = [&] { return std::string(tag()) + " field " + std::to_string(i) + " (" + QuoteToken(s) + ")"; };
  if (!s.empty() && s[0] == '-') {
    Fail(describe() + " is a negative id; ids must be integers from 0 to 18446744073709551615, fix the line");
  }
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec == std::errc::result_out_of_range) {
    Fail(describe() + " is too large for an id (at most 18446744073709551615); renumber the ids");
  }
  if (ec != std::errc() || end != s.data() + s.size()) {
    Fail(describe() + " is not an id; ids must be integers from 0 to 18446744073709551615, fix the line");
  }
  return v;
}

}  // namespace tether
