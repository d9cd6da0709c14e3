#pragma once
// The fast correlative scan matcher (Hess et al. 2016, section V): the best pose of a scan in a
// large window around a guess, found by branch and bound over the same candidates an
// exhaustive search would score, with the same answer. For loop closure: a scan against a
// finished submap.
//
// Candidates: rotations theta_k = guess.theta + k delta_theta, |k| <= K, with
// delta_theta = arccos(1 - r^2 / (2 d_max^2)) (r the resolution, d_max the farthest point:
// no point moves by more than one cell between neighbouring rotations); translations
// guess.t + (dx, dy) r with integer |dx|, |dy| <= W. A candidate's score is the mean of the
// grid's probabilities at the cells of the moved points (unknown cells count as the grid's
// minimum probability).
//
// Bound: precomputation grid h holds, at cell c, the largest value of the cells
// c + [0, 2^h)^2. A node (k, dx, dy, h) stands for the 2^h x 2^h translations from (dx, dy);
// scored on grid h its mean bounds every candidate below it. Depth first, children in order of
// their bound, a node is cut once its bound is not above the best score found (at first
// min_score): the best candidate is exact.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "tether/core/se2.h"
#include "tether/factors/probability_grid.h"

namespace tether {
namespace lidar {

struct FastMatcherOptions {
  /// Half the side of the square of translations searched (m): 3.5 is a 7 m x 7 m window.
  double linear_search_window = 3.5;
  /// Half the range of rotations searched (rad): 15 degrees, a 30-degree window.
  double angular_search_window = 0.26179938779914941;
  /// Precomputation grids 0 .. depth - 1: the top nodes cover 2^(depth - 1) cells a side.
  int branch_and_bound_depth = 7;
  /// The rotation step (rad); 0: from the resolution and the farthest point, as above.
  double angular_step = 0;
  bool IsValid(std::string* why) const;
};

/// The max-filtered copies of a grid, one per height, and the probabilities the search adds.
/// Height 0 holds the grid's own 15-bit values, each read as its exact probability. Heights
/// 1 and up hold one byte a cell: the largest value over the window, rounded up to one of 256
/// levels, read as the largest probability of its level. So a height's probability bounds
/// every cell below it, and lies at most one level, (max - min probability) / 255, above the
/// true maximum: the bounds stay admissible (the search's answer is the exhaustive one) at
/// half the memory, and the byte table fits the first-level cache.
class PrecomputationGrids {
 public:
  /// The most offsets Accumulate takes at once.
  static constexpr int kMaxOffsets = 64;
  /// Throws InvalidArgument for depth < 1 or above 16.
  PrecomputationGrids(const ProbabilityGrid& grid, int depth);
  int depth() const { return static_cast<int>(upper_.size()) + 1; }
  /// Height 0: the probability of the grid's cell c (unknown: the grid's minimum). Height h:
  /// a bound of the probabilities over c + [0, 2^h)^2, within one level above their maximum.
  float Bound(int h, const ProbabilityGrid::Cell& c) const {
    const ProbabilityGrid::Cell d = c - min_cell_;
    const bool inside = d.x() >= 0 && d.y() >= 0 && d.x() < size_.x() && d.y() < size_.y();
    const std::size_t i = inside ? static_cast<std::size_t>(d.y() * size_.x() + d.x()) : 0;
    if (h == 0) return level0_table_[inside ? level0_[i] : ProbabilityGrid::kUnknownValue];
    return upper_table_[inside ? upper_[static_cast<std::size_t>(h - 1)][i] : 0];
  }
  /// For each of `count` offsets o_j (count <= kMaxOffsets), adds Bound(h, c + o_j) to
  /// sums[j] over the cells c in order: the same sums as one offset at a time, with the offsets'
  /// additions independent of each other.
  void Accumulate(int h, const std::vector<ProbabilityGrid::Cell>& cells, const ProbabilityGrid::Cell* offsets,
                  int count, float* sums) const;

 private:
  template <typename T>
  void AccumulateLevel(const std::vector<T>& level, const float* table, int h,
                       const std::vector<ProbabilityGrid::Cell>& cells, const ProbabilityGrid::Cell* offsets, int count,
                       float* sums) const;
  // Every level covers the same box (the top level's: the grid's known cells widened by
  // 2^(depth - 1) - 1 cells below), row-major.
  ProbabilityGrid::Cell min_cell_ = ProbabilityGrid::Cell::Zero();
  ProbabilityGrid::Cell size_ = ProbabilityGrid::Cell::Zero();
  std::vector<std::uint16_t> level0_;
  std::vector<std::vector<std::uint8_t>> upper_;  // heights 1 .. depth - 1
  std::vector<float> level0_table_;               // per 15-bit value
  float upper_table_[256] = {};                   // per level byte
};

struct FastMatch {
  bool found = false;  ///< a candidate scored above min_score
  SE2d pose;           ///< the best candidate (the guess where none was found)
  double score = 0;    ///< its mean probability
  long nodes = 0;      ///< nodes (inner and leaves) scored
  double angular_step = 0;
  int rotations = 0;     ///< 2 K + 1
  int translations = 0;  ///< 2 W + 1 a side
  /// The best candidate lies on the window's edge (its rotation or a translation at the
  /// largest offset searched): the score may still rise beyond the window, as where a scan
  /// overlaps the submap's known area more the further it is pushed into it. MatchChecked
  /// also sets it where the best's translation lies within rival_distance of the edge: the
  /// candidates that count as the same match then reach past the window. Rotations searched
  /// all the way round (an angular window of pi) have no edge.
  bool on_edge = false;
  /// Set by MatchChecked only: a candidate away from the best scores nearly as well.
  bool ambiguous = false;
};

class FastCorrelativeScanMatcher2D {
 public:
  /// Precomputes the grids of `grid`, which must outlive the matcher and not change. Throws
  /// InvalidArgument for invalid options.
  FastCorrelativeScanMatcher2D(const ProbabilityGrid& grid, const FastMatcherOptions& options = {});

  /// The best candidate around `guess` (the scan's pose in the grid's frame) for `points` (the
  /// scan in its own frame), if its score is above min_score. Throws InvalidArgument for no
  /// points, or points or a guess that are not finite.
  FastMatch Match(const SE2d& guess, const std::vector<Eigen::Vector2d>& points, double min_score) const;
  /// Whether the match `best` (what Match returned for the same guess and points) is
  /// ambiguous: some candidate at least `min_distance` (m) from it, or at least `min_angle`
  /// (rad) turned from it, scores above `min_score` (a corridor whose walls match anywhere
  /// along it, a repeated room). Branch and bound as Match, over the candidates outside that
  /// neighbourhood, stopping at the first one found. Throws as Match, and InvalidArgument for
  /// a distance or angle that is negative or not finite.
  bool HasRival(const SE2d& guess, const std::vector<Eigen::Vector2d>& points, const SE2d& best, double min_distance,
                double min_angle, double min_score) const;
  /// Match, and where its best is found and not on the window's edge, HasRival on the same
  /// candidates (prepared once) with min_score max(min_score, rival_ratio * score):
  /// FastMatch::ambiguous. rival_ratio 0 skips the rival search. linear_window: the half side
  /// of the square of translations searched by this call (m); negative: the options'
  /// linear_search_window. angular_window: half the rotations searched by this call (rad, at
  /// most pi); negative: the options' angular_search_window. Throws as Match and HasRival, for
  /// a ratio outside [0, 1] and for a window that is not finite. angular_step: the rotation
  /// step of this call (rad; negative: the options'); a step coarser than the one rule above
  /// makes the search faster and no longer exact between rotations (a global search).
  FastMatch MatchChecked(const SE2d& guess, const std::vector<Eigen::Vector2d>& points, double min_score,
                         double rival_distance, double rival_angle, double rival_ratio, double linear_window = -1,
                         double angular_window = -1, double angular_step = -1) const;
  /// The same candidates scored one by one: the reference for Match, and its speed-up.
  FastMatch MatchExhaustive(const SE2d& guess, const std::vector<Eigen::Vector2d>& points, double min_score) const;

  const FastMatcherOptions& options() const { return options_; }

 private:
  struct Setup;
  // Candidates left out of a search: within `radius` cells and `angle` rotation steps of the
  // candidate (k, dx, dy).
  struct Exclusion {
    int k = 0, dx = 0, dy = 0;
    double radius = 0, angle = 0;
  };
  Setup Prepare(const SE2d& guess, const std::vector<Eigen::Vector2d>& points, double linear_window,
                double angular_window, double angular_step = -1) const;
  FastMatch Search(const Setup& s, const SE2d& guess, std::size_t n_points, double min_score,
                   const Exclusion* exclude) const;
  bool Rival(const Setup& s, const SE2d& guess, std::size_t n_points, const SE2d& best, double min_distance,
             double min_angle, double min_score) const;

  const ProbabilityGrid& grid_;
  FastMatcherOptions options_;
  PrecomputationGrids precomputed_;
};

}  // namespace lidar
}  // namespace tether
