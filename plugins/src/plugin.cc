#include "tether/plugins/plugin.h"

namespace tether {

std::vector<std::string> CompareFingerprints(const BuildFingerprint& t, const BuildFingerprint& p) {
  std::vector<std::string> diffs;
  auto check = [&](const char* field, int a, int b) {
    if (a != b) diffs.push_back(std::string(field) + ": tether " + std::to_string(a) + ", plugin " + std::to_string(b));
  };
  check("tether_major", t.tether_major, p.tether_major);
  check("tether_minor", t.tether_minor, p.tether_minor);
  check("tether_patch", t.tether_patch, p.tether_patch);
  check("eigen_world", t.eigen_world, p.eigen_world);
  check("eigen_major", t.eigen_major, p.eigen_major);
  check("eigen_minor", t.eigen_minor, p.eigen_minor);
  check("eigen_max_align_bytes", t.eigen_max_align_bytes, p.eigen_max_align_bytes);
  check("eigen_max_static_align_bytes", t.eigen_max_static_align_bytes, p.eigen_max_static_align_bytes);
  check("eigen_vectorize", t.eigen_vectorize, p.eigen_vectorize);
  check("eigen_dont_align", t.eigen_dont_align, p.eigen_dont_align);
  check("cxx11_abi", t.cxx11_abi, p.cxx11_abi);
  check("pointer_bytes", t.pointer_bytes, p.pointer_bytes);
  return diffs;
}

void PluginRegistrar::AddVariableType(VariableType type) {
  type.owner = plugin_;
  InternVariableType(type);
  variables_.push_back(std::move(type));
}

void PluginRegistrar::AddFactorType(FactorType type) {
  type.owner = plugin_;
  types_.push_back(std::move(type));
}

void PluginRegistrar::AddLinearSolver(const std::string& name, LinearSolverFactory make) {
  LinearSolverEntry entry;
  entry.name = name;
  entry.make = std::move(make);
  AddLinearSolver(std::move(entry));
}

void PluginRegistrar::AddLinearSolver(LinearSolverEntry entry) {
  entry.owner = plugin_;
  linear_solvers_.push_back(std::move(entry));
}

void PluginRegistrar::AddLoss(LossEntry entry) {
  entry.owner = plugin_;
  losses_.push_back(std::move(entry));
}

void PluginRegistrar::AddLoss(const std::string& name, LossFactory make) {
  LossEntry entry;
  entry.name = name;
  entry.make = std::move(make);
  AddLoss(std::move(entry));
}

}  // namespace tether
