// Values, keys and the square-root information noise model.
#include "tether/core/values.h"

#include <gtest/gtest.h>

#include "tether/core/error.h"
#include "tether/core/key.h"
#include "tether/core/sqrt_information.h"

namespace tether {
namespace {

TEST(KeyTest, SymbolsPrintReadably) {
  EXPECT_EQ(KeyToString(Symbol('x', 12)), "x12");
  EXPECT_EQ(KeyToString(Symbol('l', 0)), "l0");
  EXPECT_EQ(KeyToString(4000000000ull), "4000000000");
  EXPECT_EQ(SymbolLetter(Symbol('x', 7)), 'x');
  EXPECT_EQ(SymbolIndex(Symbol('x', 7)), 7u);
  EXPECT_NE(Symbol('x', 1), Symbol('l', 1));
}

TEST(ValuesTest, TypedStorageIsContiguousPerType) {
  Values v;
  v.Insert(Symbol('x', 0), SE2d(1, 2, 0.5));
  v.Insert(Symbol('l', 0), Eigen::Vector2d(3, 4));
  v.Insert(Symbol('x', 1), SE2d(5, 6, -0.5));
  v.Insert(7, SE3d(SO3d::Exp(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(1, 2, 3)));
  EXPECT_EQ(v.size(), 4u);
  EXPECT_EQ(v.Count(VarType::kSE2), 2u);
  EXPECT_EQ(v.Count(VarType::kSE3), 1u);
  // Both SE2 poses sit back to back in one array, in insertion order.
  const std::vector<double>& se2 = v.Data(VarType::kSE2);
  ASSERT_EQ(se2.size(), 6u);
  EXPECT_EQ(se2[3], 5.0);
  EXPECT_EQ(v.Params(Symbol('x', 1)), se2.data() + 3);
  EXPECT_EQ(v.keys()[1], Symbol('l', 0));
  EXPECT_TRUE(v.At<SE3d>(7).quaternion().isApprox(SO3d::Exp(Eigen::Vector3d(0.1, 0.2, 0.3)).quaternion()));
  EXPECT_EQ(v.At<Eigen::Vector2d>(Symbol('l', 0)).y(), 4.0);
}

TEST(ValuesTest, ErrorsNameTheKey) {
  Values v;
  v.Insert(Symbol('x', 3), SE2d());
  try {
    v.Insert(Symbol('x', 3), SE2d());
    FAIL() << "duplicate insert accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("x3"), std::string::npos) << e.what();
  }
  try {
    v.At<SE3d>(Symbol('x', 3));
    FAIL() << "wrong type accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("holds SE2, not SE3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(v.At<SE2d>(Symbol('x', 4)), InvalidArgument);
}

TEST(ValuesTest, HugeIdsCostNoMoreThanSmallOnes) {
  Values v;
  v.Insert(4000000000ull, SE2d(1, 0, 0));
  v.Insert(0, SE2d());
  EXPECT_EQ(v.Data(VarType::kSE2).capacity() < 100, true);
  EXPECT_EQ(v.At<SE2d>(4000000000ull).x(), 1.0);
}

TEST(ValuesTest, RetractAppliesBoxPlus) {
  Values v;
  v.Insert(1, SE2d(1, 1, 3.0));
  const double d[3] = {1, 0, 0.5};
  v.Retract(1, d);
  const SE2d x = v.At<SE2d>(1);
  EXPECT_NEAR(x.x(), 1 + std::cos(3.0), 1e-12);
  EXPECT_NEAR(x.y(), 1 + std::sin(3.0), 1e-12);
  EXPECT_NEAR(x.theta(), 3.5 - 2 * 3.14159265358979323846, 1e-12);  // wrapped
}

TEST(SqrtInformationTest, WhiteningMatchesInformation) {
  Eigen::Matrix3d omega;
  omega << 4, 1, 0.5, 1, 3, 0.2, 0.5, 0.2, 2;
  const SqrtInformation n = SqrtInformation::FromInformation(omega);
  EXPECT_TRUE(n.Information().isApprox(omega, 1e-12));
  Eigen::Vector3d e(0.3, -1.2, 0.7), w = e;
  n.WhitenVector(w.data());
  EXPECT_NEAR(w.squaredNorm(), e.dot(omega * e), 1e-12);
  EXPECT_TRUE(n.R().isUpperTriangular());
}

// A large diagonal noise (a scan-match factor's hundreds of rows) keeps only its diagonal; it
// whitens, and reports R and the information, exactly as the same matrix given in full does.
TEST(SqrtInformationTest, LargeDiagonalNoiseWhitensAsTheFullMatrix) {
  const int n = 40, cols = 4;
  Eigen::VectorXd sigmas(n);
  for (int i = 0; i < n; ++i) sigmas(i) = 0.1 + 0.05 * i;
  const SqrtInformation diag = SqrtInformation::FromSigmas(sigmas);
  const Eigen::MatrixXd omega = sigmas.cwiseInverse().cwiseAbs2().asDiagonal();
  const SqrtInformation full = SqrtInformation::FromInformation(omega);
  EXPECT_EQ(diag.dim(), n);
  EXPECT_TRUE(diag.R().isApprox(full.R(), 1e-15));
  EXPECT_TRUE(diag.Information().isApprox(omega, 1e-12));
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(n, cols), a, b;
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < cols; ++c) m(i, c) = std::sin(1.0 + i * cols + c);
  a = m;
  b = m;
  diag.WhitenRowMajor(a.data(), cols);
  full.WhitenRowMajor(b.data(), cols);
  EXPECT_TRUE(a.isApprox(b, 1e-15));
  EXPECT_NEAR(a(7, 2), m(7, 2) / sigmas(7), 1e-15);
  Eigen::VectorXd v = m.col(0), w = m.col(0);
  diag.WhitenVector(v.data());
  full.WhitenVector(w.data());
  EXPECT_TRUE(v.isApprox(w, 1e-15));
  const SqrtInformation iso = SqrtInformation::Isotropic(n, 0.5);
  Eigen::VectorXd u = Eigen::VectorXd::Ones(n);
  iso.WhitenVector(u.data());
  EXPECT_TRUE(u.isApprox(Eigen::VectorXd::Constant(n, 2.0)));
  EXPECT_TRUE(iso.R().isApprox(2.0 * Eigen::MatrixXd::Identity(n, n)));
}

TEST(SqrtInformationTest, RejectsAndRepairsNonPositiveDefinite) {
  Eigen::Matrix2d bad;
  bad << 1, 2, 2, 1;  // eigenvalues 3 and -1
  SqrtInformation out;
  std::string why;
  EXPECT_FALSE(SqrtInformation::TryFromInformation(bad, &out, &why));
  EXPECT_NE(why.find("not positive definite"), std::string::npos) << why;
  EXPECT_NE(why.find("-1"), std::string::npos) << why;
  EXPECT_THROW(SqrtInformation::FromInformation(bad), InvalidArgument);
  Eigen::MatrixXd m = bad;
  EXPECT_TRUE(RepairInformation(InformationRepair::kNearestPD, &m));
  EXPECT_TRUE(SqrtInformation::TryFromInformation(m, &out, nullptr));
  // Nearest PD keeps the positive eigen-direction: (1,1)/sqrt2 with eigenvalue 3.
  EXPECT_NEAR((m * Eigen::Vector2d(1, 1)).x(), 3.0, 1e-6);
  m = bad;
  EXPECT_TRUE(RepairInformation(InformationRepair::kIsotropic, &m));
  EXPECT_TRUE(m.isApprox(Eigen::Matrix2d::Identity(), 1e-12));  // trace/n = 1
  Eigen::MatrixXd good = Eigen::Matrix2d::Identity();
  EXPECT_FALSE(RepairInformation(InformationRepair::kNearestPD, &good));
  Eigen::MatrixXd nan = Eigen::Matrix2d::Identity();
  nan(0, 1) = nan(1, 0) = std::nan("");
  EXPECT_FALSE(SqrtInformation::TryFromInformation(nan, &out, &why));
  EXPECT_NE(why.find("NaN"), std::string::npos);
}

}  // namespace
}  // namespace tether
