#pragma once
// Kidnap detection: the thesis's Algorithm 13 (each matched scan's local matching cost through
// an average filter of size f_size; a kidnap where the filtered value exceeds T times the last
// filtered value), with an independent signal that must agree.
//
//   KidnapDetector d(options);
//   for each matched scan: KidnapStep s = d.Add(cost, overlap); if (s.detected) ... a new trajectory
//
// - The cost (LocalScanResult::match_cost) is 1 - the mean probability the matched points read
//   in the submap (unknown cells 0.5): 0.1-0.4 where a scan fits, 0.5-0.8 after a kidnap.
// - The filter: filtered(n) = the mean of the last filter_size costs. The cost rule compares it
//   with the last filtered value made only of scans before them, filtered(n - filter_size):
//   ratio(n) = filtered(n) / filtered(n - f). A kidnap raises every cost from the scan it
//   happens at, so the rise is whole once the window holds only scans after it; a single bad
//   scan, or a robot entering a part of the building the submap has not seen (the cost climbs
//   over many scans), rises less.
// - The independent signal: the share of the scan's points within about 0.1 m of a point of the
//   scan before (LocalScanResult::overlap; both at their poses). At 5-40 scans a second the scene
//   hardly changes from one scan to the next (0.6-1 on the benchmark logs); a robot that was
//   carried elsewhere sees another scene (0.01-0.22 at the cuts). A break: below max_overlap.
// - A kidnap is declared at scan n where the cost rule fires and the scan that opened the
//   window (n - f + 1) was a break: n lies f - 1 scans after the kidnap. Measured on the
//   benchmark logs cropped and uncropped (benchmarks/RESULTS.md, "Kidnapped robot"); neither
//   signal alone tells a kidnap from a glitch or a corner (KidnapStep gives both).
// Nothing here reads time stamps: a log whose stamps run on across a kidnap is judged as one
// with a gap. The first 2 f costs of a run (or after Reset) never trigger.
#include <deque>
#include <string>

namespace tether {
namespace lidar {

struct KidnapOptions {
  /// Declare kidnaps (and start a new trajectory on one); off: the signals are still computed
  /// and reported, never acted on.
  bool detect = true;
  int filter_size = 3;     ///< f_size: the costs averaged
  double threshold = 1.5;  ///< T: the filtered cost's rise over the last filtered value before it
  /// A scan breaks with the scan before where less than this share of its points lies near it.
  double max_overlap = 0.25;
  /// A cell counts as occupied for LocalScanResult::hit_fraction from this probability.
  double hit_probability = 0.6;
  /// Before a declared kidnap is acted on, the scan is searched (branch and bound, every
  /// rotation) in the current submap within this distance (m) of the last pose before the
  /// break: where it fits there as well as the scans before the break did (its cost at most
  /// relocate_max_rise times their filtered cost, the best not ambiguous), local SLAM had lost
  /// the robot without its being carried off (a stall of the logger, a slip without odometry):
  /// the scan takes that pose and the trajectory goes on (LocalScanResult::relocated). 0: never.
  double relocate_window = 3;
  double relocate_max_rise = 1.2;
  /// The relocation search's best must score above this (mean probability, as the loop
  /// closures' ConstraintBuilderOptions::min_score).
  double relocate_min_score = 0.55;
  bool IsValid(std::string* why) const;
};

/// One scan through the detector.
struct KidnapStep {
  double cost = 0;
  double filtered = 0;  ///< the mean of the last filter_size costs (fewer at the start)
  /// filtered / the filtered value filter_size scans before (0 until there are 2 f costs).
  double ratio = 0;
  double before = 0;       ///< the filtered value the ratio compares with (0 until 2 f costs)
  bool cost_rule = false;  ///< ratio above the threshold (Algorithm 13 alone)
  bool broke = false;      ///< the independent signal: the scan's overlap below max_overlap
  bool detected = false;   ///< both: the cost rule, and a break at the scan that opened the window
  /// Set by LocalSlam2D: the declaration was withdrawn, the scan fitted the current submap near
  /// the last pose before the break (KidnapOptions::relocate_window); the trajectory went on.
  bool relocated = false;
};

/// Kidnap detection, per scan (LocalScanResult's signals and the detector's step).
struct KidnapRecord {
  long scan = 0;  ///< from 0, in the log's order
  double stamp = 0;
  int trajectory = 0;    ///< the trajectory the scan went into
  bool matched = false;  ///< the scan was matched (the others have no cost)
  double cost = 0, filtered = 0, ratio = 0, hit_fraction = 0;
  double overlap = -1;     ///< -1: no scan before
  bool cost_rule = false;  ///< Algorithm 13 alone fired
  bool broke = false;      ///< the independent signal fired
  bool detected = false;   ///< a kidnap (a new trajectory starts here where KidnapOptions::detect)
  bool relocated = false;  ///< declared, then withdrawn (KidnapStep::relocated)
};

class KidnapDetector {
 public:
  /// Throws InvalidArgument for invalid options.
  explicit KidnapDetector(const KidnapOptions& options = {});
  /// The next matched scan's cost and overlap (negative: none known, never a break).
  /// Detection does not depend on options.detect. Throws InvalidArgument for a cost that is not
  /// finite.
  KidnapStep Add(double cost, double overlap);
  /// Forgets the scans (a new trajectory starts).
  void Reset();
  const KidnapOptions& options() const { return options_; }

 private:
  KidnapOptions options_;
  std::deque<double> costs_;  ///< the last 2 f costs
  std::deque<bool> breaks_;   ///< the last f scans' breaks
};

}  // namespace lidar
}  // namespace tether
