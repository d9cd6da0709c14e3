// Robust losses from plugins: the example plugin barron_loss (plugins/examples/barron_loss)
// registers Barron's general and adaptive loss as "barron". Its rho' and rho'' against central
// differences for alpha from -inf to 4, its closed forms at alpha 2, 1, 0, -2 and -inf and its
// continuity near them, the registry entry and the loader's bookkeeping (a second loader,
// removal and reload, a plugin that claims a built-in name), and a solve of a generated pose
// graph with wrong loop closures that the loss rejects.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/robust_rules.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }
std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}

// Loads barron_loss into the process-wide registries, as `--plugin` does.
LoadedPlugin LoadBarron() {
  static PluginLoader loader(DefaultRegistry());
  return loader.Load(PluginPath("barron_loss"));
}

std::shared_ptr<const LossFunction> Barron(double c, double alpha) {
  LoadBarron();
  return MakeLoss("barron:" + FormatDouble(c) + ":" + FormatDouble(alpha));
}

struct Rho {
  double v, d1, d2;
};
Rho Eval(const LossFunction& l, double s) {
  double r[3];
  l.Evaluate(s, r);
  return {r[0], r[1], r[2]};
}

const double kInf = HUGE_VAL;
const double kPi = std::acos(-1.0);
const double kAlphas[] = {-kInf, -1e6, -2, -0.5, 0, 0.5, 1, 2, 4};
const double kScales[] = {0.5, 1, 3};
const double kSquaredErrors[] = {1e-3, 0.1, 0.5, 1, 2.5, 8, 30, 200};

TEST(BarronLossPlugin, LoadsAndRegistersTheLossByName) {
  const LoadedPlugin p = LoadBarron();
  EXPECT_EQ(p.name, "barron_loss");
  EXPECT_EQ(p.loss_names, std::vector<std::string>{"barron"});
  EXPECT_TRUE(p.type_names.empty());
  EXPECT_NE(p.Summary().find("(0 factor types, 1 robust loss)"), std::string::npos) << p.Summary();
  LossEntry e;
  ASSERT_TRUE(DefaultLossRegistry().Get("barron", &e));
  EXPECT_EQ(e.owner, "barron_loss");
  EXPECT_EQ(e.parameter, "alpha");
  EXPECT_EQ(e.default_parameter, 1);
  EXPECT_NE(RegisteredLossesText().find("barron (plugin barron_loss; barron:SCALE:ALPHA, alpha 1 if omitted)"),
            std::string::npos)
      << RegisteredLossesText();
  const std::vector<std::string> names = RegisteredLossNames();
  EXPECT_EQ(std::count(names.begin(), names.end(), "barron"), 1);
  // The text forms: alpha 1 where it is left out, the scale 1 where that is too.
  EXPECT_EQ(MakeLoss("barron:2")->name(), "barron:2:1");
  EXPECT_EQ(MakeLoss("barron")->name(), "barron:1:1");
  EXPECT_EQ(MakeLoss("barron:0.5:-2")->name(), "barron:0.5:-2");
  EXPECT_EQ(MakeLoss("barron:1:-inf")->name(), "barron:1:-inf");
  // The same name resolves in a rule.
  EXPECT_EQ(ParseRobustRule("loop=barron:1:0").loss->name(), "barron:1:0");
}

TEST(BarronLossPlugin, RefusesWhatItCannotTakeNamingTheText) {
  LoadBarron();
  const struct {
    const char* spec;
    const char* says;
  } bad[] = {
      {"barron:1:inf", "alpha must be below infinity"},
      {"barron:1:nan", "the alpha of the barron loss must be a number, not nan"},
      {"barron:0:1", "must be a finite number above 0"},
      {"barron:-1", "must be a finite number above 0"},
      {"barron:1:x", "the parameter 'x' is not a number"},
      {"barron:1:1:1", "too many ':' fields"},
  };
  for (const auto& b : bad) {
    try {
      MakeLoss(b.spec);
      ADD_FAILURE() << b.spec << " was accepted";
    } catch (const InvalidArgument& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(b.says), std::string::npos) << b.spec << ": " << m;
      EXPECT_NE(m.find(std::string("robust loss '") + b.spec + "'"), std::string::npos) << b.spec << ": " << m;
    }
  }
}

TEST(BarronLossPlugin, DerivativesMatchCentralDifferences) {
  // Alpha across its range, and just beside the values that have branches of their own.
  std::vector<double> alphas(std::begin(kAlphas), std::end(kAlphas));
  for (double a : {2 - 1e-7, 2 + 1e-7, 1e-7, -1e-7}) alphas.push_back(a);
  for (double alpha : alphas)
    for (double c : kScales) {
      const auto loss = Barron(c, alpha);
      for (double s : kSquaredErrors) {
        const double h = 1e-5 * std::max(1.0, s);
        const Rho at = Eval(*loss, s), up = Eval(*loss, s + h), down = Eval(*loss, s - h);
        const double d1 = (up.v - down.v) / (2 * h), d2 = (up.d1 - down.d1) / (2 * h);
        EXPECT_NEAR(at.d1, d1, 1e-7 * std::max(1.0, std::abs(d1))) << loss->name() << " at s = " << s;
        EXPECT_NEAR(at.d2, d2, 1e-6 * std::max(1.0, std::abs(d2)) + 1e-9) << loss->name() << " at s = " << s;
        EXPECT_TRUE(std::isfinite(at.v) && std::isfinite(at.d1) && std::isfinite(at.d2)) << loss->name();
      }
      // Like least squares at 0, for every alpha.
      const Rho zero = Eval(*loss, 0);
      EXPECT_EQ(zero.v, 0) << loss->name();
      EXPECT_DOUBLE_EQ(zero.d1, 1) << loss->name();
    }
}

TEST(BarronLossPlugin, MatchesTheClosedFormsAtItsSpecialAlphas) {
  for (double c : kScales) {
    const double c2 = c * c;
    for (double s : kSquaredErrors) {
      // alpha 2: least squares, exactly.
      Rho r = Eval(*Barron(c, 2), s);
      EXPECT_EQ(r.v, s);
      EXPECT_EQ(r.d1, 1);
      EXPECT_EQ(r.d2, 0);
      // alpha 1: pseudo-Huber (Charbonnier) 2 c^2 (sqrt(1 + s / c^2) - 1).
      const double q = std::sqrt(1 + s / c2);
      r = Eval(*Barron(c, 1), s);
      EXPECT_NEAR(r.v, 2 * c2 * (q - 1), 1e-13 * r.v) << "c " << c << " s " << s;
      EXPECT_NEAR(r.d1, 1 / q, 1e-14);
      EXPECT_NEAR(r.d2, -0.5 / (c2 * q * q * q), 1e-14 / c2);
      // alpha 0: Cauchy's log form 2 c^2 log(1 + s / (2 c^2)), which is cauchy:sqrt(2) c.
      const CauchyLoss cauchy(std::sqrt(2.0) * c);
      const Rho want0 = Eval(cauchy, s);
      r = Eval(*Barron(c, 0), s);
      EXPECT_NEAR(r.v, 2 * c2 * std::log1p(s / (2 * c2)), 1e-13 * r.v);
      EXPECT_NEAR(r.v, want0.v, 1e-13 * r.v);
      EXPECT_NEAR(r.d1, want0.d1, 1e-14);
      EXPECT_NEAR(r.d2, want0.d2, 1e-14 / c2);
      // alpha -2: Geman-McClure 4 c^2 s / (4 c^2 + s), which is gm:2c.
      const Rho want2 = Eval(GemanMcClureLoss(2 * c), s);
      r = Eval(*Barron(c, -2), s);
      EXPECT_NEAR(r.v, 4 * c2 * s / (4 * c2 + s), 1e-13 * r.v);
      EXPECT_NEAR(r.v, want2.v, 1e-13 * r.v);
      EXPECT_NEAR(r.d1, want2.d1, 1e-14);
      EXPECT_NEAR(r.d2, want2.d2, 1e-14 / c2);
      // alpha -inf: Welsch 2 c^2 (1 - exp(-s / (2 c^2))).
      const double w = std::exp(-s / (2 * c2));
      r = Eval(*Barron(c, -kInf), s);
      EXPECT_NEAR(r.v, -2 * c2 * std::expm1(-s / (2 * c2)), 1e-13 * r.v);
      EXPECT_NEAR(r.v, 2 * c2 * (1 - w), 1e-14 * std::max(1.0, r.v));
      EXPECT_NEAR(r.d1, w, 1e-15);
      EXPECT_NEAR(r.d2, -w / (2 * c2), 1e-15);
    }
  }
}

TEST(BarronLossPlugin, IsContinuousInAlphaAcrossItsBranches) {
  const double c = 1.3;
  for (double s : kSquaredErrors) {
    const Rho l2 = Eval(*Barron(c, 2), s), log0 = Eval(*Barron(c, 0), s), welsch = Eval(*Barron(c, -kInf), s);
    for (double a : {2 - 1e-9, 2 + 1e-9}) {
      const Rho r = Eval(*Barron(c, a), s);
      EXPECT_NEAR(r.v, l2.v, 1e-7 * l2.v) << a << " " << s;
      EXPECT_NEAR(r.d1, l2.d1, 1e-7) << a << " " << s;
    }
    for (double a : {1e-9, -1e-9, 1e-300}) {
      const Rho r = Eval(*Barron(c, a), s);
      EXPECT_NEAR(r.v, log0.v, 1e-8 * log0.v) << a << " " << s;
      EXPECT_NEAR(r.d1, log0.d1, 1e-8) << a << " " << s;
      EXPECT_NEAR(r.d2, log0.d2, 1e-8) << a << " " << s;
    }
    const Rho far = Eval(*Barron(c, -1e9), s);
    EXPECT_NEAR(far.v, welsch.v, 1e-7 * welsch.v) << s;
    EXPECT_NEAR(far.d1, welsch.d1, 1e-7) << s;
    EXPECT_NEAR(far.d2, welsch.d2, 1e-7) << s;
  }
}

TEST(BarronLossPlugin, TheSmallerAlphaTheLessAnOutlierCosts) {
  // For alpha <= 2 the loss never costs more than least squares, its weight falls with the
  // error, and at every error a smaller alpha costs less and weighs less (the weight of
  // alpha -inf, exp(-s / 2), is 0 in doubles beyond s = 1491).
  const double ordered[] = {2, 1, 0.5, 0, -0.5, -2, -1e6, -kInf};
  for (double s = 0.01; s < 1e4; s *= 1.7) {
    double last_v = HUGE_VAL, last_w = HUGE_VAL;
    for (double alpha : ordered) {
      const Rho r = Eval(*Barron(1, alpha), s);
      EXPECT_LE(r.v, s * (1 + 1e-15)) << alpha << " " << s;
      EXPECT_GE(r.d1, 0) << alpha << " " << s;
      if (s < 1000) {
        EXPECT_GT(r.d1, 0) << alpha << " " << s;
      }
      EXPECT_LE(r.d1, 1) << alpha << " " << s;
      EXPECT_LE(r.d2, 0) << alpha << " " << s;
      EXPECT_LE(r.v, last_v * (1 + 1e-15)) << alpha << " " << s;
      EXPECT_LE(r.d1, last_w * (1 + 1e-15)) << alpha << " " << s;
      last_v = r.v;
      last_w = r.d1;
    }
  }
  // alpha 4 costs more than least squares beyond the origin (allowed; not robust).
  EXPECT_GT(Eval(*Barron(1, 4), 2).v, 2);
}

TEST(BarronLossPlugin, ASecondLoaderRemovalAndReload) {
  // Another loader into the same process-wide loss registry finds the loss registered.
  LoadBarron();
  Registry other;
  PluginLoader second(other);
  EXPECT_EQ(second.Load(PluginPath("barron_loss")).loss_names, std::vector<std::string>{"barron"});
  // A loader with a registry of its own: removed by owner, a loss made before stays usable,
  // and loading again registers it afresh.
  LossRegistry losses;
  RegisterBuiltinLosses(losses);
  Registry registry;
  PluginLoader loader(registry, DefaultLinearSolverRegistry(), losses);
  loader.Load(PluginPath("barron_loss"));
  const std::shared_ptr<const LossFunction> kept = losses.Make("barron:1:0");
  EXPECT_EQ(losses.RemoveOwner("barron_loss"), 1);
  EXPECT_FALSE(losses.Get("barron"));
  EXPECT_NEAR(Eval(*kept, 2).v, 2 * std::log(2.0), 1e-15);
  EXPECT_EQ(loader.Load(PluginPath("barron_loss")).loss_names, std::vector<std::string>{"barron"});
  LossEntry e;
  ASSERT_TRUE(losses.Get("barron", &e));
  EXPECT_EQ(e.owner, "barron_loss");
}

TEST(BarronLossPlugin, APluginClaimingABuiltinLossNameRegistersNothing) {
  LossRegistry losses;
  RegisterBuiltinLosses(losses);
  Registry registry;
  RegisterBuiltinFactors(registry);
  PluginLoader loader(registry, DefaultLinearSolverRegistry(), losses);
  try {
    loader.Load(TestPlugin("dup_loss"));
    FAIL() << "the plugin claims 'huber' and must be refused";
  } catch (const PluginError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cannot register robust loss 'huber' (owner 'test_dup_loss')"), std::string::npos) << m;
    EXPECT_NE(m.find("taken already by 'huber' (owner 'builtin')"), std::string::npos) << m;
    EXPECT_NE(m.find("nothing of it was registered"), std::string::npos) << m;
  }
  EXPECT_EQ(registry.FindByName("TestDupLossPrior"), nullptr);
  EXPECT_FALSE(losses.Get("test_fine"));
  LossEntry huber;
  ASSERT_TRUE(losses.Get("huber", &huber));
  EXPECT_EQ(huber.owner, "builtin");
  EXPECT_EQ(losses.Names().size(), 5u);
  EXPECT_TRUE(loader.loaded().empty());
}

// Two laps of a circle (radius 10 m, `n` poses a lap) with noisy odometry, true loop closures
// between the laps from every second pose, and `wrong` closures between random poses with
// random relative poses, as precise as the true ones. Poses are keyed 0 .. 2n-1.
struct Laps {
  FactorGraph graph, clean;     // clean: without the wrong closures
  Values truth, odometry;       // odometry: composed from the true first pose
  std::set<std::size_t> wrong;  // indices into graph
};

Laps MakeLaps(int n, int wrong, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const double sp = 0.05, sa = 0.01;
  const SqrtInformation noise = SqrtInformation::FromSigmas(Eigen::Vector3d(sp, sp, sa));
  const auto noisy = [&](const SE2d& z) { return z * SE2d(sp * gauss(rng), sp * gauss(rng), sa * gauss(rng)); };
  Laps l;
  std::vector<SE2d> truth;
  for (int i = 0; i < 2 * n; ++i) {
    const double t = 2 * kPi * i / n;
    truth.emplace_back(10 * std::cos(t), 10 * std::sin(t), t + kPi / 2);
    l.truth.Insert(Key(i), truth.back());
  }
  SE2d at = truth[0];
  l.odometry.Insert(Key(0), at);
  for (int i = 0; i + 1 < 2 * n; ++i) {
    const SE2d z = noisy(truth[i].Inverse() * truth[i + 1]);
    l.graph.Add<BetweenSE2>(Key(i), Key(i + 1), z, noise);
    at = at * z;
    l.odometry.Insert(Key(i + 1), at);
  }
  for (int i = 0; i < n; i += 2) {
    l.graph.Add<BetweenSE2>(Key(i), Key(i + n), noisy(truth[i].Inverse() * truth[i + n]), noise);
    l.graph.at(l.graph.size() - 1).set_loop_closure(true);
  }
  l.clean = l.graph;
  std::uniform_int_distribution<int> pose(0, 2 * n - 1);
  while (static_cast<int>(l.wrong.size()) < wrong) {
    const int i = pose(rng), j = pose(rng);
    if (std::abs(i - j) < 2) continue;
    l.graph.Add<BetweenSE2>(Key(i), Key(j), SE2d(5 * uniform(rng), 5 * uniform(rng), kPi * uniform(rng)), noise);
    l.graph.at(l.graph.size() - 1).set_loop_closure(true);
    l.wrong.insert(l.graph.size() - 1);
  }
  return l;
}

double RmsPositionError(const Values& v, const Values& truth, int poses) {
  double sum = 0;
  for (int i = 0; i < poses; ++i)
    sum += (v.At<SE2d>(Key(i)).translation() - truth.At<SE2d>(Key(i)).translation()).squaredNorm();
  return std::sqrt(sum / poses);
}

TEST(BarronLossPlugin, RejectsWrongLoopClosuresInASolve) {
  // Started as `tether optimize` starts, from the chordal relaxation of the graph with the
  // wrong closures (10 m RMS from the truth here). Measured (RMS position error): 0.128 m
  // without the wrong closures, 11.5 m with them; with barron on the closures 0.174 m
  // (alpha 1), 0.130 m (0), 0.167 m (-2), 0.128 m (-inf, scale 3). Welsch's loss at scale 1
  // gives up true closures too (0.69 m): its weight exp(-s / 2) is nil at 6 sigma.
  const int n = 40;
  const Laps l = MakeLaps(n, 4, 11);
  Values start = l.odometry;
  Initialize(l.graph, &start, InitMethod::kChordal);
  Values clean = start, plain = start;
  ASSERT_TRUE(Optimize(l.clean, &clean).IsSolutionUsable());
  ASSERT_TRUE(Optimize(l.graph, &plain).IsSolutionUsable());
  const double clean_error = RmsPositionError(clean, l.truth, 2 * n);
  const double plain_error = RmsPositionError(plain, l.truth, 2 * n);
  EXPECT_LT(clean_error, 0.2);
  EXPECT_GT(plain_error, 10 * clean_error);  // least squares: the wrong closures bend the map
  LoadBarron();
  for (const char* rule : {"loop=barron:1", "loop=barron:1:0", "loop=barron:1:-2", "loop=barron:3:-inf"}) {
    FactorGraph g = l.graph;
    ASSERT_EQ(ApplyRobustRules({ParseRobustRule(rule)}, DefaultRegistry(), &g), n / 2 + 4) << rule;
    Values v = start;
    const SolverSummary summary = Optimize(g, &v);
    ASSERT_TRUE(summary.IsSolutionUsable()) << rule << ": " << summary.BriefReport();
    // The map is about the one without the wrong closures, and every wrong closure weighs
    // far less than any true one.
    EXPECT_LT(RmsPositionError(v, l.truth, 2 * n), 1.5 * clean_error + 0.02) << rule;
    double wrong_max = 0, true_min = 1;
    for (std::size_t i = 0; i < g.size(); ++i) {
      if (!g.at(i).loop_closure()) continue;
      const double w = RobustWeight(g.at(i).loss(), g.at(i).Chi2(v));
      if (l.wrong.count(i)) {
        wrong_max = std::max(wrong_max, w);
      } else {
        true_min = std::min(true_min, w);
      }
    }
    EXPECT_LT(wrong_max, 0.2) << rule;
    EXPECT_LT(wrong_max, 0.25 * true_min) << rule;
  }
  // alpha 2 is least squares: the same solve as without a loss.
  FactorGraph g = l.graph;
  ApplyRobustRules({ParseRobustRule("all=barron:1:2")}, DefaultRegistry(), &g);
  Values v = start;
  ASSERT_TRUE(Optimize(g, &v).IsSolutionUsable());
  EXPECT_NEAR(RmsPositionError(v, l.truth, 2 * n), plain_error, 1e-9);
}

}  // namespace
}  // namespace tether
