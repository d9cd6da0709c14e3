// The loss registry (tether/core/loss_registry.h): every built-in loss is registered and made
// by name; the text form NAME[:SCALE[:PARAM]] and what is refused, with messages that name the
// text and list the registered losses; duplicate names refused naming both owners; a loss with
// a parameter; removal by owner; the listing for help texts.
#include "tether/core/loss_registry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"

namespace tether {
namespace {

// The message of the InvalidArgument `f` throws ("" and a failure where it throws none).
template <class F>
std::string Refusal(F f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  ADD_FAILURE() << "nothing was thrown";
  return "";
}

bool Has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A loss that records its scale and parameter in its name, rho = s.
struct Recording : LossFunction {
  Recording(double scale, double parameter) : scale(scale), parameter(parameter) {}
  std::string name() const override { return LossName("rec", scale, parameter); }
  void Evaluate(double s, double rho[3]) const override {
    rho[0] = s;
    rho[1] = 1;
    rho[2] = 0;
  }
  double scale, parameter;
};

LossEntry WithParameter(const std::string& name, const std::string& owner) {
  LossEntry e;
  e.name = name;
  e.owner = owner;
  e.parameter = "alpha";
  e.default_parameter = 0.5;
  e.make = [](double scale, double parameter) {
    if (parameter > 10) throw InvalidArgument("alpha must be at most 10, not " + std::to_string(parameter));
    return std::make_shared<Recording>(scale, parameter);
  };
  return e;
}

TEST(LossRegistry, EveryBuiltinLossIsRegisteredAndMadeByName) {
  const std::vector<std::string> builtin = {"huber", "cauchy", "tukey", "gm", "dcs"};
  const std::vector<std::string> names = RegisteredLossNames();
  ASSERT_GE(names.size(), builtin.size());
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 5), builtin);  // registration order
  const std::shared_ptr<const LossFunction> direct[] = {
      std::make_shared<HuberLoss>(1.5), std::make_shared<CauchyLoss>(1.5), std::make_shared<TukeyLoss>(1.5),
      std::make_shared<GemanMcClureLoss>(1.5), std::make_shared<DcsLoss>(1.5)};
  for (std::size_t k = 0; k < builtin.size(); ++k) {
    LossEntry e;
    ASSERT_TRUE(DefaultLossRegistry().Get(builtin[k], &e)) << builtin[k];
    EXPECT_EQ(e.owner, "builtin");
    EXPECT_TRUE(e.parameter.empty()) << builtin[k];
    EXPECT_FALSE(e.description.empty()) << builtin[k];
    const std::shared_ptr<const LossFunction> loss = MakeLoss(builtin[k] + ":1.5");
    ASSERT_NE(loss, nullptr);
    EXPECT_EQ(loss->name(), builtin[k] + ":1.5");
    EXPECT_EQ(loss->name(), direct[k]->name());
    EXPECT_EQ(MakeLoss(builtin[k])->name(), builtin[k] + ":1");  // the scale 1 by default
    for (double s : {0.0, 0.3, 2.0, 40.0}) {
      double a[3], b[3];
      loss->Evaluate(s, a);
      direct[k]->Evaluate(s, b);
      for (int i = 0; i < 3; ++i) EXPECT_EQ(a[i], b[i]) << builtin[k] << " at " << s;
    }
  }
  EXPECT_EQ(RegisteredLossesText().substr(0, 29), "huber, cauchy, tukey, gm, dcs");
  EXPECT_EQ(MakeLoss("huber:1.3")->name(), "huber:1.3");  // the shortest text of the number
}

TEST(LossRegistry, AnUnknownNameListsTheRegisteredOnesAndHowToAddOne) {
  const std::string m = Refusal([] { MakeLoss("welsch:2"); });
  EXPECT_TRUE(Has(m, "robust loss 'welsch:2'")) << m;
  EXPECT_TRUE(Has(m, "unknown kernel 'welsch'")) << m;
  EXPECT_TRUE(Has(m, "registered: huber, cauchy, tukey, gm, dcs")) << m;
  EXPECT_TRUE(Has(m, "PluginRegistrar::AddLoss")) << m;
  EXPECT_TRUE(Has(m, "--plugin")) << m;
  // An empty registry says so.
  const std::string none = Refusal([] { LossRegistry().Make("huber:1"); });
  EXPECT_TRUE(Has(none, "registered: none")) << none;
}

TEST(LossRegistry, TheTextFormIsCheckedFieldByField) {
  LossSpec s = ParseLossSpec("barron:2.5:-0.5");
  EXPECT_EQ(s.name, "barron");
  EXPECT_EQ(s.scale, 2.5);
  EXPECT_TRUE(s.has_parameter);
  EXPECT_EQ(s.parameter, -0.5);
  s = ParseLossSpec("cauchy");
  EXPECT_EQ(s.scale, 1);
  EXPECT_FALSE(s.has_parameter);
  EXPECT_EQ(ParseLossSpec("x:1:-inf").parameter, -HUGE_VAL);
  const struct {
    const char* spec;
    const char* says;
  } bad[] = {
      {":1", "no name before the scale"},
      {"", "no name before the scale"},
      {"huber:", "the scale '' is not a number"},
      {"huber: 1", "the scale ' 1' is not a number"},
      {"huber:1:2:3", "too many ':' fields"},
      {"barron:1:x", "the parameter 'x' is not a number"},
      {"barron:1:", "the parameter '' is not a number"},
  };
  for (const auto& b : bad) {
    const std::string m = Refusal([&] { ParseLossSpec(b.spec); });
    EXPECT_TRUE(Has(m, b.says)) << b.spec << ": " << m;
    EXPECT_TRUE(Has(m, std::string("'") + b.spec + "'")) << b.spec << ": " << m;
    EXPECT_TRUE(Has(m, "NAME:SCALE")) << b.spec << ": " << m;  // says what is accepted
  }
  // Values: the registry checks the scale, and refuses a parameter a loss does not take.
  for (const char* spec : {"huber:0", "huber:-1", "cauchy:nan", "gm:inf", "gm:1e999"}) {
    const std::string m = Refusal([&] { MakeLoss(spec); });
    EXPECT_TRUE(Has(m, "must be a finite number above 0")) << spec << ": " << m;
    EXPECT_TRUE(Has(m, std::string("'") + spec + "'")) << spec << ": " << m;
  }
  const std::string extra = Refusal([] { MakeLoss("huber:1:2"); });
  EXPECT_TRUE(Has(extra, "the huber loss takes no parameter after its scale (write huber:SCALE)")) << extra;
}

TEST(LossRegistry, ALossWithAParameterTakesItOrItsDefault) {
  LossRegistry r;
  r.Register(WithParameter("rec", "mine"));
  EXPECT_EQ(r.Make("rec:2:3")->name(), "rec:2:3");
  EXPECT_EQ(r.Make("rec:2")->name(), "rec:2:0.5");  // the default parameter
  EXPECT_EQ(r.Make("rec")->name(), "rec:1:0.5");
  EXPECT_EQ(r.Make("rec:1:-inf")->name(), "rec:1:-inf");  // infinities reach the factory
  std::string m = Refusal([&] { r.Make("rec:1:nan"); });
  EXPECT_TRUE(Has(m, "the alpha of the rec loss must be a number, not nan")) << m;
  // The factory's own refusal, with the text it refused.
  m = Refusal([&] { r.Make("rec:1:11"); });
  EXPECT_TRUE(Has(m, "robust loss 'rec:1:11': alpha must be at most 10")) << m;
  EXPECT_EQ(r.NamesText(), "rec (plugin mine; rec:SCALE:ALPHA, alpha 0.5 if omitted)");
  const std::vector<LossEntry> entries = r.Entries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].name, "rec");
  EXPECT_EQ(entries[0].owner, "mine");
  EXPECT_EQ(entries[0].parameter, "alpha");
  EXPECT_EQ(entries[0].default_parameter, 0.5);
}

TEST(LossRegistry, AFactoryThatFailsOtherwiseIsAnInvalidArgumentNamingIt) {
  LossRegistry r;
  LossEntry e;
  e.owner = "p";
  e.name = "null";
  e.make = [](double, double) { return std::shared_ptr<const LossFunction>(); };
  r.Register(e);
  e.name = "std";
  e.make = [](double, double) -> std::shared_ptr<const LossFunction> { throw std::runtime_error("boom"); };
  r.Register(e);
  e.name = "odd";
  e.make = [](double, double) -> std::shared_ptr<const LossFunction> { throw 42; };
  r.Register(e);
  std::string m = Refusal([&] { r.Make("null:1"); });
  EXPECT_TRUE(Has(m, "the factory of the loss 'null' (owner 'p') returned no loss")) << m;
  m = Refusal([&] { r.Make("std:1"); });
  EXPECT_TRUE(Has(m, "robust loss 'std:1': the loss 'std' (owner 'p') failed: boom")) << m;
  m = Refusal([&] { r.Make("odd:1"); });
  EXPECT_TRUE(Has(m, "threw something that is not a std::exception")) << m;
}

TEST(LossRegistry, ADuplicateNameIsRefusedNamingBothOwners) {
  LossRegistry r = DefaultLossRegistry();  // a copy: the built-ins
  LossEntry e = WithParameter("huber", "mine");
  std::string m = Refusal([&] { r.Register(e); });
  EXPECT_TRUE(Has(m, "cannot register robust loss 'huber' (owner 'mine')")) << m;
  EXPECT_TRUE(Has(m, "taken already by 'huber' (owner 'builtin')")) << m;
  EXPECT_TRUE(Has(m, "built-in losses cannot be removed")) << m;
  r.Register(WithParameter("shared", "first"));
  m = Refusal([&] { r.Register(WithParameter("shared", "second")); });
  EXPECT_TRUE(Has(m, "'shared' (owner 'second')")) << m;
  EXPECT_TRUE(Has(m, "taken already by 'shared' (owner 'first')")) << m;
  EXPECT_TRUE(Has(m, "or unload 'first' first")) << m;
  LossEntry kept;
  ASSERT_TRUE(r.Get("shared", &kept));
  EXPECT_EQ(kept.owner, "first");
  // The copy is its own: the default registry did not change.
  EXPECT_FALSE(DefaultLossRegistry().Get("shared"));
}

TEST(LossRegistry, IncompleteEntriesAreRefused) {
  LossRegistry r;
  LossEntry e = WithParameter("", "p");
  EXPECT_TRUE(Has(Refusal([&] { r.Register(e); }), "without a name"));
  for (const char* name : {"a:b", "a=b", "two words", "a,b"}) {
    e.name = name;
    const std::string m = Refusal([&] { r.Register(e); });
    EXPECT_TRUE(Has(m, "only letters, digits, '_' and '-'")) << name << ": " << m;
  }
  e.name = "ok_name-2";
  e.make = nullptr;
  EXPECT_TRUE(Has(Refusal([&] { r.Register(e); }), "no factory"));
  e = WithParameter("nan_default", "p");
  e.default_parameter = std::nan("");
  EXPECT_TRUE(Has(Refusal([&] { r.Register(e); }), "its default alpha is NaN"));
  EXPECT_TRUE(r.Names().empty());
}

TEST(LossRegistry, RemovalByNameAndByOwner) {
  LossRegistry r;
  RegisterBuiltinLosses(r);
  r.Register(WithParameter("a", "p"));
  r.Register(WithParameter("b", "p"));
  r.Register(WithParameter("c", "q"));
  EXPECT_EQ(r.Names(), (std::vector<std::string>{"huber", "cauchy", "tukey", "gm", "dcs", "a", "b", "c"}));
  EXPECT_EQ(r.RemoveOwner("p"), 2);
  EXPECT_EQ(r.RemoveOwner("p"), 0);
  EXPECT_TRUE(r.Remove("c"));
  EXPECT_FALSE(r.Remove("c"));
  EXPECT_EQ(r.Names(), (std::vector<std::string>{"huber", "cauchy", "tukey", "gm", "dcs"}));
  // Once removed, the name can be registered again.
  r.Register(WithParameter("a", "q"));
  EXPECT_EQ(r.Make("a:1:2")->name(), "rec:1:2");
}

}  // namespace
}  // namespace tether
