#include "tether/frontends/lidar/scan_matching/fast_correlative_scan_matcher_2d.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"

namespace tether {
namespace lidar {

using Cell = ProbabilityGrid::Cell;

bool FastMatcherOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = w;
    return false;
  };
  if (!(std::isfinite(linear_search_window) && linear_search_window >= 0)) {
    return fail("linear_search_window must be finite and not negative");
  }
  if (!(std::isfinite(angular_search_window) && angular_search_window >= 0 && angular_search_window <= M_PI)) {
    return fail("angular_search_window must lie in [0, pi]");
  }
  if (branch_and_bound_depth < 1 || branch_and_bound_depth > 16) {
    return fail("branch_and_bound_depth must lie in [1, 16]");
  }
  if (!(std::isfinite(angular_step) && angular_step >= 0)) return fail("angular_step must be finite and not negative");
  return true;
}

namespace {

// The level byte of a 15-bit value: 0 for unknown, rising with the value, 255 for the largest.
std::uint8_t LevelOf(std::uint16_t v) {
  return static_cast<std::uint8_t>((static_cast<int>(v) * 255 + ProbabilityGrid::kMaxValue - 1) /
                                   ProbabilityGrid::kMaxValue);
}

}  // namespace

PrecomputationGrids::PrecomputationGrids(const ProbabilityGrid& grid, int depth) {
  if (depth < 1 || depth > 16) throw InvalidArgument("PrecomputationGrids: depth must lie in [1, 16]");
  level0_table_.resize(ProbabilityGrid::kMaxValue + 1);
  for (int v = 0; v <= ProbabilityGrid::kMaxValue; ++v) {
    level0_table_[static_cast<std::size_t>(v)] =
        static_cast<float>(grid.ValueToProbability(static_cast<std::uint16_t>(v)));
    // Values rise with their probability: the last value of a level is its largest.
    upper_table_[LevelOf(static_cast<std::uint16_t>(v))] = level0_table_[static_cast<std::size_t>(v)];
  }
  const int margin = (1 << (depth - 1)) - 1;
  Cell lo, hi;
  if (grid.KnownBounds(&lo, &hi)) {
    // Outside the known cells every level reads unknown, in the box or not.
    min_cell_ = lo - Cell(margin, margin);
    size_ = hi - lo + 1 + Cell(margin, margin);
  }
  const std::size_t n = static_cast<std::size_t>(size_.x()) * static_cast<std::size_t>(size_.y());
  level0_.assign(n, ProbabilityGrid::kUnknownValue);
  for (int y = 0; y < size_.y(); ++y) {
    for (int x = 0; x < size_.x(); ++x)
      level0_[static_cast<std::size_t>(y * size_.x() + x)] = grid.Value(min_cell_ + Cell(x, y));
  }
  upper_.assign(static_cast<std::size_t>(depth - 1), std::vector<std::uint8_t>(n, 0));
  // The level byte rises with the value, so the byte of a window's largest value is the
  // largest byte over the window.
  const auto at = [&](int h, int x, int y) -> int {
    if (x >= size_.x() || y >= size_.y()) return 0;
    const std::size_t i = static_cast<std::size_t>(y * size_.x() + x);
    return h == 0 ? LevelOf(level0_[i]) : upper_[static_cast<std::size_t>(h - 1)][i];
  };
  for (int h = 1; h < depth; ++h) {
    // The window of height h is four windows of height h - 1, s cells apart.
    const int s = 1 << (h - 1);
    std::vector<std::uint8_t>& top = upper_[static_cast<std::size_t>(h - 1)];
    for (int y = 0; y < size_.y(); ++y) {
      for (int x = 0; x < size_.x(); ++x) {
        top[static_cast<std::size_t>(y * size_.x() + x)] = static_cast<std::uint8_t>(std::max(
            std::max(at(h - 1, x, y), at(h - 1, x + s, y)), std::max(at(h - 1, x, y + s), at(h - 1, x + s, y + s))));
      }
    }
  }
}

template <typename T>
void PrecomputationGrids::AccumulateLevel(const std::vector<T>& level, const float* table, int h,
                                          const std::vector<Cell>& cells, const Cell* offsets, int count,
                                          float* sums) const {
  Cell lo = offsets[0], hi = offsets[0];
  for (int j = 1; j < count; ++j) {
    lo = lo.min(offsets[j]);
    hi = hi.max(offsets[j]);
  }
  // Offset j's index from the index of c + lo.
  int delta[kMaxOffsets];
  for (int j = 0; j < count; ++j) delta[j] = (offsets[j].y() - lo.y()) * size_.x() + (offsets[j].x() - lo.x());
  const T* values = level.data();
  const auto inside = [&](const Cell& c) {
    const Cell a = c + lo - min_cell_, b = c + hi - min_cell_;
    return a.x() >= 0 && a.y() >= 0 && b.x() < size_.x() && b.y() < size_.y() ? values + a.y() * size_.x() + a.x()
                                                                              : nullptr;
  };
  if (count == 4) {
    // A node's four children (the common case): four sums the compiler keeps in registers.
    float s0 = sums[0], s1 = sums[1], s2 = sums[2], s3 = sums[3];
    for (const Cell& c : cells) {
      if (const T* at = inside(c)) {
        s0 += table[at[delta[0]]];
        s1 += table[at[delta[1]]];
        s2 += table[at[delta[2]]];
        s3 += table[at[delta[3]]];
      } else {
        s0 += Bound(h, c + offsets[0]);
        s1 += Bound(h, c + offsets[1]);
        s2 += Bound(h, c + offsets[2]);
        s3 += Bound(h, c + offsets[3]);
      }
    }
    sums[0] = s0;
    sums[1] = s1;
    sums[2] = s2;
    sums[3] = s3;
    return;
  }
  float acc[kMaxOffsets];
  std::copy(sums, sums + count, acc);
  for (const Cell& c : cells) {
    if (const T* at = inside(c)) {
      for (int j = 0; j < count; ++j) acc[j] += table[at[delta[j]]];
    } else {
      for (int j = 0; j < count; ++j) acc[j] += Bound(h, c + offsets[j]);
    }
  }
  std::copy(acc, acc + count, sums);
}

void PrecomputationGrids::Accumulate(int h, const std::vector<Cell>& cells, const Cell* offsets, int count,
                                     float* sums) const {
  if (count < 1 || count > kMaxOffsets) throw InvalidArgument("PrecomputationGrids::Accumulate: 1 to 64 offsets");
  if (h < 0 || h >= depth()) throw InvalidArgument("PrecomputationGrids::Accumulate: no such height");
  if (h == 0) {
    AccumulateLevel(level0_, level0_table_.data(), h, cells, offsets, count, sums);
  } else {
    AccumulateLevel(upper_[static_cast<std::size_t>(h - 1)], upper_table_, h, cells, offsets, count, sums);
  }
}

struct FastCorrelativeScanMatcher2D::Setup {
  double step = 0;
  int k_max = 0;                         // rotations -K..K
  bool full_circle = false;              // the rotations go all the way round: no edge there
  int w = 0;                             // translations -W..W cells
  std::vector<std::vector<Cell>> cells;  // per rotation index k + K: the points' cells at the guess's translation
  // A match that found nothing yet: the guess, with the search's size.
  FastMatch Unfound(const SE2d& guess) const {
    FastMatch m;
    m.pose = guess;
    m.angular_step = step;
    m.rotations = 2 * k_max + 1;
    m.translations = 2 * w + 1;
    return m;
  }
  bool OnEdge(int k, int dx, int dy) const {
    return (k_max > 0 && !full_circle && std::abs(k) == k_max) || (w > 0 && (std::abs(dx) == w || std::abs(dy) == w));
  }
  SE2d Pose(const SE2d& guess, int k, int dx, int dy, double r) const {
    return SE2d(guess.x() + dx * r, guess.y() + dy * r, guess.theta() + k * step);
  }
};

FastCorrelativeScanMatcher2D::FastCorrelativeScanMatcher2D(const ProbabilityGrid& grid,
                                                           const FastMatcherOptions& options)
    : grid_(grid),
      options_(options),
      precomputed_(grid, options.IsValid(nullptr) ? options.branch_and_bound_depth : 1) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("fast correlative scan matcher: " + why);
}

FastCorrelativeScanMatcher2D::Setup FastCorrelativeScanMatcher2D::Prepare(const SE2d& guess,
                                                                          const std::vector<Eigen::Vector2d>& points,
                                                                          double linear_window, double angular_window,
                                                                          double angular_step) const {
  if (points.empty()) throw InvalidArgument("fast correlative scan matcher: the scan has no points");
  if (!std::isfinite(guess.x()) || !std::isfinite(guess.y()) || !std::isfinite(guess.theta())) {
    throw InvalidArgument("fast correlative scan matcher: the guess is not finite");
  }
  double d_max = 0;
  for (const Eigen::Vector2d& p : points) {
    if (!p.allFinite()) throw InvalidArgument("fast correlative scan matcher: a point is not finite");
    d_max = std::max(d_max, p.norm());
  }
  const double r = grid_.resolution();
  Setup s;
  s.step = angular_step > 0 ? angular_step : options_.angular_step;
  if (s.step == 0) {
    // No point moves by more than one cell between neighbouring rotations.
    s.step = d_max > r / 2 ? std::acos(std::max(-1.0, 1 - r * r / (2 * d_max * d_max))) : M_PI / 2;
  }
  const double angles = angular_window < 0 ? options_.angular_search_window : std::min(angular_window, M_PI);
  s.k_max = static_cast<int>(std::ceil(angles / s.step - 1e-9));
  s.full_circle = angles >= M_PI;
  const double window = linear_window < 0 ? options_.linear_search_window : linear_window;
  s.w = static_cast<int>(std::ceil(window / r - 1e-9));
  s.cells.resize(static_cast<std::size_t>(2 * s.k_max + 1));
  for (int k = -s.k_max; k <= s.k_max; ++k) {
    const SE2d pose(guess.x(), guess.y(), guess.theta() + k * s.step);
    grid_.CellsOf(pose, points, &s.cells[static_cast<std::size_t>(k + s.k_max)]);
  }
  return s;
}

FastMatch FastCorrelativeScanMatcher2D::MatchExhaustive(const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                                                        double min_score) const {
  const Setup s = Prepare(guess, points, -1, -1);
  FastMatch m = s.Unfound(guess);
  float best = static_cast<float>(min_score);
  const float n = static_cast<float>(points.size());
  std::vector<Cell> offsets;
  for (int dx = -s.w; dx <= s.w; ++dx) {
    for (int dy = -s.w; dy <= s.w; ++dy) offsets.emplace_back(dx, dy);
  }
  std::vector<float> sums(offsets.size());
  for (int k = -s.k_max; k <= s.k_max; ++k) {
    const std::vector<Cell>& cells = s.cells[static_cast<std::size_t>(k + s.k_max)];
    std::fill(sums.begin(), sums.end(), 0.0f);
    for (std::size_t j = 0; j < offsets.size(); j += PrecomputationGrids::kMaxOffsets) {
      const int count = static_cast<int>(std::min<std::size_t>(PrecomputationGrids::kMaxOffsets, offsets.size() - j));
      precomputed_.Accumulate(0, cells, &offsets[j], count, &sums[j]);
    }
    for (std::size_t j = 0; j < offsets.size(); ++j) {
      const float score = sums[j] / n;
      ++m.nodes;
      if (score > best) {
        best = score;
        m.found = true;
        m.score = score;
        m.pose = s.Pose(guess, k, offsets[j].x(), offsets[j].y(), grid_.resolution());
        m.on_edge = s.OnEdge(k, offsets[j].x(), offsets[j].y());
      }
    }
  }
  return m;
}

namespace {

void CheckRivalNeighbourhood(double distance, double angle) {
  if (!(std::isfinite(distance) && distance >= 0 && std::isfinite(angle) && angle >= 0)) {
    throw InvalidArgument(
        "fast correlative scan matcher: the rival's distance and angle must be finite and not negative");
  }
}

}  // namespace

FastMatch FastCorrelativeScanMatcher2D::Match(const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                                              double min_score) const {
  const Setup s = Prepare(guess, points, -1, -1);
  return Search(s, guess, points.size(), min_score, nullptr);
}

bool FastCorrelativeScanMatcher2D::HasRival(const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                                            const SE2d& best, double min_distance, double min_angle,
                                            double min_score) const {
  CheckRivalNeighbourhood(min_distance, min_angle);
  return Rival(Prepare(guess, points, -1, -1), guess, points.size(), best, min_distance, min_angle, min_score);
}

FastMatch FastCorrelativeScanMatcher2D::MatchChecked(const SE2d& guess, const std::vector<Eigen::Vector2d>& points,
                                                     double min_score, double rival_distance, double rival_angle,
                                                     double rival_ratio, double linear_window, double angular_window,
                                                     double angular_step) const {
  CheckRivalNeighbourhood(rival_distance, rival_angle);
  if (!(rival_ratio >= 0 && rival_ratio <= 1)) {
    throw InvalidArgument("fast correlative scan matcher: the rival ratio must lie in [0, 1]");
  }
  if (!std::isfinite(linear_window) || !std::isfinite(angular_window) || !std::isfinite(angular_step)) {
    throw InvalidArgument("fast correlative scan matcher: the search window and step must be finite");
  }
  const Setup s = Prepare(guess, points, linear_window, angular_window, angular_step);
  FastMatch m = Search(s, guess, points.size(), min_score, nullptr);
  if (m.found && !m.on_edge) {
    // The best's neighbourhood (what counts as the same match) reaches past the window's
    // translations: the score may still rise beyond them (a scan pushed into the submap's
    // known part), as on the edge itself. Rotations near the edge stay: a turn of a few
    // degrees changes the score a lot, and local SLAM's worst turns lie there (fr079).
    const double r = grid_.resolution();
    const double d = std::max(std::abs(m.pose.x() - guess.x()), std::abs(m.pose.y() - guess.y())) / r;
    m.on_edge = s.w > 0 && s.w - d < rival_distance / r - 1e-9;
  }
  if (m.found && !m.on_edge && rival_ratio > 0) {
    m.ambiguous = Rival(s, guess, points.size(), m.pose, rival_distance, rival_angle,
                        std::max(min_score, rival_ratio * static_cast<double>(m.score)));
  }
  return m;
}

bool FastCorrelativeScanMatcher2D::Rival(const Setup& s, const SE2d& guess, std::size_t n_points, const SE2d& best,
                                         double min_distance, double min_angle, double min_score) const {
  const double r = grid_.resolution();
  Exclusion e;
  e.k = static_cast<int>(std::lround(WrapAngle(best.theta() - guess.theta()) / s.step));
  e.dx = static_cast<int>(std::lround((best.x() - guess.x()) / r));
  e.dy = static_cast<int>(std::lround((best.y() - guess.y()) / r));
  e.radius = min_distance / r;
  e.angle = min_angle / s.step;
  return Search(s, guess, n_points, min_score, &e).found;
}

// Branch and bound over the candidates of s. With an exclusion, the candidates near its
// centre (within both its radius and its angle) are left out, and the search stops at the
// first candidate above min_score (the question is only whether one exists).
FastMatch FastCorrelativeScanMatcher2D::Search(const Setup& s, const SE2d& guess, std::size_t n_points,
                                               double min_score, const Exclusion* exclude) const {
  FastMatch m = s.Unfound(guess);
  struct Node {
    int k, dx, dy;
    float score;
  };
  const float n = static_cast<float>(n_points);
  // Scores nodes of height h that share one rotation (at most kMaxOffsets of them).
  std::vector<Cell> offsets(PrecomputationGrids::kMaxOffsets, Cell::Zero());
  const auto score = [&](int h, Node* nodes, int count) {
    float sums[PrecomputationGrids::kMaxOffsets] = {};
    for (int j = 0; j < count; ++j) offsets[j] = Cell(nodes[j].dx, nodes[j].dy);
    precomputed_.Accumulate(h, s.cells[static_cast<std::size_t>(nodes[0].k + s.k_max)], offsets.data(), count, sums);
    for (int j = 0; j < count; ++j) nodes[j].score = sums[j] / n;
    m.nodes += count;
  };
  // Whether every candidate of a node of height h is near the exclusion's centre: its
  // rotation, and the corners of its square of translations (the disc is convex).
  const auto excluded = [&](const Node& node, int h) {
    if (exclude == nullptr) return false;
    int dk = std::abs(node.k - exclude->k);
    if (s.full_circle) dk = std::min(dk, 2 * s.k_max + 1 - dk);  // the rotations wrap round
    if (dk >= exclude->angle) return false;
    const double x0 = node.dx - exclude->dx, y0 = node.dy - exclude->dy, side = (1 << h) - 1;
    const double fx = std::max(std::abs(x0), std::abs(x0 + side)), fy = std::max(std::abs(y0), std::abs(y0 + side));
    return fx * fx + fy * fy < exclude->radius * exclude->radius;
  };
  const auto by_score = [](const Node& a, const Node& b) { return a.score > b.score; };
  const int top = precomputed_.depth() - 1;
  const int width = 1 << top;
  std::vector<Node> roots;
  for (int k = -s.k_max; k <= s.k_max; ++k) {
    const std::size_t first = roots.size();
    for (int dx = -s.w; dx <= s.w; dx += width) {
      for (int dy = -s.w; dy <= s.w; dy += width) roots.push_back(Node{k, dx, dy, 0});
    }
    for (std::size_t j = first; j < roots.size(); j += PrecomputationGrids::kMaxOffsets) {
      score(top, &roots[j],
            static_cast<int>(std::min<std::size_t>(PrecomputationGrids::kMaxOffsets, roots.size() - j)));
    }
  }
  std::stable_sort(roots.begin(), roots.end(), by_score);
  float best = static_cast<float>(min_score);
  Node best_node{0, 0, 0, 0};
  // Depth first, siblings in order of their bound: a node whose bound is not above the best
  // leaf so far is cut (its later siblings, no better, are cut as they come up).
  struct Entry {
    Node node;
    int h;
  };
  std::vector<Entry> stack;
  stack.reserve(roots.size() + 4 * static_cast<std::size_t>(top) + 4);
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back(Entry{*it, top});
  while (!stack.empty()) {
    const Entry e = stack.back();
    stack.pop_back();
    const Node& node = e.node;
    if (!(node.score > best) || excluded(node, e.h)) continue;
    if (e.h == 0) {
      best = node.score;
      best_node = node;
      m.found = true;
      if (exclude != nullptr) break;  // a rival exists: that is all the question asks
      continue;
    }
    const int half = 1 << (e.h - 1);
    Node children[4];
    int count = 0;
    for (int ox : {0, half}) {
      for (int oy : {0, half}) {
        const int dx = node.dx + ox, dy = node.dy + oy;
        if (dx > s.w || dy > s.w) continue;
        children[count++] = Node{node.k, dx, dy, 0};
      }
    }
    score(e.h - 1, children, count);
    // Highest bound first, ties in the order made (a stable insertion sort).
    for (int i = 1; i < count; ++i) {
      for (int j = i; j > 0 && by_score(children[j], children[j - 1]); --j) std::swap(children[j], children[j - 1]);
    }
    for (int i = count - 1; i >= 0; --i) stack.push_back(Entry{children[i], e.h - 1});
  }
  if (m.found) {
    m.score = best_node.score;
    m.pose = s.Pose(guess, best_node.k, best_node.dx, best_node.dy, grid_.resolution());
    m.on_edge = s.OnEdge(best_node.k, best_node.dx, best_node.dy);
  }
  return m;
}

}  // namespace lidar
}  // namespace tether
