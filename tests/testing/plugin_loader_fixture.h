#pragma once
// Shared test helper: the plugin loader's fixture, for tests/plugins/loader_test.cc and for
// tests/solvers/loader_builtins_test.cc (whose registry holds the built-in factor types too):
// a fresh registry and loader per test, a scratch folder, TETHER_PLUGIN_PATH and the working
// directory put back after each test, and Refused(), which checks that a refused load changed
// nothing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>

#include "tether/core/registry.h"
#include "tether/plugins/plugin_loader.h"

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "expected \"" << (part) << "\" in:\n" << (text)

namespace tether {
namespace testing {

namespace fs = std::filesystem;

// A test plugin built by tests/plugins/CMakeLists.txt: test_<name>.so.
inline std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}

inline std::string Canonical(const fs::path& p) { return fs::canonical(p).string(); }

// Tags of every test plugin, and a few built-in ones: Snapshot records what each finds.
inline const char* const kTags[] = {"EDGE_SE2",
                                    "EDGE_SE3:QUAT",
                                    "EDGE_SE2_XY",
                                    "EDGE_PRIOR_SE2",
                                    "TEST_GOOD_PRIOR",
                                    "TEST_GOOD_TWIN_PRIOR",
                                    "TEST_WRONG_INTERFACE_PRIOR",
                                    "TEST_UNNAMED_PRIOR",
                                    "TEST_FINGERPRINT_PRIOR",
                                    "TEST_THROWS_STD_PRIOR",
                                    "TEST_THROWS_NON_STD_PRIOR",
                                    "TEST_INCOMPLETE_FIRST_PRIOR",
                                    "TEST_INCOMPLETE_SECOND_PRIOR",
                                    "TEST_DUP_BUILTIN_OK_PRIOR",
                                    "TEST_SHARED_TAG"};

// Everything observable about a registry: each type with its tag, owner and shape, and what
// each known tag finds.
inline std::string Snapshot(const Registry& r) {
  std::ostringstream s;
  for (const auto& [name, t] : r.types()) {
    s << name << " tag=" << t.tag << " owner=" << t.owner << " dim=" << t.dim << " m=" << t.measurement_size
      << " vars=";
    for (VarType v : t.variable_types) s << ToString(v) << ",";
    s << "\n";
  }
  for (const char* tag : kTags) {
    const FactorType* t = r.FindByTag(tag);
    s << tag << " -> " << (t ? t->name : "(none)") << "\n";
  }
  return s.str();
}

inline bool SameLoadedPlugin(const LoadedPlugin& a, const LoadedPlugin& b) {
  return a.name == b.name && a.version == b.version && a.path == b.path && a.type_names == b.type_names;
}

// Restores TETHER_PLUGIN_PATH and the working directory when a test ends.
class EnvironmentGuard {
 public:
  EnvironmentGuard() : cwd_(fs::current_path()) {
    if (const char* v = std::getenv("TETHER_PLUGIN_PATH")) saved_ = std::string(v);
  }
  ~EnvironmentGuard() {
    if (saved_) {
      setenv("TETHER_PLUGIN_PATH", saved_->c_str(), 1);
    } else {
      unsetenv("TETHER_PLUGIN_PATH");
    }
    std::error_code ec;
    fs::current_path(cwd_, ec);
  }

 private:
  fs::path cwd_;
  std::optional<std::string> saved_;
};

// A fresh registry (empty: a test that needs the built-in factor types registers them) and a
// loader for it, a scratch folder dir_, and TETHER_PLUGIN_PATH unset.
class LoaderFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    unsetenv("TETHER_PLUGIN_PATH");
    dir_ = fs::temp_directory_path() / ("tether_loader_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::current_path(fs::temp_directory_path(), ec);  // leave dir_ before removing it
    fs::remove_all(dir_, ec);
  }

  // Loads `path_or_name` expecting a PluginError; checks that neither the registry nor the
  // list of loaded plugins changed, and returns the message.
  std::string Refused(const std::string& path_or_name) {
    const std::string before = Snapshot(registry_);
    const std::size_t loaded_before = loader_.loaded().size();
    std::string message;
    try {
      const LoadedPlugin p = loader_.Load(path_or_name);
      ADD_FAILURE() << path_or_name << " was loaded as '" << p.name << "'; expected a PluginError";
    } catch (const PluginError& e) {
      message = e.what();
    }
    EXPECT_EQ(Snapshot(registry_), before) << "the registry changed although " << path_or_name << " was refused";
    EXPECT_EQ(loader_.loaded().size(), loaded_before);
    return message;
  }

  // A copy of a test plugin at dir_/<to> (a distinct file, not a link).
  fs::path CopyOf(const std::string& plugin, const fs::path& to) {
    const fs::path target = dir_ / to;
    fs::create_directories(target.parent_path());
    fs::copy_file(TestPlugin(plugin), target, fs::copy_options::overwrite_existing);
    return target;
  }

  EnvironmentGuard env_;  // first member: saves the environment before SetUp changes it
  Registry registry_;
  PluginLoader loader_{registry_};
  fs::path dir_;
};

}  // namespace testing
}  // namespace tether
