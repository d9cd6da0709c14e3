#include "tether/core/registry.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"

namespace tether {
namespace {

#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

template <typename E, typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return "";
}

std::vector<std::string> Split(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

// A plugin-style factor with its own file form: "TEST_POINT_PRIOR id x y sigma".
class PointPrior : public Factor {
 public:
  PointPrior(Key k, const Eigen::Vector2d& z, SqrtInformation n, std::string name = "TestPointPrior")
      : Factor({k}, n), z_(z), name_(std::move(name)) {}
  std::string type_name() const override { return name_; }
  std::vector<VarType> variable_types() const override { return {VarType::kPoint2}; }
  bool Evaluate(const double* const* p, double* e, double* const* jac) const override {
    e[0] = p[0][0] - z_.x();
    e[1] = p[0][1] - z_.y();
    if (jac && jac[0]) {
      jac[0][0] = 1, jac[0][1] = 0, jac[0][2] = 0, jac[0][3] = 1;
    }
    return true;
  }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PointPrior>(*this); }
  std::vector<double> Measurement() const override { return {z_.x(), z_.y()}; }

 private:
  Eigen::Vector2d z_;
  std::string name_;
};

FactorType PointPriorType(const std::string& owner = "testplugin") {
  FactorType t;
  t.name = "TestPointPrior";
  t.tag = "TEST_POINT_PRIOR";
  t.owner = owner;
  t.dim = 2;
  t.variable_types = {VarType::kPoint2};
  t.measurement_size = 2;
  t.read = [](const Fields& f, ReadContext&) -> std::unique_ptr<Factor> {
    f.ExpectCount(4, "id x y sigma");
    return std::make_unique<PointPrior>(f.Id(1), Eigen::Vector2d(f.Double(2), f.Double(3)),
                                        SqrtInformation::Isotropic(2, f.Double(4)));
  };
  t.write = [](const Factor& f) {
    const std::vector<double> m = f.Measurement();
    return "TEST_POINT_PRIOR " + std::to_string(f.keys()[0]) + " " + FormatDouble(m[0]) + " " + FormatDouble(m[1]) +
           " " + FormatDouble(1.0 / f.noise().R()(0, 0));
  };
  return t;
}

// A minimal standard-layout type (uses make and measurement).
FactorType StandardPointPriorType(const std::string& name, const std::string& tag, const std::string& owner) {
  FactorType t;
  t.name = name;
  t.tag = tag;
  t.owner = owner;
  t.dim = 2;
  t.variable_types = {VarType::kPoint2};
  t.measurement_size = 2;
  t.make = [name](std::vector<Key> k, const double* m, SqrtInformation n) {
    return std::make_unique<PointPrior>(k[0], Eigen::Vector2d(m[0], m[1]), n, name);
  };
  t.measurement = [](const Factor& f) { return f.Measurement(); };
  return t;
}

Registry Builtins() {
  Registry r;
  RegisterBuiltinFactors(r);
  return r;
}

TEST(RegistryTest, BuiltinsAreFoundByTagAndName) {
  const Registry r = Builtins();
  ASSERT_NE(r.FindByTag("EDGE_SE2"), nullptr);
  EXPECT_EQ(r.FindByTag("EDGE_SE2")->name, "BetweenSE2");
  EXPECT_EQ(r.FindByTag("EDGE_SE3:QUAT")->name, "BetweenSE3");
  EXPECT_EQ(r.FindByTag("EDGE_SE2_XY")->name, "PosePoint2");
  EXPECT_EQ(r.FindByTag("EDGE_PRIOR_SE2")->name, "PriorSE2");
  EXPECT_EQ(r.FindByTag("EDGE_RANGE_BEARING_SE2_XY")->name, "RangeBearing2");
  EXPECT_EQ(r.FindByTag("EDGE_SE3_TRACKXYZ")->name, "PosePoint3");
  EXPECT_EQ(r.FindByTag("EDGE_SE3_PRIOR")->name, "PriorSE3");
  EXPECT_EQ(r.FindByTag("EDGE_SE3_PRIOR")->preamble, "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1");
  EXPECT_EQ(r.FindByTag(""), nullptr);  // tagless types have no file form
  EXPECT_EQ(r.FindByTag("EDGE_NOPE"), nullptr);
  EXPECT_EQ(r.FindByName("Nope"), nullptr);
  // The switchable constraints (tether/factors/switchable.h) and their variable type.
  EXPECT_EQ(r.FindByTag("EDGE_SE2_SWITCHABLE")->name, "SwitchableBetweenSE2");
  EXPECT_EQ(r.FindByTag("EDGE_SE3_SWITCHABLE")->name, "SwitchableBetweenSE3");
  EXPECT_EQ(r.FindByTag("EDGE_SWITCH_PRIOR")->name, "SwitchPrior");
  VarType sw;
  ASSERT_TRUE(r.FindVariableByTag("VERTEX_SWITCH", &sw));
  EXPECT_EQ(ToString(sw), "Switch");
  // The scan-match factor (tether/factors/scan_match_se2.h): no file form, since it carries a grid.
  ASSERT_NE(r.FindByName("ScanMatchSE2"), nullptr);
  EXPECT_EQ(r.FindByName("ScanMatchSE2")->tag, "");
  EXPECT_EQ(r.types().size(), 11u);
}

TEST(RegistryTest, DuplicateNameNamesBothOwners) {
  Registry r;
  r.Register(StandardPointPriorType("P", "TAG_A", "alpha"));
  const std::string m = ErrorOf<InvalidArgument>([&] { r.Register(StandardPointPriorType("P", "TAG_B", "beta")); });
  EXPECT_CONTAINS(m, "'P' (owner 'beta')");
  EXPECT_CONTAINS(m, "name is taken already by 'P' (owner 'alpha')");
  EXPECT_CONTAINS(m, "unload 'alpha'");
  EXPECT_EQ(r.FindByTag("TAG_B"), nullptr);  // nothing half-registered
}

TEST(RegistryTest, DuplicateTagNamesBothOwners) {
  Registry r = Builtins();
  const std::string m =
      ErrorOf<InvalidArgument>([&] { r.Register(StandardPointPriorType("MyEdge", "EDGE_SE2", "myplugin")); });
  EXPECT_CONTAINS(m, "'MyEdge' (owner 'myplugin')");
  EXPECT_CONTAINS(m, "g2o tag 'EDGE_SE2' is taken already by 'BetweenSE2' (owner 'builtin')");
  EXPECT_CONTAINS(m, "built-in types cannot be removed");
  EXPECT_EQ(m.find("unload"), std::string::npos) << m;  // built-in types cannot be unloaded
  EXPECT_EQ(r.FindByName("MyEdge"), nullptr);
  EXPECT_EQ(r.FindByTag("EDGE_SE2")->name, "BetweenSE2");
}

TEST(RegistryTest, RegisteringBuiltinsTwiceThrows) {
  Registry r = Builtins();
  EXPECT_THROW(RegisterBuiltinFactors(r), InvalidArgument);
}

TEST(RegistryTest, IncompleteDescriptionsAreRejected) {
  Registry r;
  {
    FactorType t = StandardPointPriorType("", "T1", "p");
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "name is empty");
  }
  {
    FactorType t = StandardPointPriorType("A", "T1", "p");
    t.make = nullptr;
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "neither `make` (standard layout) nor `read`");
  }
  {
    FactorType t = StandardPointPriorType("A", "T1", "p");
    t.measurement = nullptr;
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }),
                    "neither `measurement` (standard layout) nor `write`");
  }
  {
    FactorType t = StandardPointPriorType("A", "T1", "p");
    t.dim = 0;
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "residual dimension is 0; it must be at least 1");
  }
  {
    FactorType t = StandardPointPriorType("A", "T1", "p");
    t.variable_types.clear();
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "no variable types");
  }
  {
    FactorType t = StandardPointPriorType("A", "BAD TAG", "p");
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "contains blanks");
  }
  {
    FactorType t = StandardPointPriorType("A", "T1", "p");
    t.measurement_size = -1;
    EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Register(t); }), "measurement_size is negative");
  }
  EXPECT_TRUE(r.types().empty());
}

TEST(RegistryTest, CustomReaderAndWriterReplaceMakeAndMeasurement) {
  Registry r;
  FactorType t = PointPriorType();
  ASSERT_FALSE(t.make);
  EXPECT_NO_THROW(r.Register(t));
}

TEST(RegistryTest, TypesWithoutTagNeedNoFileForm) {
  Registry r;
  FactorType t = StandardPointPriorType("NoFile", "", "p");
  t.make = nullptr;
  t.measurement = nullptr;
  EXPECT_NO_THROW(r.Register(t));
  EXPECT_NE(r.FindByName("NoFile"), nullptr);
}

TEST(RegistryTest, RemoveOwnerRemovesOnlyThatOwnersTypesAndFreesTheirTags) {
  Registry r = Builtins();
  r.Register(StandardPointPriorType("A", "TAG_A", "plug"));
  r.Register(StandardPointPriorType("B", "", "plug"));
  r.Register(StandardPointPriorType("C", "TAG_C", "other"));
  EXPECT_EQ(r.RemoveOwner("plug"), 2);
  EXPECT_EQ(r.FindByName("A"), nullptr);
  EXPECT_EQ(r.FindByName("B"), nullptr);
  EXPECT_EQ(r.FindByTag("TAG_A"), nullptr);
  EXPECT_NE(r.FindByName("C"), nullptr);
  EXPECT_NE(r.FindByName("BetweenSE2"), nullptr);
  EXPECT_EQ(r.RemoveOwner("plug"), 0);
  // The name and the tag can be taken again.
  EXPECT_NO_THROW(r.Register(StandardPointPriorType("A", "TAG_A", "plug2")));
  EXPECT_EQ(r.FindByTag("TAG_A")->owner, "plug2");
}

TEST(RegistryTest, RemoveTakesOutOneTypeAndItsTagAndLeavesTheOthersInPlace) {
  Registry r = Builtins();
  r.Register(StandardPointPriorType("A", "TAG_A", "plug"));
  r.Register(StandardPointPriorType("B", "TAG_B", "plug"));
  const FactorType* b = r.FindByName("B");
  const FactorType* between = r.FindByName("BetweenSE2");
  EXPECT_TRUE(r.Remove("A"));
  EXPECT_EQ(r.FindByName("A"), nullptr);
  EXPECT_EQ(r.FindByTag("TAG_A"), nullptr);
  EXPECT_EQ(r.FindByName("B"), b);
  EXPECT_EQ(r.FindByTag("TAG_B"), b);
  EXPECT_EQ(r.FindByName("BetweenSE2"), between);
  EXPECT_FALSE(r.Remove("A"));
  EXPECT_NO_THROW(r.Register(StandardPointPriorType("A2", "TAG_A", "plug")));
  EXPECT_EQ(r.FindByTag("TAG_A")->name, "A2");
}

TEST(RegistryTest, ReadsStandardEdgeSE2) {
  const Registry r = Builtins();
  const Fields f("g.g2o", 4, "EDGE_SE2 3 8 0.5 -0.25 0.1 10 1 2 20 3 30");
  ReadContext ctx;
  const std::unique_ptr<Factor> factor = r.Read(*r.FindByTag("EDGE_SE2"), f, ctx);
  EXPECT_EQ(factor->type_name(), "BetweenSE2");
  EXPECT_EQ(factor->keys(), (std::vector<Key>{3, 8}));
  EXPECT_EQ(factor->Measurement(), (std::vector<double>{0.5, -0.25, 0.1}));
  Eigen::Matrix3d expected;
  expected << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  EXPECT_LT((factor->noise().Information() - expected).norm(), 1e-12);
  EXPECT_EQ(ctx.repaired_informations, 0);
}

TEST(RegistryTest, ReadsStandardEdgeSE3) {
  const Registry r = Builtins();
  std::string line = "EDGE_SE3:QUAT 0 1 1 2 3 0 0 0.6 0.8";
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) line += i == j ? " " + std::to_string(100 * (i + 1)) : (j == i + 1 ? " 1" : " 0");
  ReadContext ctx;
  const auto factor = r.Read(*r.FindByTag("EDGE_SE3:QUAT"), Fields("g.g2o", 1, line), ctx);
  EXPECT_EQ(factor->keys(), (std::vector<Key>{0, 1}));
  const std::vector<double> m = factor->Measurement();
  ASSERT_EQ(m.size(), 7u);
  const double want[7] = {1, 2, 3, 0, 0, 0.6, 0.8};
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(m[i], want[i], 1e-12);
  const Eigen::MatrixXd info = factor->noise().Information();
  EXPECT_NEAR(info(5, 5), 600, 1e-9);
  EXPECT_NEAR(info(2, 3), 1, 1e-9);
  EXPECT_NEAR(info(3, 2), 1, 1e-9);
  EXPECT_NEAR(info(0, 5), 0, 1e-9);
}

TEST(RegistryTest, ReadChecksTheFieldCountAndNamesTheLayout) {
  const Registry r = Builtins();
  ReadContext ctx;
  const std::string m = ErrorOf<ParseError>(
      [&] { r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 12, "EDGE_SE2 1 2 0.5 0 0 1 0 0 1"), ctx); });
  EXPECT_EQ(m,
            "g.g2o:12: too few fields: EDGE_SE2 needs 11 after the tag (id1 id2 x y theta I11 I12 I13 I22 "
            "I23 I33), "
            "found 9; fix or remove the line");
  const std::string m2 = ErrorOf<ParseError>(
      [&] { r.Read(*r.FindByTag("EDGE_SE3:QUAT"), Fields("g.g2o", 2, "EDGE_SE3:QUAT 1 2 0 0 0 0 0 0 1"), ctx); });
  EXPECT_CONTAINS(m2,
                  "g.g2o:2: too few fields: EDGE_SE3:QUAT needs 30 after the tag (id1 id2 x y z qx qy qz qw I11 "
                  "I12 I13 I14 I15 I16 I22");
  EXPECT_CONTAINS(m2, "I66), found 9");
}

TEST(RegistryTest, ExplicitMeasurementLayoutIsUsedInMessages) {
  Registry r;
  FactorType t = StandardPointPriorType("A", "T_A", "p");
  t.measurement_layout = "u v";
  r.Register(t);
  r.Register(StandardPointPriorType("B", "T_B", "p"));
  FactorType c = StandardPointPriorType("C", "T_C", "p");
  c.measurement_size = 1;
  r.Register(c);
  ReadContext ctx;
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] { r.Read(*r.FindByTag("T_A"), Fields("x", 1, "T_A 1"), ctx); }),
                  "(id1 u v I11 I12 I22)");
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] { r.Read(*r.FindByTag("T_B"), Fields("x", 1, "T_B 1"), ctx); }),
                  "(id1 x y I11 I12 I22)");
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] { r.Read(*r.FindByTag("T_C"), Fields("x", 1, "T_C 1"), ctx); }),
                  "(id1 m1 I11 I12 I22)");
}

TEST(RegistryTest, ReadRejectsNonNumbers) {
  const Registry r = Builtins();
  ReadContext ctx;
  EXPECT_EQ(ErrorOf<ParseError>([&] {
              r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 7, "EDGE_SE2 1 2 0.5 abc 0 1 0 0 1 0 1"), ctx);
            }),
            "g.g2o:7: EDGE_SE2 field 4 ('abc') is not a number; fix or remove the line");
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] {
                    r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 8, "EDGE_SE2 1 x 0.5 0 0 1 0 0 1 0 1"), ctx);
                  }),
                  "g.g2o:8: EDGE_SE2 field 2 ('x') is not an id");
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] {
                    r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 9, "EDGE_SE2 1 2 0.5 0 0 1 0 0 nan 0 1"), ctx);
                  }),
                  "g.g2o:9: EDGE_SE2 field 9 ('nan') is NaN");
}

TEST(RegistryTest, NonPositiveDefiniteInformationIsAnErrorByDefault) {
  const Registry r = Builtins();
  ReadContext ctx;
  const std::string m = ErrorOf<ParseError>(
      [&] { r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 5, "EDGE_SE2 1 2 0 0 0 1 0 0 -2 0 1"), ctx); });
  EXPECT_EQ(m,
            "g.g2o:5: EDGE_SE2: information matrix is not positive definite (smallest eigenvalue -2, largest 1); "
            "fix the file or pass --repair-information nearest-pd|isotropic");
  // A singular (semidefinite) matrix is not positive definite either.
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] {
                    r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 6, "EDGE_SE2 1 2 0 0 0 1 1 0 1 0 1"), ctx);
                  }),
                  "g.g2o:6: EDGE_SE2: information matrix is not positive definite (smallest eigenvalue");
  EXPECT_EQ(ctx.repaired_informations, 0);
}

TEST(RegistryTest, NonPositiveDefiniteSE3InformationNamesTheTag) {
  const Registry r = Builtins();
  std::string line = "EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1";
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) line += i == j ? (i == 4 ? " -3.2e-05" : " 1") : " 0";
  ReadContext ctx;
  EXPECT_EQ(ErrorOf<ParseError>([&] { r.Read(*r.FindByTag("EDGE_SE3:QUAT"), Fields("p.g2o", 31, line), ctx); }),
            "p.g2o:31: EDGE_SE3:QUAT: information matrix is not positive definite (smallest eigenvalue "
            "-3.2e-05, largest 1); "
            "fix the file or pass --repair-information nearest-pd|isotropic");
}

TEST(RegistryTest, NearestPDRepairIsCounted) {
  const Registry r = Builtins();
  ReadContext ctx;
  ctx.repair = InformationRepair::kNearestPD;
  const auto good = r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 3, "EDGE_SE2 1 2 0 0 0 1 0 0 1 0 1"), ctx);
  EXPECT_EQ(ctx.repaired_informations, 0);
  const auto f1 = r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 5, "EDGE_SE2 1 2 0 0 0 4 0 0 -2 0 9"), ctx);
  const auto f2 = r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 8, "EDGE_SE2 1 2 0 0 0 1 2 0 1 0 1"), ctx);
  EXPECT_EQ(ctx.repaired_informations, 2);
  EXPECT_EQ(ctx.first_repaired_line, 5);
  // Clamping keeps the positive eigenvalues and raises the negative one to a small floor.
  const Eigen::MatrixXd info = f1->noise().Information();
  EXPECT_NEAR(info(0, 0), 4, 1e-6);
  EXPECT_NEAR(info(2, 2), 9, 1e-6);
  EXPECT_GT(info(1, 1), 0);
  EXPECT_LT(info(1, 1), 1e-6);
}

TEST(RegistryTest, IsotropicRepairUsesTheMeanDiagonal) {
  const Registry r = Builtins();
  ReadContext ctx;
  ctx.repair = InformationRepair::kIsotropic;
  const auto f = r.Read(*r.FindByTag("EDGE_SE2"), Fields("g.g2o", 5, "EDGE_SE2 1 2 0 0 0 4 0 0 -1 0 9"), ctx);
  EXPECT_EQ(ctx.repaired_informations, 1);
  EXPECT_LT((f->noise().Information() - 4.0 * Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(RegistryTest, FactoryErrorsBecomeParseErrorsWithTheLine) {
  const Registry r = Builtins();
  std::string line = "EDGE_SE3:QUAT 0 1 1 2 3 0 0 0 0";  // zero quaternion
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) line += i == j ? " 1" : " 0";
  ReadContext ctx;
  const std::string m =
      ErrorOf<ParseError>([&] { r.Read(*r.FindByTag("EDGE_SE3:QUAT"), Fields("q.g2o", 44, line), ctx); });
  EXPECT_CONTAINS(m, "q.g2o:44: EDGE_SE3:QUAT: ");
  EXPECT_CONTAINS(m, "quaternion");
}

TEST(RegistryTest, CustomReaderIsUsed) {
  Registry r;
  r.Register(PointPriorType());
  ReadContext ctx;
  const auto f = r.Read(*r.FindByTag("TEST_POINT_PRIOR"), Fields("c.g2o", 1, "TEST_POINT_PRIOR 5 1.5 2.5 0.5"), ctx);
  EXPECT_EQ(f->type_name(), "TestPointPrior");
  EXPECT_EQ(f->keys(), std::vector<Key>{5});
  EXPECT_EQ(f->Measurement(), (std::vector<double>{1.5, 2.5}));
  EXPECT_NEAR(f->noise().Information()(0, 0), 4.0, 1e-12);
  EXPECT_CONTAINS(ErrorOf<ParseError>([&] {
                    r.Read(*r.FindByTag("TEST_POINT_PRIOR"), Fields("c.g2o", 2, "TEST_POINT_PRIOR 5 1.5"), ctx);
                  }),
                  "c.g2o:2: too few fields: TEST_POINT_PRIOR needs 4 after the tag (id x y sigma), found 2");
}

TEST(RegistryTest, CustomWriterIsUsed) {
  Registry r;
  r.Register(PointPriorType());
  const PointPrior f(5, Eigen::Vector2d(1.5, 2.5), SqrtInformation::Isotropic(2, 0.5));
  EXPECT_EQ(r.Write(f), "TEST_POINT_PRIOR 5 1.5 2.5 0.5");
}

TEST(RegistryTest, WritesStandardLayout) {
  const Registry r = Builtins();
  Eigen::Matrix3d omega;
  omega << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  const BetweenSE2 f(3, 4000000000, SE2d(0.5, -0.25, 0.1), SqrtInformation::FromInformation(omega));
  const std::vector<std::string> w = Split(r.Write(f));
  ASSERT_EQ(w.size(), 12u);
  EXPECT_EQ(w[0], "EDGE_SE2");
  EXPECT_EQ(w[1], "3");
  EXPECT_EQ(w[2], "4000000000");
  EXPECT_EQ(w[3], "0.5");
  EXPECT_EQ(w[4], "-0.25");
  EXPECT_EQ(w[5], "0.1");
  const double upper[6] = {10, 1, 2, 20, 3, 30};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(std::stod(w[6 + i]), upper[i], 1e-12 * 30) << w[6 + i];
}

TEST(RegistryTest, WritesTheInformationAsTheFileHadIt) {
  // The factor keeps the square root; R^T R is printed without its round-off noise.
  const Registry r = Builtins();
  const std::string lines[] = {
      "EDGE_SE2 0 1 0.144012 -0.004462 -0.017453 115.187 -9.86523 -7.085 347.418 185.36 224.616",
      "EDGE_SE2 28 29 0.32555 0.002219 0.042036 127.269 22.1589 7.81407 147.245 0.050542 119.561",
      "EDGE_SE3:QUAT 0 1 0.341895 -0.0416997 0.0330394 0 0 0 1 10 0 0 0 0 0 10 0 0 0 0 10 0 0 0 400.021 0.00193512 "
      "2.06612 399.993 0.496977 99.203",
      "EDGE_SE2_XY 4 5 -1.5 2.25 0.3333 -0.1 7"};
  for (const std::string& line : lines) {
    const Fields f("g.g2o", 1, line);
    ReadContext ctx;
    EXPECT_EQ(r.Write(*r.Read(*r.FindByTag(std::string(f.tag())), f, ctx)), line);
  }
}

// AppendLine adds to what the buffer holds, the same text as Write, for the standard layout
// and a custom writer alike.
TEST(RegistryTest, AppendLineAppendsWhatWriteReturns) {
  Registry r = Builtins();
  r.Register(PointPriorType());
  const PointPrior custom(5, Eigen::Vector2d(1.5, 2.5), SqrtInformation::Isotropic(2, 0.5));
  const BetweenSE2 standard(3, 4, SE2d(0.5, -0.25, 0.1), SqrtInformation::Isotropic(3, 2.0));
  std::string buf = "before|";
  r.AppendLine(standard, &buf);
  buf += "|";
  r.AppendLine(custom, &buf);
  EXPECT_EQ(buf, "before|" + r.Write(standard) + "|" + r.Write(custom));
  EXPECT_EQ(r.Write(standard), "EDGE_SE2 3 4 0.5 -0.25 0.1 0.25 0 0 0.25 0 0.25");  // sigma 2
}

TEST(RegistryTest, WriteThenReadGivesTheSameFactor) {
  const Registry r = Builtins();
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
  const Eigen::MatrixXd omega = a * a.transpose() + 6 * Eigen::MatrixXd::Identity(6, 6);
  const BetweenSE3 f(7, 9, SE3d(Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2), Eigen::Vector3d(1.0 / 3, -2e-7, 5e5)),
                     SqrtInformation::FromInformation(omega));
  const std::string line = r.Write(f);
  ReadContext ctx;
  const auto g = r.Read(*r.FindByTag("EDGE_SE3:QUAT"), Fields("w", 1, line), ctx);
  EXPECT_EQ(g->keys(), f.keys());
  const std::vector<double> m1 = f.Measurement(), m2 = g->Measurement();
  ASSERT_EQ(m1.size(), m2.size());
  for (std::size_t i = 0; i < m1.size(); ++i) EXPECT_NEAR(m1[i], m2[i], 1e-15 * std::max(1.0, std::abs(m1[i])));
  EXPECT_LT((f.noise().Information() - g->noise().Information()).norm(), 1e-12 * omega.norm());
}

TEST(RegistryTest, WriteRejectsTaglessAndUnregisteredTypes) {
  Registry r = Builtins();
  r.Register(StandardPointPriorType("TaglessPointPrior", "", "test"));
  const PointPrior f(1, Eigen::Vector2d(1, 2), SqrtInformation::Identity(2), "TaglessPointPrior");
  EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Write(f); }),
                  "cannot write a factor of type 'TaglessPointPrior': it has no g2o tag");
  const PointPrior p(5, Eigen::Vector2d(1, 2), SqrtInformation::Identity(2));
  EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Write(p); }),
                  "type 'TestPointPrior': the type is not registered; load the plugin that defines it");
}

TEST(RegistryTest, WriteChecksTheMeasurementSize) {
  Registry r;
  FactorType t = StandardPointPriorType("TestPointPrior", "T_P", "p");
  t.measurement = [](const Factor&) { return std::vector<double>{1.0}; };
  r.Register(t);
  const PointPrior p(5, Eigen::Vector2d(1, 2), SqrtInformation::Identity(2));
  EXPECT_CONTAINS(ErrorOf<InvalidArgument>([&] { r.Write(p); }), "its measurement has 1 numbers, the type declares 2");
}

TEST(FormatDoubleTest, ShortestTextThatReadsBackExactly) {
  EXPECT_EQ(FormatDouble(0.1), "0.1");
  EXPECT_EQ(FormatDouble(500), "500");
  EXPECT_EQ(FormatDouble(-0.25), "-0.25");
  EXPECT_EQ(FormatDouble(0), "0");
  const double values[] = {1.0 / 3,   -2.0 / 3, 1e-300, 5e-324, DBL_MAX,     -DBL_MIN, 123456789.123456789,
                           0.1 + 0.2, M_PI,     -0.0,   1e22,   4000000000.5};
  for (double v : values) {
    const std::string s = FormatDouble(v);
    double back = 0;
    std::from_chars(s.data(), s.data() + s.size(), back);
    EXPECT_EQ(back, v) << s;
    EXPECT_EQ(std::signbit(back), std::signbit(v)) << s;
  }
}

}  // namespace
}  // namespace tether
