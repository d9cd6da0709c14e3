// The plugin loader beside the built-in factor types (tether::factors), in a registry that holds
// them as tether's programs do: a plugin's types join them, a plugin claiming a built-in tag
// (EDGE_SE2) is refused naming both owners, and what was found before a load stays valid after
// it. The loader's other tests, which need no built-in type, are in
// tests/plugins/loader_test.cc; the fixture is shared (testing/plugin_loader_fixture.h).
#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "testing/plugin_loader_fixture.h"
#include "tether/core/graph_io.h"
#include "tether/core/values.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {
namespace {

using testing::Canonical;
using testing::SameLoadedPlugin;
using testing::TestPlugin;

// The shared fixture with the built-in factor types registered first.
class LoaderTest : public testing::LoaderFixture {
 protected:
  void SetUp() override {
    LoaderFixture::SetUp();
    RegisterBuiltinFactors(registry_);
  }
};

TEST_F(LoaderTest, LoadsAMinimalPluginAndRegistersItsTypesUnderItsName) {
  const LoadedPlugin p = loader_.Load(TestPlugin("good"));
  EXPECT_EQ(p.name, "test_good");
  EXPECT_EQ(p.version, "0.1.0");
  EXPECT_EQ(p.path, Canonical(TestPlugin("good")));
  EXPECT_EQ(p.type_names, std::vector<std::string>{"TestGoodPrior"});
  ASSERT_EQ(loader_.loaded().size(), 1u);
  EXPECT_TRUE(SameLoadedPlugin(loader_.loaded()[0], p));

  const FactorType* t = registry_.FindByTag("TEST_GOOD_PRIOR");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->name, "TestGoodPrior");
  EXPECT_EQ(t->owner, "test_good");
  EXPECT_EQ(registry_.FindByTag("EDGE_SE2")->owner, "builtin");

  // The plugin's tag reads and writes in the standard layout: TAG id x y I11 I12 I22.
  std::istringstream in("VERTEX_XY 7 1 2\nTEST_GOOD_PRIOR 7 0.5 -0.25 4 0 9\n");
  const GraphFile g = ReadGraph(in, "inline.g2o", registry_);
  ASSERT_EQ(g.graph.size(), 1u);
  EXPECT_EQ(g.graph.at(0).type_name(), "TestGoodPrior");
  EXPECT_DOUBLE_EQ(g.graph.Chi2(g.values), 4 * 0.5 * 0.5 + 9 * 2.25 * 2.25);
  EXPECT_EQ(registry_.Write(g.graph.at(0)), "TEST_GOOD_PRIOR 7 0.5 -0.25 4 0 9");
}

TEST_F(LoaderTest, TypesFoundBeforeALoadStayValidAfterIt) {
  // Lifetime rule: a FactorType found in the registry stays where it is until its owner is
  // removed; loading another plugin (or failing to) moves none of them.
  const FactorType* builtin = registry_.FindByTag("EDGE_SE2");
  ASSERT_NE(builtin, nullptr);
  loader_.Load(TestPlugin("good"));
  const FactorType* good = registry_.FindByTag("TEST_GOOD_PRIOR");
  ASSERT_NE(good, nullptr);
  EXPECT_EQ(registry_.FindByTag("EDGE_SE2"), builtin);
  Refused(TestPlugin("dup_builtin_tag"));  // a refusal on a conflict does not move them either
  loader_.Load(TestPlugin("dup_tag_a"));
  const FactorType* shared = registry_.FindByTag("TEST_SHARED_TAG");
  ASSERT_NE(shared, nullptr);
  Refused(TestPlugin("dup_tag_b"));
  EXPECT_EQ(registry_.FindByTag("TEST_SHARED_TAG"), shared);
  EXPECT_EQ(registry_.FindByTag("EDGE_SE2"), builtin);
  EXPECT_EQ(registry_.FindByTag("TEST_GOOD_PRIOR"), good);
  // And they still work: a factor made through the pointer found first.
  const double z[2] = {1, 2};
  const std::unique_ptr<Factor> f = good->make({3}, z, SqrtInformation::Identity(2));
  Values values;
  values.Insert(3, Eigen::Vector2d(1, 2));
  EXPECT_DOUBLE_EQ(f->Chi2(values), 0.0);
}

TEST_F(LoaderTest, RefusesATagTakenByABuiltinNamingBothOwners) {
  const std::string m = Refused(TestPlugin("dup_builtin_tag"));
  EXPECT_CONTAINS(m, "plugin " + Canonical(TestPlugin("dup_builtin_tag")) + " ('test_dup_builtin_tag')");
  EXPECT_CONTAINS(m, "'TestDupBuiltinPrior' (owner 'test_dup_builtin_tag')");
  EXPECT_CONTAINS(m, "the g2o tag 'EDGE_SE2' is taken already by 'BetweenSE2' (owner 'builtin')");
  EXPECT_EQ(registry_.FindByTag("EDGE_SE2")->name, "BetweenSE2");
  EXPECT_EQ(registry_.FindByName("TestDupBuiltinOkPrior"), nullptr);
}

TEST_F(LoaderTest, EveryRefusalLeavesTheLoaderUsable) {
  for (const char* broken :
       {"not_a_library", "missing_entry", "null_description", "wrong_interface", "unnamed", "fingerprint_mismatch",
        "no_register_function", "throws_std", "throws_non_std", "incomplete_type", "dup_builtin_tag"}) {
    SCOPED_TRACE(broken);
    EXPECT_FALSE(Refused(TestPlugin(broken)).empty());
  }
  EXPECT_EQ(loader_.Load(TestPlugin("good")).name, "test_good");
  EXPECT_EQ(loader_.Load(TestPlugin("dup_tag_a")).name, "test_dup_a");
  EXPECT_EQ(loader_.loaded().size(), 2u);
  EXPECT_NE(registry_.FindByTag("TEST_GOOD_PRIOR"), nullptr);
  EXPECT_NE(registry_.FindByTag("TEST_SHARED_TAG"), nullptr);
}

}  // namespace
}  // namespace tether
