#include "tether/core/linear_solver.h"

#include <cmath>

#include "tether/core/error.h"

namespace tether {

bool LinearSolverOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_reuse_iterations < 0) return fail("linear.max_reuse_iterations must be >= 0");
  if (!(iterative_tolerance > 0) || !(iterative_tolerance < 1)) {
    return fail("linear.iterative_tolerance must be in (0, 1)");
  }
  if (iterative_max_iterations < 0) return fail("linear.iterative_max_iterations must be >= 0");
  return true;
}

LinearSolverRegistry::LinearSolverRegistry(const LinearSolverRegistry& other) {
  std::lock_guard<std::mutex> lock(other.mutex_);
  by_name_ = other.by_name_;
}

LinearSolverRegistry& LinearSolverRegistry::operator=(const LinearSolverRegistry& other) {
  if (this != &other) {
    std::map<std::string, LinearSolverEntry> copy;
    {
      std::lock_guard<std::mutex> lock(other.mutex_);
      copy = other.by_name_;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    by_name_ = std::move(copy);
  }
  return *this;
}

void LinearSolverRegistry::Register(LinearSolverEntry entry) {
  const std::string who = "'" + entry.name + "' (owner '" + entry.owner + "')";
  if (entry.name.empty()) throw InvalidArgument("cannot register a linear solver without a name; give it one");
  if (!entry.make) throw InvalidArgument("cannot register linear solver " + who + ": it has no factory (`make`)");
  std::lock_guard<std::mutex> lock(mutex_);
  const auto taken = by_name_.find(entry.name);
  if (taken != by_name_.end()) {
    throw InvalidArgument("cannot register linear solver " + who + ": the name is taken already by '" +
                          taken->second.name + "' (owner '" + taken->second.owner + "'); choose another name");
  }
  const std::string name = entry.name;
  by_name_.emplace(name, std::move(entry));
}

bool LinearSolverRegistry::Remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  return by_name_.erase(name) > 0;
}

int LinearSolverRegistry::RemoveOwner(const std::string& owner) {
  std::lock_guard<std::mutex> lock(mutex_);
  int removed = 0;
  for (auto it = by_name_.begin(); it != by_name_.end();) {
    if (it->second.owner == owner) {
      it = by_name_.erase(it);
      ++removed;
    } else {
      ++it;
    }
  }
  return removed;
}

const LinearSolverEntry* LinearSolverRegistry::Find(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : &it->second;
}

bool LinearSolverRegistry::Get(const std::string& name, LinearSolverEntry* out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = by_name_.find(name);
  if (it == by_name_.end()) return false;
  *out = it->second;
  return true;
}

std::vector<std::string> LinearSolverRegistry::Names() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> names;
  for (const auto& kv : by_name_) names.push_back(kv.first);
  return names;
}

LinearSolverRegistry& DefaultLinearSolverRegistry() {
  static LinearSolverRegistry registry;
  return registry;
}

}  // namespace tether
