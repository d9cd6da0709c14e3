#include "tether/core/loss_registry.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "tether/core/error.h"
#include "tether/core/registry.h"
#include "tether/core/robust_kernels.h"

namespace tether {

namespace {

const char kForms[] = "write NAME:SCALE, e.g. huber:1.0, or NAME:SCALE:PARAM for a loss with a parameter";

// The whole of `text` as a number (strtod's forms: 1, -2.5, 1e-3, inf); false where it is empty,
// starts with a blank or has anything after the number.
bool ReadNumber(const std::string& text, double* value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size();
}

std::string Owned(const LossEntry& e) { return "'" + e.name + "' (owner '" + e.owner + "')"; }

bool Builtin(const LossEntry& e) { return e.owner.empty() || e.owner == "builtin"; }

}  // namespace

LossSpec ParseLossSpec(const std::string& spec) {
  const auto fail = [&](const std::string& what) {
    throw InvalidArgument("robust loss '" + spec + "': " + what + " (" + kForms + ")");
  };
  std::vector<std::string> fields;
  for (std::size_t start = 0;;) {
    const std::size_t colon = spec.find(':', start);
    fields.push_back(spec.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  LossSpec s;
  s.name = fields[0];
  if (s.name.empty()) fail("no name before the scale");
  if (fields.size() > 3) fail("too many ':' fields");
  if (fields.size() > 1 && !ReadNumber(fields[1], &s.scale)) fail("the scale '" + fields[1] + "' is not a number");
  if (fields.size() > 2) {
    s.has_parameter = true;
    if (!ReadNumber(fields[2], &s.parameter)) fail("the parameter '" + fields[2] + "' is not a number");
  }
  return s;
}

LossRegistry::LossRegistry(const LossRegistry& other) {
  std::lock_guard<std::mutex> lock(other.mutex_);
  entries_ = other.entries_;
}

LossRegistry& LossRegistry::operator=(const LossRegistry& other) {
  if (this != &other) {
    std::vector<LossEntry> copy;
    {
      std::lock_guard<std::mutex> lock(other.mutex_);
      copy = other.entries_;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    entries_ = std::move(copy);
  }
  return *this;
}

void LossRegistry::Register(LossEntry entry) {
  if (entry.name.empty()) throw InvalidArgument("cannot register a robust loss without a name; give it one");
  const auto refuse = [&](const std::string& what) {
    throw InvalidArgument("cannot register robust loss " + Owned(entry) + ": " + what);
  };
  const bool plain = std::all_of(entry.name.begin(), entry.name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
  if (!plain) refuse("the name may hold only letters, digits, '_' and '-' (it is written NAME:SCALE)");
  if (!entry.make) refuse("it has no factory (`make`)");
  if (!entry.parameter.empty() && std::isnan(entry.default_parameter)) {
    refuse("its default " + entry.parameter + " is NaN; give a number");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  for (const LossEntry& e : entries_) {
    if (e.name != entry.name) continue;
    refuse("the name is taken already by " + Owned(e) + "; choose another name" +
           (Builtin(e) ? " (built-in losses cannot be removed)" : " or unload '" + e.owner + "' first"));
  }
  entries_.push_back(std::move(entry));
}

bool LossRegistry::Remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = std::find_if(entries_.begin(), entries_.end(), [&](const LossEntry& e) { return e.name == name; });
  if (it == entries_.end()) return false;
  entries_.erase(it);
  return true;
}

int LossRegistry::RemoveOwner(const std::string& owner) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto first =
      std::remove_if(entries_.begin(), entries_.end(), [&](const LossEntry& e) { return e.owner == owner; });
  const int removed = static_cast<int>(entries_.end() - first);
  entries_.erase(first, entries_.end());
  return removed;
}

bool LossRegistry::Get(const std::string& name, LossEntry* out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const LossEntry& e : entries_) {
    if (e.name != name) continue;
    if (out != nullptr) *out = e;
    return true;
  }
  return false;
}

std::vector<std::string> LossRegistry::Names() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> names;
  for (const LossEntry& e : entries_) names.push_back(e.name);
  return names;
}

std::vector<LossEntry> LossRegistry::Entries() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_;
}

std::string LossRegistry::NamesText() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string text;
  for (const LossEntry& e : entries_) {
    if (!text.empty()) text += ", ";
    text += e.name;
    std::string notes;
    if (!Builtin(e)) notes = "plugin " + e.owner;
    if (!e.parameter.empty()) {
      std::string upper = e.parameter;
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      notes += (notes.empty() ? "" : "; ") + e.name + ":SCALE:" + upper + ", " + e.parameter + " " +
               FormatDouble(e.default_parameter) + " if omitted";
    }
    if (!notes.empty()) text += " (" + notes + ")";
  }
  return text.empty() ? "none" : text;
}

std::shared_ptr<const LossFunction> LossRegistry::Make(const std::string& spec) const {
  const LossSpec s = ParseLossSpec(spec);
  const std::string where = "robust loss '" + spec + "': ";
  LossEntry e;
  if (!Get(s.name, &e)) {
    throw InvalidArgument(where + "unknown kernel '" + s.name + "' (registered: " + NamesText() +
                          "; a plugin adds more with PluginRegistrar::AddLoss, loaded with --plugin or "
                          "tether.load_plugin; " +
                          kForms + ")");
  }
  if (!(std::isfinite(s.scale) && s.scale > 0)) {
    throw InvalidArgument(where + "the scale of the " + s.name + " loss must be a finite number above 0, not " +
                          FormatDouble(s.scale));
  }
  if (s.has_parameter && e.parameter.empty()) {
    throw InvalidArgument(where + "the " + s.name + " loss takes no parameter after its scale (write " + s.name +
                          ":SCALE)");
  }
  const double parameter = e.parameter.empty() ? 0 : s.has_parameter ? s.parameter : e.default_parameter;
  if (std::isnan(parameter)) {
    throw InvalidArgument(where + "the " + e.parameter + " of the " + s.name + " loss must be a number, not nan");
  }
  std::shared_ptr<const LossFunction> loss;
  try {
    loss = e.make(s.scale, parameter);
  } catch (const InvalidArgument& x) {
    throw InvalidArgument(where + x.what());
  } catch (const std::exception& x) {
    throw InvalidArgument(where + "the loss " + Owned(e) + " failed: " + x.what());
  } catch (...) {
    throw InvalidArgument(where + "the loss " + Owned(e) + " threw something that is not a std::exception");
  }
  if (loss == nullptr) {
    throw InvalidArgument(where + "the factory of the loss " + Owned(e) +
                          " returned no loss; it must return one or throw InvalidArgument");
  }
  return loss;
}

LossRegistry& DefaultLossRegistry() {
  static LossRegistry registry = [] {
    LossRegistry r;
    RegisterBuiltinLosses(r);
    return r;
  }();
  return registry;
}

std::vector<std::string> RegisteredLossNames() { return DefaultLossRegistry().Names(); }

std::string RegisteredLossesText() { return DefaultLossRegistry().NamesText(); }

std::shared_ptr<const LossFunction> MakeLoss(const std::string& spec) { return DefaultLossRegistry().Make(spec); }

std::string LossName(const std::string& name, double scale) { return name + ":" + FormatDouble(scale); }

std::string LossName(const std::string& name, double scale, double parameter) {
  return LossName(name, scale) + ":" + FormatDouble(parameter);
}

}  // namespace tether
