#include "tether/tools/command.h"

#include <cctype>
#include <chrono>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/timing.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/tools/commands.h"

namespace tether {

namespace {
struct ProcessClock {
  bool marked = false;
  double startup = -1;
  std::chrono::steady_clock::time_point main_entered;
};
ProcessClock& TheProcessClock() {
  static ProcessClock clock;
  return clock;
}
}  // namespace

void MarkMainEntered() {
  ProcessClock& c = TheProcessClock();
  c.startup = ThreadCpuSeconds();
  c.main_entered = std::chrono::steady_clock::now();
  c.marked = true;
}

double StartupSeconds() { return TheProcessClock().startup; }

double SecondsSinceMain() {
  const ProcessClock& c = TheProcessClock();
  return c.marked ? SecondsSince(c.main_entered) : 0;
}

CLI::Option* Command::AddPath(CLI::App* app, const std::string& flags, std::string* path, const std::string& help) {
  CLI::Option* o = app->add_option(flags, *path, help);
  paths_.emplace_back(o, path);
  return o;
}

int Command::CheckPaths(std::ostream& err) const {
  for (const auto& [o, path] : paths_) {
    if (o->count() == 0 || !path->empty()) continue;
    // The shortest of the option's names, as a user types it ("-o" rather than "--output").
    const std::string shown = !o->get_snames().empty() ? "-" + o->get_snames().front() : "--" + o->get_lnames().front();
    err << "tether " << app_->get_name() << ": " << shown
        << " was given an empty path (an unset shell variable?); give a file name\n";
    return kExitUsage;
  }
  return kExitOk;
}

int CheckOutputs(const std::string& command, OutputSet& set, const std::function<void()>& add, std::ostream& err) {
  try {
    add();
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  } catch (const Error& e) {
    err << "tether " << command << ": " << e.what() << "\n";
    return kExitUsage;
  }
  for (const std::string& note : set.Notes()) err << "note: " << note << "\n";
  return 0;
}

bool LoadPlugins(const std::vector<std::string>& plugins, PluginLoader* loader, std::ostream& out, std::ostream& err) {
  for (const std::string& p : plugins) {
    try {
      const LoadedPlugin l = loader->Load(p);
      out << l.Summary() << "\n";
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return false;
    }
  }
  return true;
}

}  // namespace tether

namespace tether {

std::string WithFlags(std::string why, const std::vector<FieldFlag>& fields) {
  for (const auto& [name, flag] : fields) {
    const std::string shown = " (" + flag + ")";
    for (std::size_t at = why.find(name); at != std::string::npos; at = why.find(name, at + 1)) {
      const std::size_t end = at + name.size();
      const auto word = [&why](std::size_t i) {
        // A flag's dashes join its words too: "hops" in "--local-hops" is no field.
        return std::isalnum(static_cast<unsigned char>(why[i])) || why[i] == '_' || why[i] == '-';
      };
      if ((at > 0 && word(at - 1)) || (end < why.size() && word(end))) continue;
      // Nor in a path or a file name: data/ground_truth.g2o names no field.
      if ((at > 0 && why[at - 1] == '/') || (end + 1 < why.size() && why[end] == '.' && word(end + 1))) continue;
      if (why.compare(end, shown.size(), shown) == 0) continue;  // named already
      why.insert(end, shown);
      at = end + shown.size() - 1;
    }
  }
  return why;
}

std::vector<FieldFlag> FieldFlagsOf(const CLI::App& sub) {
  std::vector<FieldFlag> fields;
  for (const CLI::Option* o : sub.get_options()) {
    for (const std::string& name : o->get_lnames()) {
      if (name.find('-') == std::string::npos) continue;
      std::string field = name;
      for (char& c : field) c = c == '-' ? '_' : c;
      fields.emplace_back(field, "--" + name);
    }
  }
  return fields;
}

FlagNamingStream::FlagNamingStream(std::ostream& to, std::vector<FieldFlag> fields)
    : std::ostream(nullptr), buffer_(to, std::move(fields)) {
  rdbuf(&buffer_);
}

FlagNamingStream::~FlagNamingStream() { buffer_.Flush(); }

void FlagNamingStream::Buffer::Flush() {
  if (!line_.empty()) to_ << WithFlags(std::move(line_), fields_);
  line_.clear();
  to_.flush();
}

FlagNamingStream::Buffer::int_type FlagNamingStream::Buffer::overflow(int_type c) {
  if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
  line_.push_back(traits_type::to_char_type(c));
  if (line_.back() == '\n') {
    to_ << WithFlags(std::move(line_), fields_);
    line_.clear();
  }
  return c;
}

int FlagNamingStream::Buffer::sync() {
  // A flush mid-line waits for the line's end, so a field is never cut from its flag.
  to_.flush();
  return 0;
}

}  // namespace tether
