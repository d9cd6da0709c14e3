// Library messages name fields (min_particles); the command line adds the flag the user typed
// (--min-particles): WithFlags, the fields a subcommand's flags name, and the error stream that
// applies them line by line.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <sstream>
#include <string>

#include "tether/tools/command.h"

namespace tether {
namespace {

TEST(FlagNamingTest, EachFieldGetsItsFlagOnceAndOnlyAsAWholeWord) {
  const std::vector<FieldFlag> fields = {{"local_hops", "--local-hops"}, {"hops", "--hops"}};
  EXPECT_EQ(WithFlags("local_hops must be 0 or more", fields), "local_hops (--local-hops) must be 0 or more");
  // "hops" inside local_hops is not the field hops; a field already named is left alone.
  EXPECT_EQ(WithFlags("local_hops (--local-hops) and hops", fields), "local_hops (--local-hops) and hops (--hops)");
  EXPECT_EQ(WithFlags("nothing here", fields), "nothing here");
  // A path or a file name is left as it is; a field ending a sentence is named.
  EXPECT_EQ(WithFlags("cannot open data/local_hops.g2o", fields), "cannot open data/local_hops.g2o");
  EXPECT_EQ(WithFlags("check local_hops.", fields), "check local_hops (--local-hops).");
}

TEST(FlagNamingTest, ASubcommandsFlagsOfTwoWordsNameTheirFields) {
  CLI::App app;
  CLI::App* sub = app.add_subcommand("mcl");
  int a = 0, b = 0, c = 0;
  sub->add_option("--min-particles", a);
  sub->add_option("--seed", b);  // one word: too common to look for
  sub->add_option("-k,--kld-bin-size", c);
  const std::vector<FieldFlag> fields = FieldFlagsOf(*sub);
  ASSERT_EQ(fields.size(), 2u);
  EXPECT_EQ(fields[0], FieldFlag("min_particles", "--min-particles"));
  EXPECT_EQ(fields[1], FieldFlag("kld_bin_size", "--kld-bin-size"));
}

TEST(FlagNamingTest, TheErrorStreamNamesFlagsLineByLine) {
  std::ostringstream to;
  {
    FlagNamingStream err(to, {{"min_particles", "--min-particles"}});
    err << "error: min_parti" << std::flush;  // a flush mid-line waits for the line's end
    EXPECT_EQ(to.str(), "");
    err << "cles must be at least 1\nseed 5: min_particles\n";
    err << "tail without an end: min_particles";
  }
  EXPECT_EQ(to.str(),
            "error: min_particles (--min-particles) must be at least 1\nseed 5: min_particles (--min-particles)\n"
            "tail without an end: min_particles (--min-particles)");
}

}  // namespace
}  // namespace tether
