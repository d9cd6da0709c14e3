#pragma once
// One subcommand of the `tether` program. A command binds its flags straight into the options
// struct of the library call it makes, runs that call and prints its report; tools/main.cc is
// only the table of commands. Adding a command: a file in tools/src/ with a class derived from
// Command and a function tether::MakeNameCommand() returning it, and X(Name) in tools/main.cc's
// table (docs/architecture.md).
#include <CLI/CLI.hpp>
#include <iosfwd>
#include <memory>
#include <ostream>
#include <streambuf>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/enum_names.h"

namespace tether {

/// Exit codes of the `tether` program, the one place they are defined: 0 done; 1 bad input (the
/// message names file:line); 2 bad usage (arguments); 3 the solve failed; 4 an output could not
/// be written (nothing was written); 5 a plugin could not be loaded.
constexpr int kExitOk = 0;
constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;
constexpr int kExitSolveFailed = 3;
constexpr int kExitWriteFailed = 4;
constexpr int kExitPluginFailed = 5;

/// The process's own clock. main() calls MarkMainEntered() first thing; the commands report
/// the whole process's time from it (start-up + time since main).
void MarkMainEntered();
/// CPU seconds the main thread used before main(): exec, the dynamic loader mapping and
/// relocating the shared libraries, and their constructors; -1 where unknown (MarkMainEntered
/// not called, or no thread clock).
double StartupSeconds();
/// Wall seconds since MarkMainEntered (0 where it was not called).
double SecondsSinceMain();

class Command {
 public:
  virtual ~Command() = default;
  /// Adds the subcommand and its flags to `app`, bound to this object's fields.
  virtual void Add(CLI::App& app) = 0;
  /// Runs the command after a parse that selected it; the exit code.
  virtual int Run(std::ostream& out, std::ostream& err) = 0;
  /// True when the parse selected this command.
  bool Selected() const { return app_ != nullptr && app_->parsed(); }
  /// The subcommand (after Add).
  const CLI::App* app() const { return app_; }
  /// After the parse: an output flag given an empty path (`-o "$UNSET"`) is refused, naming the
  /// flag; 0 or kExitUsage.
  int CheckPaths(std::ostream& err) const;

 protected:
  /// Adds an option whose value is a file or folder to write: refused when given empty.
  CLI::Option* AddPath(CLI::App* app, const std::string& flags, std::string* path, const std::string& help);
  /// The subcommand whose parse runs this command (set by Add).
  CLI::App* app_ = nullptr;

 private:
  std::vector<std::pair<const CLI::Option*, const std::string*>> paths_;
};

/// An option that takes one of an enum's names (tether/core/enum_names.h): the names and the
/// default are shown in --help, any other word is refused while parsing (exit 2) with the list.
template <class E, class = IfNamedEnum<E>>
CLI::Option* AddEnumOption(CLI::App* app, const std::string& flags, E* value, const std::string& help) {
  const std::string names = EnumNameList<E>();
  CLI::Option* o = app->add_option_function<std::string>(
      flags,
      [value, names](const std::string& s) {
        if (!FromString(s, value)) throw CLI::ValidationError("'" + s + "' is not one of " + names);
      },
      help);
  o->type_name("NAME")->default_str(ToString(*value))->check(CLI::IsMember(EnumNameVector<E>()));
  return o;
}

/// A field of a library options struct and the flag that sets it.
using FieldFlag = std::pair<std::string, std::string>;
/// `why` (an options struct's IsValid message) with the flag after each field name it mentions
/// as a whole word: "huber_delta must ..." becomes "huber_delta (--huber) must ..." (once: a
/// field already followed by its flag is left as it is).
std::string WithFlags(std::string why, const std::vector<FieldFlag>& fields);
template <std::size_t N>
std::string WithFlags(std::string why, const std::pair<const char*, const char*> (&fields)[N]) {
  return WithFlags(std::move(why), std::vector<FieldFlag>(fields, fields + N));
}
/// The fields a subcommand's flags name by themselves: --local-batch-gap sets local_batch_gap.
/// Flags of two words or more only (a one-word name such as "seed" is too common a word to
/// look for in a message).
std::vector<FieldFlag> FieldFlagsOf(const CLI::App& sub);

/// An output stream that writes each line to `to` with WithFlags(line, fields) applied: the
/// program's error stream, so that a library message naming an option's field names the flag
/// the user typed too. What is left of a line is written when the stream is destroyed.
class FlagNamingStream : public std::ostream {
 public:
  FlagNamingStream(std::ostream& to, std::vector<FieldFlag> fields);
  ~FlagNamingStream() override;

 private:
  class Buffer : public std::streambuf {
   public:
    Buffer(std::ostream& to, std::vector<FieldFlag> fields) : to_(to), fields_(std::move(fields)) {}
    void Flush();

   protected:
    int_type overflow(int_type c) override;
    int sync() override;

   private:
    std::ostream& to_;
    std::vector<FieldFlag> fields_;
    std::string line_;
  };
  Buffer buffer_;
};

}  // namespace tether
