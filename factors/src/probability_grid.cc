#include "tether/factors/probability_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {

ProbabilityGrid::ProbabilityGrid(double resolution, const Eigen::Vector2d& origin, double min_probability,
                                 double max_probability)
    : resolution_(resolution), origin_(origin), min_probability_(min_probability), max_probability_(max_probability) {
  if (!(std::isfinite(resolution) && resolution > 0)) {
    throw InvalidArgument("ProbabilityGrid: the resolution is " + FormatDouble(resolution) +
                          " m; it must be finite and positive (e.g. 0.05)");
  }
  if (!origin.allFinite()) throw InvalidArgument("ProbabilityGrid: the origin is not finite");
  if (!(min_probability > 0 && min_probability < max_probability && max_probability < 1)) {
    throw InvalidArgument("ProbabilityGrid: the probability range is [" + FormatDouble(min_probability) + ", " +
                          FormatDouble(max_probability) + "]; it must satisfy 0 < min < max < 1 (e.g. 0.12, 0.97)");
  }
  value_step_ = (max_probability - min_probability) / (kMaxValue - 1);
}

ProbabilityGrid::Cell ProbabilityGrid::CellOf(const Eigen::Vector2d& p) const {
  // Clamped before the cast (a cell that far out is refused by GrowToInclude; a cast of a
  // value beyond int would be undefined).
  constexpr double kFar = 1 << 30;
  const Eigen::Vector2d u = ((p - origin_) / resolution_).cwiseMax(-kFar).cwiseMin(kFar);
  return Cell(static_cast<int>(std::floor(u.x())), static_cast<int>(std::floor(u.y())));
}

void ProbabilityGrid::CellsOf(const SE2d& pose, const std::vector<Eigen::Vector2d>& points,
                              std::vector<Cell>* cells) const {
  // pose * p, with the rotation's sine and cosine computed once.
  const double angle = pose.rotation().angle();
  const double c = std::cos(angle), s = std::sin(angle);
  cells->resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d& p = points[i];
    (*cells)[i] = CellOf(pose.translation() + Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y()));
  }
}

Eigen::Vector2d ProbabilityGrid::CellCenter(const Cell& c) const {
  return origin_ + resolution_ * Eigen::Vector2d(c.x() + 0.5, c.y() + 0.5);
}

bool ProbabilityGrid::KnownBounds(Cell* min_corner, Cell* max_corner) const {
  Cell lo(std::numeric_limits<int>::max(), std::numeric_limits<int>::max());
  Cell hi(std::numeric_limits<int>::min(), std::numeric_limits<int>::min());
  bool any = false;
  for (int y = 0; y < size_.y(); ++y) {
    for (int x = 0; x < size_.x(); ++x) {
      if ((cells_[y * size_.x() + x] & kMaxValue) == kUnknownValue) continue;
      any = true;
      lo = lo.min(Cell(x, y));
      hi = hi.max(Cell(x, y));
    }
  }
  if (!any) return false;
  *min_corner = lo + min_cell_;
  *max_corner = hi + min_cell_;
  return true;
}

std::uint16_t ProbabilityGrid::ProbabilityToValue(double p) const {
  const double clamped = std::min(std::max(p, min_probability_), max_probability_);
  const long v = std::lround((clamped - min_probability_) / value_step_) + 1;
  return static_cast<std::uint16_t>(std::min<long>(std::max<long>(v, 1), kMaxValue));
}

void ProbabilityGrid::SetProbability(const Cell& c, double p) {
  if (std::isnan(p)) throw InvalidArgument("ProbabilityGrid::SetProbability: the probability is NaN");
  const int i = GrowToInclude(c);
  cells_[i] = static_cast<std::uint16_t>((cells_[i] & kUpdateMarker) | ProbabilityToValue(p));
}

std::vector<std::uint16_t> ProbabilityGrid::ComputeUpdateTable(double p) const {
  if (!(p > 0 && p < 1)) {
    throw InvalidArgument("ProbabilityGrid: an observation's probability is " + FormatDouble(p) +
                          "; it must lie strictly between 0 and 1 (e.g. hit 0.55, miss 0.49)");
  }
  std::vector<std::uint16_t> table(kMaxValue + 1);
  const double odds = Odds(p);
  table[kUnknownValue] = static_cast<std::uint16_t>(ProbabilityToValue(p) | kUpdateMarker);
  for (int v = 1; v <= kMaxValue; ++v) {
    const double old_p = ValueToProbability(static_cast<std::uint16_t>(v));
    table[v] = static_cast<std::uint16_t>(ProbabilityToValue(ProbabilityFromOdds(Odds(old_p) * odds)) | kUpdateMarker);
  }
  return table;
}

bool ProbabilityGrid::ApplyUpdate(const Cell& c, const std::vector<std::uint16_t>& table) {
  const int i = GrowToInclude(c);
  const std::uint16_t v = cells_[i];
  if (v & kUpdateMarker) return false;
  cells_[i] = table[v];
  updated_.push_back(i);
  return true;
}

void ProbabilityGrid::FinishUpdate() {
  for (int i : updated_) cells_[i] &= kMaxValue;
  updated_.clear();
}

void ProbabilityGrid::ShrinkToKnown() {
  if (!updated_.empty()) {
    throw Error("ProbabilityGrid::ShrinkToKnown: " + std::to_string(updated_.size()) +
                " cells are marked as updated; call FinishUpdate first");
  }
  Cell lo, hi;
  if (!KnownBounds(&lo, &hi)) {
    min_cell_ = Cell::Zero();
    size_ = Cell::Zero();
    std::vector<std::uint16_t>().swap(cells_);
    return;
  }
  const Cell size = hi - lo + 1;
  if ((size == size_).all()) return;
  std::vector<std::uint16_t> kept(static_cast<std::size_t>(size.x()) * size.y());
  for (int y = 0; y < size.y(); ++y) {
    const auto from = cells_.begin() + Index(Cell(lo.x(), lo.y() + y));
    std::copy(from, from + size.x(), kept.begin() + static_cast<std::ptrdiff_t>(y) * size.x());
  }
  cells_.swap(kept);
  min_cell_ = lo;
  size_ = size;
}

void ProbabilityGrid::Restore(const Cell& min_cell, const Cell& size, std::vector<std::uint16_t> values) {
  if (!updated_.empty()) {
    throw Error("ProbabilityGrid::Restore: " + std::to_string(updated_.size()) +
                " cells are marked as updated; call FinishUpdate first");
  }
  const long long last_x = static_cast<long long>(min_cell.x()) + size.x();
  const long long last_y = static_cast<long long>(min_cell.y()) + size.y();
  if (size.x() < 0 || size.y() < 0 || last_x > std::numeric_limits<int>::max() ||
      last_y > std::numeric_limits<int>::max()) {
    throw InvalidArgument("ProbabilityGrid::Restore: a box of " + std::to_string(size.x()) + " x " +
                          std::to_string(size.y()) + " cells from (" + std::to_string(min_cell.x()) + ", " +
                          std::to_string(min_cell.y()) + ") does not fit in int cells");
  }
  const auto count = static_cast<unsigned long long>(size.x()) * static_cast<unsigned long long>(size.y());
  if (values.size() != count) {
    throw InvalidArgument("ProbabilityGrid::Restore: " + std::to_string(values.size()) + " values for a box of " +
                          std::to_string(count) + " cells");
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i] > kMaxValue) {
      throw InvalidArgument("ProbabilityGrid::Restore: value " + std::to_string(i) + " is " +
                            std::to_string(values[i]) + ", above " + std::to_string(kMaxValue));
    }
  }
  min_cell_ = count == 0 ? Cell::Zero() : min_cell;
  size_ = count == 0 ? Cell::Zero() : size;
  cells_ = std::move(values);
}

int ProbabilityGrid::GrowToInclude(const Cell& c) {
  const int existing = Index(c);
  if (existing >= 0) return existing;
  Cell lo = c, hi = c;
  if (size_.x() > 0) {
    // Double the box (at least) on the side that needs it, so that growth is amortised.
    const Cell old_hi = min_cell_ + size_ - 1;
    lo = lo.min(min_cell_);
    hi = hi.max(old_hi);
    if (c.x() < min_cell_.x()) lo.x() = std::min(lo.x(), min_cell_.x() - size_.x());
    if (c.y() < min_cell_.y()) lo.y() = std::min(lo.y(), min_cell_.y() - size_.y());
    if (c.x() > old_hi.x()) hi.x() = std::max(hi.x(), old_hi.x() + size_.x());
    if (c.y() > old_hi.y()) hi.y() = std::max(hi.y(), old_hi.y() + size_.y());
  } else {
    lo -= 32;
    hi += 32;
  }
  const Cell new_size = hi - lo + 1;
  if (static_cast<double>(new_size.x()) * new_size.y() > 4e8) {
    throw InvalidArgument("ProbabilityGrid: writing cell (" + std::to_string(c.x()) + ", " + std::to_string(c.y()) +
                          ") would grow the grid to " + std::to_string(new_size.x()) + " x " +
                          std::to_string(new_size.y()) + " cells; a point is far outside the map (check ranges)");
  }
  std::vector<std::uint16_t> grown(static_cast<std::size_t>(new_size.x()) * new_size.y(), kUnknownValue);
  const Cell shift = min_cell_ - lo;
  for (int y = 0; y < size_.y(); ++y) {
    std::copy_n(cells_.begin() + static_cast<std::ptrdiff_t>(y) * size_.x(), size_.x(),
                grown.begin() + static_cast<std::ptrdiff_t>(y + shift.y()) * new_size.x() + shift.x());
  }
  for (int& i : updated_) i = (i / size_.x() + shift.y()) * new_size.x() + i % size_.x() + shift.x();
  cells_.swap(grown);
  min_cell_ = lo;
  size_ = new_size;
  return Index(c);
}

}  // namespace tether
