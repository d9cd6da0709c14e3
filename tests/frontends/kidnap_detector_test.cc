// The kidnap detector on hand-made sequences: the average filter, the cost rule (the thesis's
// Algorithm 13: the filtered cost against the last filtered value before its window), the
// independent signal (a break with the scan before), the declaration only where both agree,
// exactly at the scan the rule names, the warm-up, Reset, and the options' checks.
#include "tether/frontends/lidar/mapping/kidnap_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tether/core/error.h"

namespace tether {
namespace lidar {
namespace {

KidnapOptions Options(int f, double t) {
  KidnapOptions o;
  o.filter_size = f;
  o.threshold = t;
  return o;
}

struct Fired {
  std::vector<int> cost_rule, broke, detected;
};

// Scans (from 0) where each signal fires on `costs` and `overlaps`.
Fired Signals(const KidnapOptions& o, const std::vector<double>& costs, const std::vector<double>& overlaps) {
  KidnapDetector d(o);
  Fired f;
  for (std::size_t i = 0; i < costs.size(); ++i) {
    const KidnapStep s = d.Add(costs[i], overlaps[i]);
    const int at = static_cast<int>(i);
    if (s.cost_rule) f.cost_rule.push_back(at);
    if (s.broke) f.broke.push_back(at);
    if (s.detected) f.detected.push_back(at);
  }
  return f;
}

// 20 scans costing 0.3 that overlap their predecessor by 0.9.
std::vector<double> Flat(double v = 0.3) { return std::vector<double>(20, v); }

TEST(KidnapDetectorTest, TheFilterAndTheRatio) {
  KidnapDetector d(Options(3, 1.5));
  EXPECT_DOUBLE_EQ(d.Add(0.3, 0.9).filtered, 0.3);
  EXPECT_DOUBLE_EQ(d.Add(0.6, 0.9).filtered, 0.45);
  EXPECT_DOUBLE_EQ(d.Add(0.9, 0.9).filtered, 0.6);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(d.Add(0.3, 0.9).ratio, 0);  // fewer than 2 f costs
  const KidnapStep s = d.Add(0.6, 0.9);                             // (0.3 0.6 0.9) (0.3 0.3 0.6)
  EXPECT_DOUBLE_EQ(s.filtered, 0.4);
  EXPECT_DOUBLE_EQ(s.before, 0.6);  // what the ratio compares with, for the relocation's check
  EXPECT_DOUBLE_EQ(s.ratio, 0.4 / 0.6);
}

TEST(KidnapDetectorTest, AKidnapIsDeclaredFMinusOneScansAfterIt) {
  // At scan 12 the cost steps from 0.3 to 0.6 and that scan breaks with the one before. With
  // f = 3 the window holds only scans after the step at 14: ratio 2 there, declared there.
  std::vector<double> costs = Flat(), overlaps = Flat(0.9);
  for (std::size_t i = 12; i < costs.size(); ++i) costs[i] = 0.6;
  overlaps[12] = 0.1;
  const Fired f = Signals(Options(3, 1.5), costs, overlaps);
  EXPECT_EQ(f.broke, std::vector<int>({12}));
  // (0.3 0.3 0.6) / 0.3 = 1.33 at 12; (0.3 0.6 0.6) / 0.3 = 1.67: the rule already fires at 13
  // (its window opened at 11, no break), then at 14 (2); at 15 0.6 / 0.4 = 1.5, not above.
  EXPECT_EQ(f.cost_rule, std::vector<int>({13, 14}));
  EXPECT_EQ(f.detected, std::vector<int>({14}));
  // With f = 1 the rule compares raw costs: declared at the step itself.
  EXPECT_EQ(Signals(Options(1, 1.5), costs, overlaps).detected, std::vector<int>({12}));
}

TEST(KidnapDetectorTest, NeitherSignalAloneDeclaresAKidnap) {
  std::vector<double> costs = Flat(), overlaps = Flat(0.9);
  // A rise without a break (a robot entering a part the submap has not seen).
  for (std::size_t i = 12; i < costs.size(); ++i) costs[i] = 0.6;
  Fired f = Signals(Options(3, 1.5), costs, overlaps);
  EXPECT_FALSE(f.cost_rule.empty());
  EXPECT_TRUE(f.detected.empty());
  // A break without a rise (a turn in a corner, the scene changed but the submap holds it).
  costs = Flat();
  overlaps[12] = 0.1;
  f = Signals(Options(3, 1.5), costs, overlaps);
  EXPECT_EQ(f.broke, std::vector<int>({12}));
  EXPECT_TRUE(f.detected.empty());
  // A single bad scan that breaks: (0.3 + 0.3 + 0.9) / 3 / 0.3 = 1.67 at 12 (a window opened at
  // 10, no break there); at 14 the window (0.9 0.3 0.3) opened at the break but the rise is
  // (1.5 / 3) / 0.3 = 1.67 too. f = 3 and T = 1.8: nothing.
  costs[12] = 0.9;
  EXPECT_TRUE(Signals(Options(3, 1.8), costs, overlaps).detected.empty());
  // No overlap known (the first scan): never a break.
  EXPECT_FALSE(KidnapDetector().Add(0.3, -1).broke);
}

TEST(KidnapDetectorTest, NothingBeforeTwoWindowsAndAfterReset) {
  // A step at scan 3 with f = 3: the first ratio is at scan 5.
  std::vector<double> costs = {0.2, 0.2, 0.2, 0.8, 0.8, 0.8, 0.8}, overlaps = {-1, 0.9, 0.9, 0.1, 0.9, 0.9, 0.9};
  EXPECT_EQ(Signals(Options(3, 1.5), costs, overlaps).detected, std::vector<int>({5}));
  costs = {0.2, 0.8, 0.8, 0.8, 0.8};
  overlaps = {-1, 0.1, 0.9, 0.9, 0.9};
  EXPECT_TRUE(Signals(Options(3, 1.5), costs, overlaps).detected.empty());
  KidnapDetector d(Options(1, 1.5));
  d.Add(0.2, 0.9);
  d.Add(0.2, 0.9);
  EXPECT_TRUE(d.Add(0.8, 0.1).detected);
  d.Reset();
  EXPECT_FALSE(d.Add(0.2, 0.9).detected);
  EXPECT_EQ(d.Add(0.8, 0.1).ratio, 4);
}

TEST(KidnapDetectorTest, OptionsAreChecked) {
  std::string why;
  KidnapOptions o;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.filter_size = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("filter_size"), std::string::npos);
  o = KidnapOptions();
  o.threshold = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("threshold"), std::string::npos);
  o = KidnapOptions();
  o.threshold = NAN;
  EXPECT_FALSE(o.IsValid(nullptr));
  o = KidnapOptions();
  o.max_overlap = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_overlap"), std::string::npos);
  o = KidnapOptions();
  o.relocate_window = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("relocate_window"), std::string::npos);
  o = KidnapOptions();
  o.relocate_max_rise = 0.9;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("relocate_max_rise"), std::string::npos);
  o = KidnapOptions();
  o.relocate_min_score = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("relocate_min_score"), std::string::npos);
  o = KidnapOptions();
  o.relocate_window = 0;  // off
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o = KidnapOptions();
  o.hit_probability = 0.5;
  EXPECT_FALSE(o.IsValid(nullptr));
  EXPECT_THROW(KidnapDetector{o}, InvalidArgument);
  KidnapDetector d;
  EXPECT_THROW(d.Add(NAN, 0.5), InvalidArgument);
}

}  // namespace
}  // namespace lidar
}  // namespace tether
