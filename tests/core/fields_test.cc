#include "tether/core/fields.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace tether {
namespace {

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

// The message of the ParseError that `fn` throws ("" and a failure if it throws none).
template <typename Fn>
std::string ParseErrorOf(Fn fn) {
  try {
    fn();
  } catch (const ParseError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ParseError";
  return "";
}

TEST(FieldsTest, SplitsAtSpacesAndTabs) {
  const Fields f("a.g2o", 3, "  EDGE_SE2\t1   2 \t 0.5\t");
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f.tag(), "EDGE_SE2");
  EXPECT_EQ(f[0], "EDGE_SE2");
  EXPECT_EQ(f[1], "1");
  EXPECT_EQ(f[2], "2");
  EXPECT_EQ(f[3], "0.5");
  EXPECT_EQ(f.file(), "a.g2o");
  EXPECT_EQ(f.line_number(), 3);
}

TEST(FieldsTest, EmptyAndBlankLinesHaveNoFields) {
  EXPECT_EQ(Fields("a", 1, "").size(), 0u);
  EXPECT_EQ(Fields("a", 1, " \t \r").size(), 0u);
  EXPECT_EQ(Fields("a", 1, "").tag(), "");
}

TEST(FieldsTest, ToleratesTrailingCarriageReturn) {
  const Fields f("a.g2o", 1, "VERTEX_SE2 7 1 2 3.5\r");
  ASSERT_EQ(f.size(), 5u);
  EXPECT_EQ(f[4], "3.5");
  EXPECT_EQ(f.Double(4), 3.5);
  EXPECT_EQ(f.Id(1), 7u);
  const Fields g("a.g2o", 1, "FIX 7\r");
  EXPECT_EQ(g.Id(1), 7u);
}

TEST(FieldsTest, ParsesDoubles) {
  const Fields f("a", 1, "T 1.5 -2e-3 +3 .25 1E10 0 -0 0.1 5e-324 1.7976931348623157e308");
  EXPECT_EQ(f.Double(1), 1.5);
  EXPECT_EQ(f.Double(2), -2e-3);
  EXPECT_EQ(f.Double(3), 3.0);
  EXPECT_EQ(f.Double(4), 0.25);
  EXPECT_EQ(f.Double(5), 1e10);
  EXPECT_EQ(f.Double(6), 0.0);
  EXPECT_TRUE(std::signbit(f.Double(7)));
  EXPECT_EQ(f.Double(8), 0.1);
  EXPECT_EQ(f.Double(9), 5e-324);
  EXPECT_EQ(f.Double(10), std::numeric_limits<double>::max());
}

TEST(FieldsTest, ParsesIds) {
  const Fields f("a", 1, "T 0 42 4000000000 18446744073709551615");
  EXPECT_EQ(f.Id(1), 0u);
  EXPECT_EQ(f.Id(2), 42u);
  EXPECT_EQ(f.Id(3), 4000000000u);
  EXPECT_EQ(f.Id(4), std::numeric_limits<std::uint64_t>::max());
}

TEST(FieldsTest, NotANumberNamesFileLineTagFieldAndText) {
  const Fields f("f.g2o", 12, "EDGE_SE2 1 2 0.5 abc 0.1 1 0 0 1 0 1");
  EXPECT_EQ(ParseErrorOf([&] { f.Double(4); }),
            "f.g2o:12: EDGE_SE2 field 4 ('abc') is not a number; fix or remove the line");
}

TEST(FieldsTest, RejectsTrailingGarbageAndOddForms) {
  const Fields f("f.g2o", 2, "T 1.5x 1,5 0x10 -- + . 1e");
  for (std::size_t i = 1; i < f.size(); ++i) {
    const std::string m = ParseErrorOf([&] { f.Double(i); });
    EXPECT_CONTAINS(m, "f.g2o:2: T field " + std::to_string(i) + " ('" + std::string(f[i]) + "') is not a number");
  }
}

TEST(FieldsTest, RejectsNaNAndInf) {
  const Fields f("f.g2o", 5, "T nan NaN inf -inf infinity -nan");
  EXPECT_EQ(ParseErrorOf([&] { f.Double(1); }),
            "f.g2o:5: T field 1 ('nan') is NaN; every number must be finite, fix or remove the line");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(2); }), "field 2 ('NaN') is NaN");
  EXPECT_EQ(ParseErrorOf([&] { f.Double(3); }),
            "f.g2o:5: T field 3 ('inf') is inf; every number must be finite, fix or remove the line");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(4); }), "field 4 ('-inf') is inf");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(5); }), "field 5 ('infinity') is inf");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(6); }), "field 6 ('-nan') is NaN");
}

TEST(FieldsTest, RejectsNumbersOutsideTheRangeOfADouble) {
  const Fields f("f.g2o", 6, "T 1e999 -1e999");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(1); }), "f.g2o:6: T field 1 ('1e999') is out of the range of a double");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Double(2); }), "field 2 ('-1e999') is out of the range");
}

TEST(FieldsTest, MissingFieldIsAnError) {
  const Fields f("f.g2o", 9, "T 1 2");
  EXPECT_EQ(ParseErrorOf([&] { f.Double(3); }),
            "f.g2o:9: T field 3 is missing (the line has 2 fields after the tag); fix or remove the line");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Id(7); }), "f.g2o:9: T id field 7 is missing");
}

TEST(FieldsTest, RejectsBadIds) {
  const Fields f("f.g2o", 4, "EDGE_SE2 -1 1.5 abc 18446744073709551616 +3");
  EXPECT_EQ(ParseErrorOf([&] { f.Id(1); }),
            "f.g2o:4: EDGE_SE2 field 1 ('-1') is a negative id; ids must be integers from 0 to "
            "18446744073709551615, fix the line");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Id(2); }), "f.g2o:4: EDGE_SE2 field 2 ('1.5') is not an id");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Id(3); }), "field 3 ('abc') is not an id");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Id(4); }), "field 4 ('18446744073709551616') is too large for an id");
  EXPECT_CONTAINS(ParseErrorOf([&] { f.Id(5); }), "field 5 ('+3') is not an id");
}

TEST(FieldsTest, ExpectCountAcceptsTheRightCount) {
  const Fields f("f.g2o", 1, "VERTEX_SE2 1 0 0 0");
  EXPECT_NO_THROW(f.ExpectCount(4, "id x y theta"));
}

TEST(FieldsTest, ExpectCountTooFew) {
  const Fields f("f.g2o", 12, "EDGE_SE2 1 2 0.5 0 0 1 0 0 1");
  EXPECT_EQ(ParseErrorOf([&] { f.ExpectCount(11, "id1 id2 x y theta I11 I12 I13 I22 I23 I33"); }),
            "f.g2o:12: too few fields: EDGE_SE2 needs 11 after the tag (id1 id2 x y theta I11 I12 I13 I22 "
            "I23 I33), "
            "found 9; fix or remove the line");
}

TEST(FieldsTest, ExpectCountTooMany) {
  const Fields f("f.g2o", 3, "VERTEX_SE2 1 0 0 0 9");
  EXPECT_EQ(ParseErrorOf([&] { f.ExpectCount(4, "id x y theta"); }),
            "f.g2o:3: too many fields: VERTEX_SE2 needs 4 after the tag (id x y theta), found 5; fix or remove the "
            "line");
}

TEST(FieldsTest, WhereAndFail) {
  EXPECT_EQ(Fields("in.g2o", 17, "X").Where(), "in.g2o:17: ");
  EXPECT_EQ(Fields("in.g2o", 0, "X").Where(), "in.g2o: ");
  EXPECT_EQ(ParseErrorOf([] { Fields("in.g2o", 17, "X").Fail("bad thing; do this"); }),
            "in.g2o:17: bad thing; do this");
  // Fail throws a tether::Error, so callers can catch the base class.
  EXPECT_THROW(Fields("in.g2o", 1, "X").Fail("x"), Error);
}

}  // namespace
}  // namespace tether
