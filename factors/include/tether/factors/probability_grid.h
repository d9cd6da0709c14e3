#pragma once
// ProbabilityGrid: a 2D occupancy grid of probabilities on a regular lattice that grows as cells
// are written (the data of a LiDAR submap, and what the scan-match factor reads).
//
// Cell (i, j) covers origin + [i r, (i + 1) r) x [j r, (j + 1) r), r the resolution; its centre
// is origin + (i + 0.5, j + 0.5) r. Any integer cell may be read (a cell never written is
// unknown); writing stores a box of cells that grows, doubling, to include the cell written.
//
// Values are quantised to 15 bits: 0 is unknown, 1..32767 map linearly onto
// [min_probability, max_probability]. The odds update M_new = clamp(odds^-1(odds(M_old) odds(p)))
// becomes one lookup in a table of 32768 entries (ComputeUpdateTable); the top bit marks a cell
// updated during the current scan, so that a cell is updated at most once per scan (hits are
// applied first, so they win) until FinishUpdate clears the marks.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "tether/core/se2.h"

namespace tether {

/// odds(p) = p / (1 - p).
inline double Odds(double p) { return p / (1.0 - p); }
/// The probability of odds o: o / (1 + o).
inline double ProbabilityFromOdds(double o) { return o / (1.0 + o); }

class ProbabilityGrid {
 public:
  using Cell = Eigen::Array2i;
  static constexpr std::uint16_t kUnknownValue = 0;
  static constexpr std::uint16_t kMaxValue = 32767;
  static constexpr std::uint16_t kUpdateMarker = 32768;
  /// Probabilities are clamped to [0.12, 0.97] unless the constructor says otherwise.
  static constexpr double kDefaultMinProbability = 0.12;
  static constexpr double kDefaultMaxProbability = 0.97;

  /// Throws InvalidArgument unless resolution is finite and positive, the origin finite and
  /// 0 < min_probability < max_probability < 1.
  explicit ProbabilityGrid(double resolution, const Eigen::Vector2d& origin = Eigen::Vector2d::Zero(),
                           double min_probability = kDefaultMinProbability,
                           double max_probability = kDefaultMaxProbability);

  double resolution() const { return resolution_; }
  const Eigen::Vector2d& origin() const { return origin_; }
  double min_probability() const { return min_probability_; }
  double max_probability() const { return max_probability_; }

  /// The cell holding point p (map frame).
  Cell CellOf(const Eigen::Vector2d& p) const;
  /// The cells holding pose * p for each of `points` (the same cells as CellOf, one rotation
  /// for all points).
  void CellsOf(const SE2d& pose, const std::vector<Eigen::Vector2d>& points, std::vector<Cell>* cells) const;
  /// The centre of a cell (map frame).
  Eigen::Vector2d CellCenter(const Cell& c) const;

  /// The stored box: cells min_cell() .. min_cell() + size() - 1 (size zero before any write).
  const Cell& min_cell() const { return min_cell_; }
  const Cell& size() const { return size_; }
  /// The smallest box holding every known cell (min and max corner); false where none is known.
  bool KnownBounds(Cell* min_corner, Cell* max_corner) const;

  /// The raw 15-bit value (kUnknownValue outside the stored box).
  std::uint16_t Value(const Cell& c) const {
    const int i = Index(c);
    return i < 0 ? kUnknownValue : static_cast<std::uint16_t>(cells_[i] & kMaxValue);
  }
  /// Where the whole box lo .. hi (inclusive corners) lies in the stored box, the index of lo:
  /// cell lo + (x, y) is then at index + y * stride() + x, read by ValueAt. -1 otherwise.
  int BoxIndex(const Cell& lo, const Cell& hi) const { return Index(hi) < 0 ? -1 : Index(lo); }
  int stride() const { return size_.x(); }
  std::uint16_t ValueAt(int index) const { return static_cast<std::uint16_t>(cells_[index] & kMaxValue); }
  bool IsKnown(const Cell& c) const { return Value(c) != kUnknownValue; }
  /// The cell's probability; an unknown cell reads as min_probability() (it supports no hit).
  double Probability(const Cell& c) const { return ValueToProbability(Value(c)); }
  /// The cell's probability, `unknown` where the cell is unknown.
  double Probability(const Cell& c, double unknown) const {
    const std::uint16_t v = Value(c);
    return v == kUnknownValue ? unknown : ValueToProbability(v);
  }
  /// Sets a cell's probability (clamped to the range); grows the box. Throws for a NaN.
  void SetProbability(const Cell& c, double p);

  /// Quantisation: the value of probability p (clamped), and the probability of a value
  /// (min_probability() for kUnknownValue).
  std::uint16_t ProbabilityToValue(double p) const;
  double ValueToProbability(std::uint16_t v) const {
    return v == kUnknownValue ? min_probability_ : min_probability_ + (v - 1) * value_step_;
  }

  /// The update table for an observation of probability p (p_hit, p_miss): entry v is the
  /// value after the update of a cell of value v, with kUpdateMarker set. An unknown cell takes
  /// p itself (clamped). Throws InvalidArgument unless 0 < p < 1.
  std::vector<std::uint16_t> ComputeUpdateTable(double p) const;
  /// Applies `table` to the cell unless it was updated since the last FinishUpdate; grows the
  /// box. Returns true where it updated the cell.
  bool ApplyUpdate(const Cell& c, const std::vector<std::uint16_t>& table);
  /// Clears the marks of the cells updated since the last FinishUpdate.
  void FinishUpdate();
  /// Crops the stored box to the known cells (what KnownBounds gives), freeing the rest: every
  /// cell reads as before. The box grows by doubling, so a grid whose rays reach far can store
  /// several times the cells it knows. Throws Error while updates are pending.
  void ShrinkToKnown();
  /// Number of cells updated since the last FinishUpdate.
  std::size_t pending_updates() const { return updated_.size(); }
  /// The stored box's raw values, row-major (y rows of x cells; what Restore takes back).
  const std::vector<std::uint16_t>& values() const { return cells_; }
  /// Replaces the stored box: cells min_cell .. min_cell + size - 1 take `values`, row-major (a
  /// saved grid read back). Throws InvalidArgument for a negative size, a box reaching beyond
  /// int cells, a count that is not size.x() * size.y(), or a value above kMaxValue (a marked
  /// cell); Error while updates are pending.
  void Restore(const Cell& min_cell, const Cell& size, std::vector<std::uint16_t> values);

 private:
  int Index(const Cell& c) const {
    const Cell d = c - min_cell_;
    if (d.x() < 0 || d.y() < 0 || d.x() >= size_.x() || d.y() >= size_.y()) return -1;
    return d.y() * size_.x() + d.x();
  }
  /// Index of c in the stored box, growing the box first where c lies outside.
  int GrowToInclude(const Cell& c);

  double resolution_;
  Eigen::Vector2d origin_;
  double min_probability_, max_probability_, value_step_;
  Cell min_cell_ = Cell::Zero();
  Cell size_ = Cell::Zero();
  std::vector<std::uint16_t> cells_;  // row-major over the box, y rows of x cells
  std::vector<int> updated_;          // indices marked since the last FinishUpdate
};

}  // namespace tether
