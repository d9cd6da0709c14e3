// The plugin loader against the deliberately broken plugins of tests/plugins/broken: every
// refusal names the file and the problem and leaves the registry exactly as it was. Also the
// search order, repeated loads, the lifetime rule, the fingerprint comparison and the
// registrar.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "testing/plugin_loader_fixture.h"
#include "tether/core/values.h"
#include "tether/plugins/plugin.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {
namespace {

namespace fs = std::filesystem;
using testing::Canonical;
using testing::SameLoadedPlugin;
using testing::Snapshot;
using testing::TestPlugin;

// The registry holds no built-in factor types here (tether::factors is not linked): the tests
// that need them (a plugin claiming EDGE_SE2, ...) are in tests/solvers/loader_builtins_test.cc.
class LoaderTest : public testing::LoaderFixture {};

// ---- loading a good plugin ----

TEST_F(LoaderTest, LoadingTheSameFileAgainIsHarmlessWhateverPathLeadsToIt) {
  const std::string path = TestPlugin("good");
  const LoadedPlugin first = loader_.Load(path);
  const std::string after_first = Snapshot(registry_);

  // The same file through a relative path, a symbolic link, and a bare name on the search path.
  const std::string relative = fs::relative(path, fs::current_path()).string();
  ASSERT_NE(relative, path);
  fs::create_symlink(path, dir_ / "alias.so");
  setenv("TETHER_PLUGIN_PATH", TETHER_TEST_PLUGIN_DIR, 1);
  for (const std::string& again : {path, relative, (dir_ / "alias.so").string(), std::string("test_good.so")}) {
    SCOPED_TRACE(again);
    const LoadedPlugin p = loader_.Load(again);
    EXPECT_TRUE(SameLoadedPlugin(p, first));
    EXPECT_EQ(Snapshot(registry_), after_first);
    EXPECT_EQ(loader_.loaded().size(), 1u);
  }
}

TEST_F(LoaderTest, PluginFactorsOutliveTheLoaderAndTheRegistry) {
  // Lifetime rule: a plugin is never unloaded, so its factors stay usable after everything
  // that loaded it is gone.
  std::unique_ptr<Factor> factor;
  {
    Registry registry;
    PluginLoader loader(registry);
    loader.Load(TestPlugin("good"));
    const double z[2] = {1, 2};
    factor = registry.FindByName("TestGoodPrior")->make({3}, z, SqrtInformation::Identity(2));
  }
  Values values;
  values.Insert(3, Eigen::Vector2d(4, 6));
  EXPECT_DOUBLE_EQ(factor->Chi2(values), 3 * 3 + 4 * 4);
  const std::unique_ptr<Factor> copy = factor->Clone();
  EXPECT_EQ(copy->type_name(), "TestGoodPrior");
  EXPECT_EQ(copy->Measurement(), (std::vector<double>{1, 2}));
}

TEST_F(LoaderTest, RemoveOwnerUnregistersAPluginAndLoadingItAgainRegistersItAgain) {
  const std::string before = Snapshot(registry_);
  const LoadedPlugin first = loader_.Load(TestPlugin("good"));
  EXPECT_EQ(registry_.RemoveOwner("test_good"), 1);
  EXPECT_EQ(Snapshot(registry_), before);
  EXPECT_EQ(registry_.FindByTag("TEST_GOOD_PRIOR"), nullptr);

  const LoadedPlugin again = loader_.Load(TestPlugin("good"));
  EXPECT_TRUE(SameLoadedPlugin(again, first));
  const FactorType* t = registry_.FindByTag("TEST_GOOD_PRIOR");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->owner, "test_good");
  EXPECT_EQ(loader_.loaded().size(), 1u);
}

// ---- refusals: each names the file and what to do, and changes nothing ----

TEST_F(LoaderTest, RefusesAMissingFile) {
  const std::string path = (dir_ / "no_such_plugin.so").string();
  const std::string m = Refused(path);
  EXPECT_CONTAINS(m, "plugin " + path + ": no such file");
  EXPECT_CONTAINS(m, "TETHER_PLUGIN_PATH");
}

TEST_F(LoaderTest, RefusesAFileThatIsNotALibraryWithDlerrorsText) {
  const std::string path = Canonical(TestPlugin("not_a_library"));
  // What the dynamic loader itself says about this file.
  ASSERT_EQ(dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL), nullptr);
  const char* why = dlerror();
  ASSERT_NE(why, nullptr);
  const std::string dl_message = why;

  const std::string m = Refused(path);
  EXPECT_CONTAINS(m, "plugin " + path + ": cannot be loaded as a shared library: ");
  EXPECT_CONTAINS(m, dl_message);
}

TEST_F(LoaderTest, RefusesALibraryWithoutTheEntrySymbolAndNamesIt) {
  const std::string m = Refused(TestPlugin("missing_entry"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("missing_entry")) + ": ");
  EXPECT_CONTAINS(m, "the entry symbol 'tether_plugin_entry' is missing");
  EXPECT_CONTAINS(m, "TETHER_PLUGIN(name, version, register_function)");
}

TEST_F(LoaderTest, RefusesAnEntryThatReturnsNoDescription) {
  const std::string m = Refused(TestPlugin("null_description"));
  EXPECT_CONTAINS(m, Canonical(TestPlugin("null_description")));
  EXPECT_CONTAINS(m, "tether_plugin_entry returned no description");
}

TEST_F(LoaderTest, RefusesAnotherInterfaceVersionStatingBoth) {
  const std::string m = Refused(TestPlugin("wrong_interface"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("wrong_interface")) + ": ");
  EXPECT_CONTAINS(m, "plugin interface version " + std::to_string(TETHER_PLUGIN_INTERFACE_VERSION + 1));
  EXPECT_CONTAINS(m, "this tether speaks version " + std::to_string(TETHER_PLUGIN_INTERFACE_VERSION));
  EXPECT_CONTAINS(m, "rebuild the plugin");
  EXPECT_EQ(registry_.FindByName("TestWrongInterfacePrior"), nullptr);
}

TEST_F(LoaderTest, RefusesAnUnnamedPlugin) {
  const std::string m = Refused(TestPlugin("unnamed"));
  EXPECT_CONTAINS(m, Canonical(TestPlugin("unnamed")));
  EXPECT_CONTAINS(m, "has no name");
}

TEST_F(LoaderTest, RefusesAnotherBuildFingerprintFieldByField) {
  const BuildFingerprint here = CurrentBuildFingerprint();
  const int plugin_align = here.eigen_max_align_bytes == 16 ? 32 : 16;  // as broken/fingerprint_mismatch.cc
  const std::string m = Refused(TestPlugin("fingerprint_mismatch"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("fingerprint_mismatch")) + " ('test_fingerprint_mismatch')");
  EXPECT_CONTAINS(m, "tether_minor: tether " + std::to_string(here.tether_minor) + ", plugin " +
                         std::to_string(here.tether_minor + 1));
  EXPECT_CONTAINS(m, "eigen_max_align_bytes: tether " + std::to_string(here.eigen_max_align_bytes) + ", plugin " +
                         std::to_string(plugin_align));
  EXPECT_CONTAINS(m, "rebuild the plugin with the same tether, Eigen version and compiler flags");
  // Only the two fields that differ are listed.
  std::size_t listed = 0;
  for (std::size_t at = m.find(": tether "); at != std::string::npos; at = m.find(": tether ", at + 1)) ++listed;
  EXPECT_EQ(listed, 2u) << m;
  EXPECT_EQ(registry_.FindByName("TestFingerprintPrior"), nullptr);
}

TEST_F(LoaderTest, RefusesADescriptionWithoutRegistrationFunction) {
  const std::string m = Refused(TestPlugin("no_register_function"));
  EXPECT_CONTAINS(m, Canonical(TestPlugin("no_register_function")) + " ('test_no_register_function')");
  EXPECT_CONTAINS(m, "no registration function");
}

TEST_F(LoaderTest, PassesOnTheMessageOfAThrowingRegistrationAndRegistersNothing) {
  const std::string m = Refused(TestPlugin("throws_std"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("throws_std")) + " ('test_throws_std')");
  EXPECT_CONTAINS(m, "registration failed: test_throws_std cannot find its calibration table");
  EXPECT_CONTAINS(m, "nothing of it was registered");
  // The type it added before throwing is not there.
  EXPECT_EQ(registry_.FindByName("TestThrowsStdPrior"), nullptr);
  EXPECT_EQ(registry_.FindByTag("TEST_THROWS_STD_PRIOR"), nullptr);
  // Trying again fails the same way: a failed load is not remembered as loaded.
  EXPECT_EQ(Refused(TestPlugin("throws_std")), m);
}

TEST_F(LoaderTest, RefusesARegistrationThatThrowsSomethingElse) {
  const std::string m = Refused(TestPlugin("throws_non_std"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("throws_non_std")) + " ('test_throws_non_std')");
  EXPECT_CONTAINS(m, "not a std::exception");
  EXPECT_CONTAINS(m, "nothing of it was registered");
  EXPECT_EQ(registry_.FindByName("TestThrowsNonStdPrior"), nullptr);
}

TEST_F(LoaderTest, RefusesAnIncompleteTypeAndCommitsNoneOfThePlugin) {
  const std::string m = Refused(TestPlugin("incomplete_type"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("incomplete_type")) + " ('test_incomplete_type')");
  EXPECT_CONTAINS(m, "'TestIncompleteSecondPrior' (owner 'test_incomplete_type')");
  EXPECT_CONTAINS(m, "residual dimension is 0");
  EXPECT_EQ(registry_.FindByName("TestIncompleteFirstPrior"), nullptr);
}

TEST_F(LoaderTest, RefusesATagTakenByAnotherPluginNamingBothPlugins) {
  const LoadedPlugin a = loader_.Load(TestPlugin("dup_tag_a"));
  EXPECT_EQ(a.name, "test_dup_a");
  const std::string m = Refused(TestPlugin("dup_tag_b"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("dup_tag_b")) + " ('test_dup_b')");
  EXPECT_CONTAINS(m, "'TestDupB' (owner 'test_dup_b')");
  EXPECT_CONTAINS(m, "the g2o tag 'TEST_SHARED_TAG' is taken already by 'TestDupA' (owner 'test_dup_a')");
  EXPECT_EQ(registry_.FindByTag("TEST_SHARED_TAG")->owner, "test_dup_a");

  // The other way round, in a fresh registry, the roles swap.
  Registry other;
  PluginLoader other_loader(other);
  other_loader.Load(TestPlugin("dup_tag_b"));
  try {
    other_loader.Load(TestPlugin("dup_tag_a"));
    ADD_FAILURE() << "test_dup_a was loaded after test_dup_b";
  } catch (const PluginError& e) {
    EXPECT_CONTAINS(e.what(), "'TestDupA' (owner 'test_dup_a')");
    EXPECT_CONTAINS(e.what(), "taken already by 'TestDupB' (owner 'test_dup_b')");
  }
  EXPECT_EQ(other.FindByTag("TEST_SHARED_TAG")->owner, "test_dup_b");
}

TEST_F(LoaderTest, RefusesASecondPluginOfTheSameNameNamingBothFiles) {
  loader_.Load(TestPlugin("good"));
  const std::string m = Refused(TestPlugin("good_twin"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("good_twin")) +
                         ": a plugin named 'test_good' is loaded already "
                         "from " +
                         Canonical(TestPlugin("good")));
  EXPECT_EQ(registry_.FindByName("TestGoodTwinPrior"), nullptr);

  // A copy of the same library elsewhere is another file with the same name: refused too.
  const fs::path copy = CopyOf("good", "elsewhere/test_good.so");
  EXPECT_CONTAINS(Refused(copy.string()), "a plugin named 'test_good' is loaded already");
}

// ---- search order ----

TEST_F(LoaderTest, SearchPathIsTetherPluginPathThenTheInstalledFolder) {
  const std::vector<std::string> installed_only = PluginLoader::SearchPath();
  ASSERT_EQ(installed_only.size(), 1u);
  const std::string installed = installed_only[0];
  EXPECT_EQ(fs::path(installed).filename(), "plugins");
  EXPECT_EQ(fs::path(installed).parent_path().filename(), "tether");

  // Empty entries are skipped; folders that do not exist are kept (and skipped when searching).
  const std::string a = (dir_ / "a").string(), b = (dir_ / "b").string();
  setenv("TETHER_PLUGIN_PATH", (":" + a + "::/nonexistent/folder:" + b + ":").c_str(), 1);
  EXPECT_EQ(PluginLoader::SearchPath(), (std::vector<std::string>{a, "/nonexistent/folder", b, installed}));
  setenv("TETHER_PLUGIN_PATH", "", 1);
  EXPECT_EQ(PluginLoader::SearchPath(), installed_only);
}

TEST_F(LoaderTest, ExplicitPathComesFirstThenTetherPluginPathInOrder) {
  // probe.so is a different plugin in each place, so the one loaded shows where it came from.
  const fs::path first = CopyOf("dup_tag_a", "first/probe.so");
  const fs::path second = CopyOf("good", "second/probe.so");
  const fs::path here = CopyOf("dup_tag_b", "here/probe.so");
  setenv("TETHER_PLUGIN_PATH",
         (":/nonexistent/folder:" + (dir_ / "first").string() + ":" + (dir_ / "second").string()).c_str(), 1);

  // A bare name: the first folder of TETHER_PLUGIN_PATH that has it.
  EXPECT_EQ(PluginLoader::Resolve("probe.so"), Canonical(first));
  // An explicit path wins over the search path.
  EXPECT_EQ(PluginLoader::Resolve(second.string()), Canonical(second));
  // A name that exists relative to the working directory is an explicit path too.
  fs::current_path(dir_ / "here");
  EXPECT_EQ(PluginLoader::Resolve("probe.so"), Canonical(here));
  EXPECT_EQ(PluginLoader::Resolve("./probe.so"), Canonical(here));
  EXPECT_EQ(PluginLoader::Resolve("../second/probe.so"), Canonical(second));
  fs::current_path(dir_);
  // Not in the first folder: the next one.
  fs::remove(first);
  EXPECT_EQ(PluginLoader::Resolve("probe.so"), Canonical(second));

  // Load follows the same order.
  const LoadedPlugin p = loader_.Load("probe.so");
  EXPECT_EQ(p.name, "test_good");
  EXPECT_EQ(p.path, Canonical(second));
}

TEST_F(LoaderTest, ResolveListsEveryPlaceSearched) {
  const std::string a = (dir_ / "a").string();
  fs::create_directories(a);
  setenv("TETHER_PLUGIN_PATH", (a + "::/nonexistent/folder").c_str(), 1);
  const std::string installed = PluginLoader::SearchPath().back();
  std::string m;
  try {
    PluginLoader::Resolve("no_such_plugin.so");
    ADD_FAILURE() << "no_such_plugin.so was found";
  } catch (const PluginError& e) {
    m = e.what();
  }
  EXPECT_CONTAINS(m, "plugin no_such_plugin.so: no such file (looked in: no_such_plugin.so, " + a +
                         "/no_such_plugin.so, /nonexistent/folder/no_such_plugin.so, " + installed +
                         "/no_such_plugin.so)");
  EXPECT_CONTAINS(m, "give the path of the .so, or add its folder to TETHER_PLUGIN_PATH");
  EXPECT_EQ(Refused("no_such_plugin.so"), m);

  // A path with a folder in it is only looked for where it says.
  const std::string with_folder = Refused("sub/no_such_plugin.so");
  EXPECT_CONTAINS(with_folder, "(looked in: sub/no_such_plugin.so)");
}

// ---- pieces ----

TEST(CompareFingerprintsTest, IdenticalFingerprintsAgree) {
  EXPECT_TRUE(CompareFingerprints(CurrentBuildFingerprint(), CurrentBuildFingerprint()).empty());
}

TEST(CompareFingerprintsTest, CurrentFingerprintDescribesThisBuild) {
  const BuildFingerprint f = CurrentBuildFingerprint();
  EXPECT_EQ(f.tether_major, TETHER_VERSION_MAJOR);
  EXPECT_EQ(f.tether_minor, TETHER_VERSION_MINOR);
  EXPECT_EQ(f.tether_patch, TETHER_VERSION_PATCH);
  EXPECT_EQ(f.eigen_world, EIGEN_WORLD_VERSION);
  EXPECT_EQ(f.eigen_major, EIGEN_MAJOR_VERSION);
  EXPECT_EQ(f.eigen_minor, EIGEN_MINOR_VERSION);
  EXPECT_EQ(f.eigen_max_align_bytes, EIGEN_MAX_ALIGN_BYTES);
  EXPECT_EQ(f.pointer_bytes, static_cast<int>(sizeof(void*)));
}

TEST(CompareFingerprintsTest, EveryFieldIsComparedAndNamedWithBothValues) {
  struct Field {
    int BuildFingerprint::*member;
    const char* name;
  };
  const Field fields[] = {{&BuildFingerprint::tether_major, "tether_major"},
                          {&BuildFingerprint::tether_minor, "tether_minor"},
                          {&BuildFingerprint::tether_patch, "tether_patch"},
                          {&BuildFingerprint::eigen_world, "eigen_world"},
                          {&BuildFingerprint::eigen_major, "eigen_major"},
                          {&BuildFingerprint::eigen_minor, "eigen_minor"},
                          {&BuildFingerprint::eigen_max_align_bytes, "eigen_max_align_bytes"},
                          {&BuildFingerprint::eigen_max_static_align_bytes, "eigen_max_static_align_bytes"},
                          {&BuildFingerprint::eigen_vectorize, "eigen_vectorize"},
                          {&BuildFingerprint::eigen_dont_align, "eigen_dont_align"},
                          {&BuildFingerprint::cxx11_abi, "cxx11_abi"},
                          {&BuildFingerprint::pointer_bytes, "pointer_bytes"}};
  static_assert(sizeof(fields) / sizeof(fields[0]) * sizeof(int) == sizeof(BuildFingerprint),
                "a BuildFingerprint field is missing from this test");
  const BuildFingerprint here = CurrentBuildFingerprint();
  for (const Field& field : fields) {
    SCOPED_TRACE(field.name);
    BuildFingerprint plugin = here;
    plugin.*field.member += 7;
    EXPECT_EQ(CompareFingerprints(here, plugin),
              std::vector<std::string>{std::string(field.name) + ": tether " + std::to_string(here.*field.member) +
                                       ", plugin " + std::to_string(here.*field.member + 7)});
  }
}

TEST(CompareFingerprintsTest, SeveralDifferencesGiveOneLineEachInFieldOrder) {
  BuildFingerprint tether = CurrentBuildFingerprint(), plugin = tether;
  tether.eigen_max_align_bytes = 16;
  plugin.eigen_max_align_bytes = 32;
  tether.tether_minor = 1;
  plugin.tether_minor = 2;
  EXPECT_EQ(
      CompareFingerprints(tether, plugin),
      (std::vector<std::string>{"tether_minor: tether 1, plugin 2", "eigen_max_align_bytes: tether 16, plugin 32"}));
}

TEST(PluginRegistrarTest, SetsTheOwnerOfEveryTypeToThePluginName) {
  PluginRegistrar r("my_plugin");
  EXPECT_EQ(r.plugin_name(), "my_plugin");
  FactorType a;
  a.name = "A";  // owner left at its default, "builtin"
  FactorType b;
  b.name = "B";
  b.owner = "someone_else";
  r.AddFactorType(a);
  r.AddFactorType(b);
  ASSERT_EQ(r.factor_types().size(), 2u);
  EXPECT_EQ(r.factor_types()[0].name, "A");
  EXPECT_EQ(r.factor_types()[0].owner, "my_plugin");
  EXPECT_EQ(r.factor_types()[1].name, "B");
  EXPECT_EQ(r.factor_types()[1].owner, "my_plugin");
}

}  // namespace
}  // namespace tether
