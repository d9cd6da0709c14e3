#pragma once
// Errors thrown by tether. Every message says what was wrong, where, and what to do.
#include <stdexcept>
#include <string>

namespace tether {

/// Base class of every exception tether throws.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// A file (or stream) could not be read: the message starts with "file:line:".
class ParseError : public Error {
 public:
  using Error::Error;
};

/// An argument or option was invalid (bad key, wrong type, inconsistent options).
class InvalidArgument : public Error {
 public:
  using Error::Error;
};

/// Input/output failure (cannot open, cannot write, cannot rename).
class IoError : public Error {
 public:
  using Error::Error;
};

}  // namespace tether
