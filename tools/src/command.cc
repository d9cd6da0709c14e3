#include "tether/tools/command.h"

#include <cctype>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/tools/commands.h"

namespace tether {

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
  for (const auto& [field, flag] : fields) {
    const std::string name = field;
    for (std::size_t at = why.find(name); at != std::string::npos; at = why.find(name, at + 1)) {
      const std::size_t end = at + name.size();
      const auto word = [&why](std::size_t i) {
        return std::isalnum(static_cast<unsigned char>(why[i])) || why[i] == '_';
      };
      if ((at > 0 && word(at - 1)) || (end < why.size() && word(end))) continue;
      const std::string shown = " (" + std::string(flag) + ")";
      why.insert(end, shown);
      at = end + shown.size() - 1;
    }
  }
  return why;
}

}  // namespace tether
