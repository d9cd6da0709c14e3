// Variable types as registry entries: the built-in ones, a type registered at run time (ids,
// box-plus, Values, g2o files), one naming scheme for Values, and the probe check that
// refuses a factor registration whose entry disagrees with its factors.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "tether/core/autodiff_factor.h"
#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/jacobian_check.h"
#include "tether/core/registry.h"
#include "tether/core/values.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"

namespace tether_vt_test {

// A bearing on the unit circle, stored as (cos, sin): ambient 2, tangent 1 (a rotation).
struct Heading {
  double c = 1, s = 0;
};

}  // namespace tether_vt_test

template <>
struct tether::VariableTraits<tether_vt_test::Heading> {
  static constexpr const char* kName = "TestHeading";
  static constexpr const char* kTag = "VERTEX_TEST_HEADING";
  static constexpr const char* kParameterNames = "c s";
  static constexpr int kAmbient = 2, kTangent = 1;
  template <typename T>
  static void Retract(const T* x, const T* d, T* out) {
    using std::cos, std::sin;
    const T c = x[0] * cos(d[0]) - x[1] * sin(d[0]), s = x[0] * sin(d[0]) + x[1] * cos(d[0]);
    out[0] = c;
    out[1] = s;
  }
  static void Local(const double* x, const double* y, double* d) {
    d[0] = std::atan2(x[0] * y[1] - x[1] * y[0], x[0] * y[0] + x[1] * y[1]);
  }
  static void Identity(double* x) { x[0] = 1, x[1] = 0; }
  static bool Canonicalize(double* x) {
    const double n = std::hypot(x[0], x[1]);
    if (!(n > 0)) throw tether::InvalidArgument("heading (c s) is zero");
    x[0] /= n, x[1] /= n;
    return std::abs(n - 1) > 1e-6;
  }
  static constexpr const char* kCanonicalizeNote = "normalised headings";
  static tether_vt_test::Heading FromParams(const double* p) { return {p[0], p[1]}; }
  static void ToParams(const tether_vt_test::Heading& h, double* p) { p[0] = h.c, p[1] = h.s; }
};

namespace tether {
namespace {

using tether_vt_test::Heading;

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

#define EXPECT_CONTAINS(haystack, needle) EXPECT_NE(std::string(haystack).find(needle), std::string::npos) << haystack

// A heading prior: e = angle from the measured heading to the variable (autodiff).
class HeadingPrior : public AutoDiffFactor<HeadingPrior, 1, Heading> {
 public:
  static constexpr const char* kTypeName = "TestHeadingPrior";
  HeadingPrior(Key k, double z, SqrtInformation n) : AutoDiffFactor({k}, std::move(n)), z_(z) {}
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    using std::atan2, std::cos, std::sin;
    const T c(std::cos(z_)), s(std::sin(z_));
    e[0] = atan2(c * p[0][1] - s * p[0][0], c * p[0][0] + s * p[0][1]);
    return true;
  }
  std::vector<double> Measurement() const override { return {z_}; }

 private:
  double z_;
};

Registry WithHeading() {
  Registry r;
  RegisterBuiltinFactors(r);
  r.RegisterVariable<Heading>();
  r.Register(DescribeFactor<HeadingPrior>("EDGE_TEST_HEADING_PRIOR", 1,
                                          [](std::vector<Key> k, const double* m, SqrtInformation n) {
                                            return std::make_unique<HeadingPrior>(k[0], m[0], std::move(n));
                                          }));
  return r;
}

TEST(VariableTypeTest, BuiltInTypesHaveFixedIdsAndGoThroughTheRegistry) {
  EXPECT_EQ(VarTypeOf<SE2d>(), VarType::kSE2);
  EXPECT_EQ(VarTypeOf<SE3d>(), VarType::kSE3);
  EXPECT_EQ(VarTypeOf<Eigen::Vector2d>(), VarType::kPoint2);
  EXPECT_EQ(VarTypeOf<Eigen::Vector3d>(), VarType::kPoint3);
  EXPECT_EQ(Describe(VarType::kSE3).ambient_dim, 7);
  EXPECT_EQ(Describe(VarType::kSE3).tangent_dim, 6);
  EXPECT_EQ(Describe(VarType::kSE3).tag, "VERTEX_SE3:QUAT");
  const Registry r;  // every registry starts with the four built-in variable types
  ASSERT_EQ(r.variable_types().size(), 4u);
  VarType t;
  ASSERT_TRUE(r.FindVariableByTag("VERTEX_XY", &t));
  EXPECT_EQ(t, VarType::kPoint2);
  EXPECT_EQ(r.VariableOwner("SE2"), "builtin");
}

TEST(VariableTypeTest, ARegisteredTypeGetsOneIdForLifeAndItsBoxPlus) {
  Registry r;
  const VarType id = r.RegisterVariable<Heading>();
  EXPECT_GE(static_cast<int>(id), kNumBuiltinVarTypes);
  EXPECT_EQ(VarTypeOf<Heading>(), id);
  EXPECT_EQ(ToString(id), "TestHeading");
  EXPECT_EQ(AmbientDim(id), 2);
  EXPECT_EQ(TangentDim(id), 1);
  // A second registry (or a reload) gets the same id for the same name.
  Registry other;
  EXPECT_EQ(other.RegisterVariable<Heading>(), id);
  // Box-plus and box-minus through the run-time table.
  const double x[2] = {1, 0}, d[1] = {0.5};
  double y[2], back[1];
  RetractParams<double>(id, x, d, y);
  EXPECT_NEAR(y[0], std::cos(0.5), 1e-15);
  EXPECT_NEAR(y[1], std::sin(0.5), 1e-15);
  LocalParams(id, x, y, back);
  EXPECT_NEAR(back[0], 0.5, 1e-15);
  double identity[2] = {7, 7};
  IdentityParams(id, identity);
  EXPECT_EQ(identity[0], 1.0);
  EXPECT_EQ(identity[1], 0.0);
}

TEST(VariableTypeTest, SameNameWithOtherSizesOrTakenTagsAreRefused) {
  Registry r;
  r.RegisterVariable<Heading>();
  VariableType clash = DescribeVariable<Heading>();
  EXPECT_CONTAINS(ErrorOf([&] { r.RegisterVariable(clash); }), "the name is taken already (owner 'builtin')");
  clash.ambient_dim = 3;
  Registry fresh;
  EXPECT_CONTAINS(ErrorOf([&] { fresh.RegisterVariable(clash); }),
                  "variable type 'TestHeading' exists already with ambient size 2 and tangent size 1");
  VariableType tag = DescribeVariable<Heading>();
  tag.name = "OtherHeading";
  EXPECT_CONTAINS(ErrorOf([&] { r.RegisterVariable(tag); }),
                  "the g2o tag 'VERTEX_TEST_HEADING' is taken already by variable type 'TestHeading'");
  tag.tag = "EDGE_SE2";
  Registry b;
  RegisterBuiltinFactors(b);
  EXPECT_CONTAINS(ErrorOf([&] { b.RegisterVariable(tag); }),
                  "the g2o tag 'EDGE_SE2' is taken already by factor type 'BetweenSE2'");
  VariableType empty;
  empty.name = "Nothing";
  EXPECT_CONTAINS(ErrorOf([&] { r.RegisterVariable(empty); }), "both must be at least 1");
}

VariableType Foo(const char* tag, const char* owner, VariableType::RetractFn retract) {
  VariableType t;
  t.name = "TestFoo";
  t.tag = tag;
  t.owner = owner;
  t.ambient_dim = t.tangent_dim = 1;
  t.retract = retract;
  t.local = [](const double* x, const double* y, double* d) { d[0] = y[0] - x[0]; };
  t.identity = [](double* x) { x[0] = 0; };
  return t;
}

// Two descriptions of one name: the second is refused while a registry holds the first, and
// takes its place (same id) once none does, as a plugin refused or removed earlier leaves it.
TEST(VariableTypeTest, ADescriptionHeldByARegistryIsNotReplaced) {
  const auto plus = [](const double* x, const double* d, double* out) { out[0] = x[0] + d[0]; };
  const auto twice = [](const double* x, const double* d, double* out) { out[0] = x[0] + 2 * d[0]; };
  VarType id;
  {
    Registry first;
    id = first.RegisterVariable(Foo("VERTEX_FOO", "p1", plus));
    Registry second;
    EXPECT_CONTAINS(ErrorOf([&] { second.RegisterVariable(Foo("VERTEX_FOO2", "p2", twice)); }),
                    "variable type 'TestFoo' is registered already by 'p1' with another box-plus");
    EXPECT_EQ(second.RegisterVariable(Foo("VERTEX_FOO", "p1", plus)), id);  // the same description is shared
    Registry copy = first;                                                  // a copy holds it too
    EXPECT_TRUE(first.RemoveVariable("TestFoo"));
    EXPECT_TRUE(second.RemoveVariable("TestFoo"));
    EXPECT_CONTAINS(ErrorOf([&] {
                      Registry r;
                      r.RegisterVariable(Foo("VERTEX_FOO2", "p2", twice));
                    }),
                    "registered already by 'p1'");
  }
  Registry later;
  EXPECT_EQ(later.RegisterVariable(Foo("VERTEX_FOO2", "p2", twice)), id);
  EXPECT_EQ(Describe(id).tag, "VERTEX_FOO2");
  const double x[1] = {1}, d[1] = {1};
  double y[1];
  RetractParams<double>(id, x, d, y);
  EXPECT_EQ(y[0], 3.0);
  VarType found;
  ASSERT_TRUE(later.FindVariableByTag("VERTEX_FOO2", &found));
  EXPECT_TRUE(later.RemoveVariable("TestFoo"));
  EXPECT_FALSE(later.FindVariableByTag("VERTEX_FOO2", &found));  // the tag registered here goes
}

TEST(VariableTypeTest, RemoveOwnerTakesTheVertexTagBackButKeepsTheId) {
  Registry r;
  VariableType t = DescribeVariable<Heading>();
  t.owner = "headings";
  const VarType id = r.RegisterVariable(t);
  VarType found;
  ASSERT_TRUE(r.FindVariableByTag("VERTEX_TEST_HEADING", &found));
  EXPECT_EQ(r.RemoveOwner("headings"), 1);
  EXPECT_FALSE(r.FindVariableByTag("VERTEX_TEST_HEADING", &found));
  EXPECT_EQ(r.RegisterVariable(t), id);
}

TEST(VariableTypeTest, ValuesUseOneNamingSchemeForEveryType) {
  WithHeading();
  Values v;
  v.Insert(1, SE2d(1, 2, 0.3));
  v.Insert(2, SE3d());
  v.Insert(3, Eigen::Vector2d(4, 5));
  v.Insert(4, Eigen::Vector3d(6, 7, 8));
  v.Insert(5, Heading{0, 1});
  EXPECT_NEAR(v.At<SE2d>(1).theta(), 0.3, 0);
  EXPECT_EQ(v.At<Eigen::Vector2d>(3), Eigen::Vector2d(4, 5));
  EXPECT_EQ(v.At<Eigen::Vector3d>(4), Eigen::Vector3d(6, 7, 8));
  EXPECT_EQ(v.At<Heading>(5).s, 1.0);
  v.Update(5, Heading{1, 0});
  v.Update(3, Eigen::Vector2d(-1, -2));
  EXPECT_EQ(v.At<Heading>(5).c, 1.0);
  EXPECT_EQ(v.At<Eigen::Vector2d>(3), Eigen::Vector2d(-1, -2));
  EXPECT_EQ(v.TypeOf(5), VarTypeOf<Heading>());
  EXPECT_CONTAINS(ErrorOf([&] { v.At<SE2d>(5); }), "key 5 holds TestHeading, not SE2");
  EXPECT_CONTAINS(ErrorOf([&] { v.Update(1, Heading{}); }), "key 1 holds SE2, not TestHeading");
  std::ostringstream s;
  s << v;
  EXPECT_CONTAINS(s.str(), "5 TestHeading (1, 0)");
  EXPECT_CONTAINS(s.str(), "1 SE2 (1, 2, 0.3)");
}

TEST(VariableTypeTest, EraseMovesTheLastOfItsTypeIntoTheGap) {
  Values v;
  for (int i = 0; i < 4; ++i) v.Insert(i, SE2d(i, 0, 0));
  v.Insert(10, Eigen::Vector2d(1, 1));
  EXPECT_TRUE(v.Erase(1));
  EXPECT_FALSE(v.Erase(1));
  EXPECT_FALSE(v.Has(1));
  EXPECT_EQ(v.size(), 4u);
  EXPECT_EQ(v.Count(VarType::kSE2), 3u);
  EXPECT_EQ(v.At<SE2d>(0).x(), 0);
  EXPECT_EQ(v.At<SE2d>(2).x(), 2);
  EXPECT_EQ(v.At<SE2d>(3).x(), 3);
  EXPECT_EQ(v.keys(), (std::vector<Key>{0, 2, 3, 10}));
  v.Insert(1, SE2d(9, 0, 0));
  EXPECT_EQ(v.At<SE2d>(1).x(), 9);
  EXPECT_EQ(v.At<SE2d>(3).x(), 3);
}

TEST(VariableTypeTest, RegisteredVertexTagsAreReadCanonicalisedAndWrittenBack) {
  const Registry r = WithHeading();
  std::istringstream in(
      "VERTEX_TEST_HEADING 7 0 2\n"
      "EDGE_TEST_HEADING_PRIOR 7 1.5 4\n"
      "EDGE_TEST_HEADING_PRIOR 7 0.9 4\n");
  const GraphFile g = ReadGraph(in, "h.g2o", r);
  ASSERT_EQ(g.values.size(), 1u);
  EXPECT_EQ(g.values.At<Heading>(7).s, 1.0);  // (0, 2) normalised
  ASSERT_EQ(g.warnings.size(), 1u);
  EXPECT_EQ(g.warnings[0], "h.g2o: normalised headings on 1 line VERTEX_TEST_HEADING (first at line 1)");
  std::ostringstream out;
  WriteG2o(out, g.values, g.graph, r);
  std::istringstream again(out.str());
  const GraphFile h = ReadGraph(again, "h2.g2o", r);
  EXPECT_EQ(h.values.Data(VarTypeOf<Heading>()), g.values.Data(VarTypeOf<Heading>()));
  EXPECT_EQ(h.graph.at(0).Measurement(), std::vector<double>{1.5});
  std::istringstream bad("VERTEX_TEST_HEADING 7 0 0\n");
  EXPECT_CONTAINS(ErrorOf([&] { ReadGraph(bad, "b.g2o", r); }),
                  "b.g2o:1: VERTEX_TEST_HEADING heading (c s) is zero; fix the line");
  std::istringstream few("VERTEX_TEST_HEADING 7 0\n");
  EXPECT_CONTAINS(ErrorOf([&] { ReadGraph(few, "f.g2o", r); }), "(id c s)");
}

TEST(VariableTypeTest, AutodiffThroughARegisteredTypeMatchesCentralDifferences) {
  WithHeading();
  Values v;
  v.Insert(1, Heading{std::cos(2.0), std::sin(2.0)});
  const HeadingPrior f(1, 0.4, SqrtInformation::Identity(1));
  const JacobianCheck c = CheckJacobians(f, v);
  EXPECT_TRUE(c.ok) << c.Report();
  double e;
  const double* p[1] = {v.Params(1)};
  ASSERT_TRUE(f.Evaluate(p, &e, nullptr));
  EXPECT_NEAR(e, 1.6, 1e-12);
}

// ---- the probe check ----

// A factor whose reported facts can be set, to make every kind of mismatch.
class Configurable : public Factor {
 public:
  Configurable(std::vector<Key> k, SqrtInformation n, std::string name, int dim, std::vector<VarType> types)
      : Factor(std::move(k), std::move(n)), name_(std::move(name)), dim_(dim), types_(std::move(types)) {}
  std::string type_name() const override { return name_; }
  int residual_dim() const override { return dim_; }
  std::vector<VarType> variable_types() const override { return types_; }
  bool Evaluate(const double* const*, double* e, double* const*) const override {
    for (int i = 0; i < dim_; ++i) e[i] = 0;
    return true;
  }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<Configurable>(*this); }

 private:
  std::string name_;
  int dim_;
  std::vector<VarType> types_;
};

FactorType Entry(std::string made_name, int made_dim, std::vector<VarType> made_types) {
  FactorType t;
  t.name = "Probe";
  t.tag = "EDGE_PROBE";
  t.owner = "probe_plugin";
  t.dim = 2;
  t.variable_types = {VarType::kSE2, VarType::kPoint2};
  t.measurement_size = 2;
  t.make = [=](std::vector<Key> k, const double*, SqrtInformation n) {
    return std::make_unique<Configurable>(std::move(k), std::move(n), made_name, made_dim, made_types);
  };
  t.measurement = [](const Factor&) { return std::vector<double>{0, 0}; };
  return t;
}

TEST(ProbeCheckTest, AMatchingEntryIsTaken) {
  Registry r;
  EXPECT_NO_THROW(r.Register(Entry("Probe", 2, {VarType::kSE2, VarType::kPoint2})));
}

TEST(ProbeCheckTest, EachMismatchIsRefusedNamingTheField) {
  Registry r;
  EXPECT_CONTAINS(ErrorOf([&] {
                    r.Register(Entry("Probed", 2, {VarType::kSE2, VarType::kPoint2}));
                  }),
                  "cannot register factor type 'Probe' (owner 'probe_plugin'): name mismatch: the entry says "
                  "'Probe' but its factors' type_name() is 'Probed'");
  EXPECT_CONTAINS(ErrorOf([&] {
                    r.Register(Entry("Probe", 3, {VarType::kSE2, VarType::kPoint2}));
                  }),
                  "dimension mismatch: the entry says 2 but its factors' residual_dim() is 3");
  EXPECT_CONTAINS(ErrorOf([&] {
                    r.Register(Entry("Probe", 2, {VarType::kSE2, VarType::kSE2}));
                  }),
                  "variable types mismatch: the entry says (SE2, Point2) but its factors' variable_types() are "
                  "(SE2, SE2)");
  EXPECT_EQ(r.FindByName("Probe"), nullptr);  // nothing of a refused entry stays
  FactorType throws = Entry("Probe", 2, {VarType::kSE2, VarType::kPoint2});
  throws.make = [](std::vector<Key>, const double*, SqrtInformation) -> std::unique_ptr<Factor> {
    throw InvalidArgument("no");
  };
  EXPECT_CONTAINS(ErrorOf([&] { r.Register(throws); }), "its factory `make` threw on a probe factor");
}

TEST(ProbeCheckTest, DescribeFactorTakesNameSizeAndTypesFromTheClass) {
  const FactorType t = DescribeFactor<BetweenSE2>("X", 3, nullptr);
  EXPECT_EQ(t.name, "BetweenSE2");
  EXPECT_EQ(t.dim, 3);
  EXPECT_EQ(t.variable_types, (std::vector<VarType>{VarType::kSE2, VarType::kSE2}));
}

TEST(UserApiTest, PosesPrintAndFactorsAreBuiltInPlace) {
  std::ostringstream a, b;
  a << SE2d(1, 2, 0.5);
  EXPECT_EQ(a.str(), "SE2(1, 2, 0.5)");
  b << SE3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(b.str(), "SE3(t: 1, 2, 3; q: 0, 0, 0, 1)");
  FactorGraph g;
  BetweenSE2& f = g.Add<BetweenSE2>(3, 4, SE2d(1, 0, 0), SqrtInformation::Identity(3));
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(&g.at(0), &f);
  EXPECT_EQ(f.keys(), (std::vector<Key>{3, 4}));
}

TEST(UserApiTest, FactorsAreRemovedByTheHandleAddingThemReturned) {
  FactorGraph g;
  const SqrtInformation n = SqrtInformation::Identity(3);
  const FactorId a = g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), n));
  g.Add<BetweenSE2>(1, 2, SE2d(1, 0, 0), n);
  const FactorId b = g.id(1);
  const FactorId c = g.Add(std::make_unique<BetweenSE2>(2, 3, SE2d(1, 0, 0), n));
  EXPECT_NE(a, b);
  EXPECT_TRUE(g.Remove(b));
  EXPECT_FALSE(g.Remove(b));
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g.at(0).keys(), (std::vector<Key>{0, 1}));  // the others keep their order
  EXPECT_EQ(g.at(1).keys(), (std::vector<Key>{2, 3}));
  std::size_t i;
  ASSERT_TRUE(g.IndexOf(c, &i));
  EXPECT_EQ(i, 1u);
  const FactorGraph copy = g;  // a copy keeps the handles
  EXPECT_EQ(copy.id(1), c);
  FactorGraph h = g;
  const FactorId d = h.Add(std::make_unique<BetweenSE2>(3, 4, SE2d(1, 0, 0), n));
  EXPECT_GT(d, c);  // never reused
  EXPECT_TRUE(h.Remove(a));
  EXPECT_EQ(h.at(0).keys(), (std::vector<Key>{2, 3}));
}

TEST(NoiseTest, FromSigmasIsDiagonalAndNamesABadAxis) {
  const SqrtInformation n = SqrtInformation::FromSigmas(Eigen::Vector3d(0.1, 0.2, 0.05));
  const Eigen::MatrixXd info = n.Information();
  EXPECT_NEAR(info(0, 0), 100, 1e-9);
  EXPECT_NEAR(info(1, 1), 25, 1e-9);
  EXPECT_NEAR(info(2, 2), 400, 1e-9);
  EXPECT_EQ(info(0, 1), 0);
  EXPECT_CONTAINS(ErrorOf([] { SqrtInformation::FromSigmas(Eigen::Vector2d(1, -1)); }), "sigma of axis 1 is -1");
  // Larger than the inline size: stored on the heap, same behaviour.
  Eigen::VectorXd s(9);
  for (int i = 0; i < 9; ++i) s[i] = 0.5 + i;
  const SqrtInformation big = SqrtInformation::FromSigmas(s);
  EXPECT_EQ(big.dim(), 9);
  EXPECT_NEAR(big.Information()(8, 8), 1 / (8.5 * 8.5), 1e-12);
  Eigen::MatrixXd omega = Eigen::MatrixXd::Identity(9, 9) * 4;
  omega(0, 8) = omega(8, 0) = 1;
  const SqrtInformation full = SqrtInformation::FromInformation(omega);
  EXPECT_LT((full.Information() - omega).norm(), 1e-12);
}

}  // namespace
}  // namespace tether
