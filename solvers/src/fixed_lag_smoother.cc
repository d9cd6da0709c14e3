#include "tether/solvers/fixed_lag_smoother.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_set>

#include "gauge.h"
#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/timing.h"
#include "tether/factors/marginal_prior.h"
#include "tether/solvers/optimizer.h"

namespace tether {

namespace {

// The tangent directions in which a global rigid motion (a small translation and rotation of
// the world applied on the left) moves each of `keys` at `values`, stacked (one column per
// direction of the motion: 3 in 2D, 6 in 3D), and the lowest pose among them. False where a
// key is of another type (or of both dimensions) or none is a pose.
bool RigidMotionBasis(const std::vector<Key>& keys, const Values& values, Eigen::MatrixXd* N, Key* first_pose) {
  bool two_d = false, three_d = false, pose = false;
  int rows = 0;
  for (Key k : keys) {
    const VarType t = values.TypeOf(k);
    if (t == VarType::kSE2 || t == VarType::kPoint2) {
      two_d = true;
    } else if (t == VarType::kSE3 || t == VarType::kPoint3) {
      three_d = true;
    } else {
      return false;
    }
    if (IsPose(t) && (!pose || k < *first_pose)) *first_pose = k, pose = true;
    rows += TangentDim(t);
  }
  if (two_d == three_d || !pose) return false;
  N->setZero(rows, two_d ? 3 : 6);
  int r = 0;
  for (Key k : keys) {
    const VarType t = values.TypeOf(k);
    const double* p = values.Params(k);
    if (t == VarType::kSE2) {
      // t + v + w J t, theta + w; in the tangent: R^T (v + w J t), w.
      const Eigen::Matrix2d Rt = Eigen::Rotation2Dd(p[2]).toRotationMatrix().transpose();
      N->block<2, 2>(r, 0) = Rt;
      N->block<2, 1>(r, 2) = Rt * Eigen::Vector2d(-p[1], p[0]);
      (*N)(r + 2, 2) = 1;
    } else if (t == VarType::kPoint2) {
      N->block<2, 2>(r, 0).setIdentity();
      N->block<2, 1>(r, 2) = Eigen::Vector2d(-p[1], p[0]);
    } else {
      // t + v + w x t, Exp(w) R; in the tangent: R^T (v - [t]x w), R^T w.
      const Eigen::Vector3d tr(p[0], p[1], p[2]);
      Eigen::Matrix3d tx;
      tx << 0, -tr.z(), tr.y(), tr.z(), 0, -tr.x(), -tr.y(), tr.x(), 0;
      if (t == VarType::kSE3) {
        const Eigen::Matrix3d Rt =
            Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized().toRotationMatrix().transpose();
        N->block<3, 3>(r, 0) = Rt;
        N->block<3, 3>(r, 3) = -Rt * tx;
        N->block<3, 3>(r + 3, 3) = Rt;
      } else {
        N->block<3, 3>(r, 0).setIdentity();
        N->block<3, 3>(r, 3) = -tx;
      }
    }
    r += TangentDim(t);
  }
  return true;
}

}  // namespace

FixedLagOptions::FixedLagOptions() {
  converge.algorithm = Algorithm::kGaussNewton;
  converge.max_iterations = 10;
}

bool FixedLagOptions::IsValid(std::string* why) const {
  std::string reason;
  if (!(lag >= 0) || !std::isfinite(lag)) {
    reason = "lag must be 0 or more (and finite)";
  } else if (!(batch >= 0) || !std::isfinite(batch)) {
    reason = "batch must be 0 or more (and finite)";
  } else if (!smoother.IsValid(&reason)) {
    reason = "smoother: " + reason;
  } else if (!converge.IsValid(&reason)) {
    reason = "converge: " + reason;
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

FixedLagSmoother::FixedLagSmoother(const FixedLagOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("invalid fixed-lag smoother options: " + why);
  window_ = std::make_unique<IncrementalSmoother>(options_.smoother);
}

FixedLagSmoother::~FixedLagSmoother() = default;

bool FixedLagSmoother::WasMarginalized(Key key) const {
  auto it = marginalized_ranges_.upper_bound(key);
  if (it == marginalized_ranges_.begin()) return false;
  --it;
  return key <= it->second;
}

void FixedLagSmoother::RememberMarginalized(Key k) {
  ++marginalized_count_;
  // Runs of consecutive keys (a trajectory's poses) take one entry.
  auto next = marginalized_ranges_.upper_bound(k);
  if (next != marginalized_ranges_.begin()) {
    auto prev = std::prev(next);
    if (k <= prev->second) return;
    if (prev->second + 1 == k) {
      prev->second = k;
      if (next != marginalized_ranges_.end() && next->first == k + 1) {
        prev->second = next->second;
        marginalized_ranges_.erase(next);
      }
      return;
    }
  }
  if (next != marginalized_ranges_.end() && next->first == k + 1) {
    const Key last = next->second;
    marginalized_ranges_.erase(next);
    marginalized_ranges_[k] = last;
    return;
  }
  marginalized_ranges_[k] = k;
}

Values FixedLagSmoother::TakeMarginalized() {
  Values out;
  std::swap(out, taken_out_);
  return out;
}

SmootherUpdate FixedLagSmoother::Update(FactorGraph new_factors, Values new_values,
                                        std::vector<FactorId> factors_to_remove, double time) {
  const auto t0 = std::chrono::steady_clock::now();
  if (std::isnan(time)) time = static_cast<double>(updates_);
  if (!std::isfinite(time)) throw InvalidArgument("the update's time is not finite");
  if (time < last_time_) {
    throw InvalidArgument("the update's time " + std::to_string(time) + " is before the previous update's (" +
                          std::to_string(last_time_) + "): times must not decrease");
  }
  const Values& estimate = window_->Estimate();
  for (std::size_t i = 0; i < new_factors.size(); ++i) {
    const Factor& f = new_factors.at(i);
    for (Key k : f.keys()) {
      if (!new_values.Has(k) && !estimate.Has(k) && WasMarginalized(k)) {
        throw InvalidArgument("new factor " + std::to_string(i) + " (" + f.Describe() + ") refers to " +
                              KeyToString(k) + ", which was marginalised (it was added more than the lag of " +
                              std::to_string(options_.lag) +
                              " before); a factor that reaches that far back needs a longer lag");
      }
    }
  }
  for (Key k : new_values.keys()) {
    if (WasMarginalized(k)) {
      throw InvalidArgument("new value " + KeyToString(k) + ": a variable with that key was marginalised already");
    }
  }
  std::vector<FactorId> inner_remove;
  for (FactorId id : factors_to_remove) {
    auto it = inner_of_.find(id);
    if (it == inner_of_.end()) {
      throw InvalidArgument("cannot remove factor " + std::to_string(id) +
                            ": the smoother has no factor with that handle (it was never added, was removed, or "
                            "was marginalised with its variables)");
    }
    inner_remove.push_back(it->second);
  }
  std::vector<Key> fresh = new_values.keys();
  SmootherUpdate u = window_->Update(std::move(new_factors), std::move(new_values), inner_remove);

  // The update is in: hand out handles and stamp the new variables.
  ++updates_;
  last_time_ = time;
  for (FactorId id : factors_to_remove) {
    outer_of_.erase(inner_of_.at(id));
    inner_of_.erase(id);
  }
  for (FactorId& id : u.new_factor_ids) {
    const FactorId outer = next_id_++;
    inner_of_[outer] = id;
    outer_of_[id] = outer;
    id = outer;
  }
  for (Key k : fresh) added_.emplace_back(time, k);

  // Marginalise in a batch once the oldest variable is older than lag * (1 + batch).
  const Values& now = window_->Estimate();
  while (!added_.empty() && !now.Has(added_.front().second)) added_.pop_front();  // erased by the window
  if (!added_.empty() && time - added_.front().first > options_.lag * (1 + options_.batch)) {
    std::vector<Key> old;
    for (const auto& [t, k] : added_) {
      if (!(time - t > options_.lag)) break;
      if (now.Has(k)) old.push_back(k);
    }
    std::string why;
    if (Marginalize(old, &why)) {
      u.marginalized = static_cast<int>(old.size());
      u.structure_rebuilt = true;
      while (!added_.empty() && time - added_.front().first > options_.lag) added_.pop_front();
    } else {
      u.message += (u.message.empty() ? "" : "; ") + ("marginalisation put off: " + why);
    }
  }
  u.seconds = SecondsSince(t0);
  return u;
}

bool FixedLagSmoother::Marginalize(const std::vector<Key>& keys, std::string* why) {
  if (keys.empty()) return true;
  const FactorGraph& graph = window_->graph();
  // The window at its optimum, where the leaving factors are linearised (and the window
  // restarts); the smoother's estimate where that solve fails.
  Values estimate = window_->Estimate();
  {
    Values optimum = estimate;
    const SolverSummary s = Optimize(graph, &optimum, options_.converge);
    if (s.IsSolutionUsable() && s.final_chi2 <= s.initial_chi2) estimate = std::move(optimum);
  }
  const std::unordered_set<Key> leaving(keys.begin(), keys.end());
  // The variables the window's smoother holds (fixed, or the automatic gauge): their step is
  // zero, so the marginalisation is conditioned on them.
  SolverSummary gauge;
  std::set<Key> held = internal::ChooseFixed(graph, estimate, &gauge);
  const bool automatic = gauge.gauge_fixed_automatically || (has_moving_gauge_ && held == std::set<Key>{moving_gauge_});

  // The factors that leave with the variables, and the separator: the other variables they use.
  std::vector<std::size_t> leaving_factors, staying_factors;
  std::vector<Key> separator;
  std::unordered_set<Key> in_separator;
  for (std::size_t i = 0; i < graph.size(); ++i) {
    const std::vector<Key>& fk = graph.at(i).keys();
    const bool leaves = std::any_of(fk.begin(), fk.end(), [&](Key k) { return leaving.count(k) != 0; });
    (leaves ? leaving_factors : staying_factors).push_back(i);
    if (!leaves) continue;
    for (Key k : fk) {
      if (!leaving.count(k) && in_separator.insert(k).second) separator.push_back(k);
    }
  }
  std::sort(separator.begin(), separator.end());
  separator.erase(std::remove_if(separator.begin(), separator.end(), [&](Key k) { return held.count(k) != 0; }),
                  separator.end());

  // Columns: the leaving variables that are not held, then the separator.
  std::unordered_map<Key, int> column;
  int n_m = 0;
  for (Key k : keys) {
    if (held.count(k)) continue;
    column[k] = n_m;
    n_m += TangentDim(estimate.TypeOf(k));
  }
  int n = n_m;
  for (Key k : separator) {
    column[k] = n;
    n += TangentDim(estimate.TypeOf(k));
  }
  const int n_s = n - n_m;

  // H and g of the leaving factors, linearised at the estimate (whitened, with a robust
  // loss's weight at the estimate, as the smoother linearises).
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  std::vector<Eigen::MatrixXd> J;
  std::vector<double*> jp;
  Eigen::VectorXd r;
  for (std::size_t i : leaving_factors) {
    const Factor& f = graph.at(i);
    const std::vector<const double*> params = f.GatherParams(estimate);
    const std::vector<VarType> types = f.variable_types();
    J.resize(types.size());
    jp.resize(types.size());
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    std::vector<RowMajor> rows(types.size());
    for (std::size_t k = 0; k < types.size(); ++k) {
      rows[k].resize(f.dim(), TangentDim(types[k]));
      jp[k] = rows[k].data();
    }
    r.resize(f.dim());
    if (!f.Linearize(params.data(), r.data(), jp.data()) || !r.allFinite()) {
      *why = f.Describe() + " cannot be evaluated at the estimate";
      return false;
    }
    const double w = RobustWeight(f.loss(), r.squaredNorm());
    for (std::size_t a = 0; a < types.size(); ++a) {
      auto ca = column.find(f.keys()[a]);
      if (ca == column.end()) continue;
      const RowMajor Ja = w * rows[a];
      if (!Ja.allFinite()) {
        *why = f.Describe() + " has a Jacobian that is not finite at the estimate";
        return false;
      }
      g.segment(ca->second, Ja.cols()) += Ja.transpose() * (w * r);
      for (std::size_t b = 0; b < types.size(); ++b) {
        auto cb = column.find(f.keys()[b]);
        if (cb == column.end()) continue;
        H.block(ca->second, cb->second, Ja.cols(), rows[b].cols()) += Ja.transpose() * (w * rows[b]);
      }
    }
  }

  // The Schur complement onto the separator: H_SS - H_SM H_MM^-1 H_MS, g_S - H_SM H_MM^-1 g_M.
  // Directions of the leaving variables that their factors leave undetermined carry nothing
  // to the separator (a pseudo-inverse there).
  std::unique_ptr<MarginalPrior> prior;
  bool new_gauge = false;
  if (n_s > 0) {
    Eigen::MatrixXd Hs = H.bottomRightCorner(n_s, n_s);
    Eigen::VectorXd gs = g.tail(n_s);
    if (n_m > 0) {
      const Eigen::MatrixXd Hmm = H.topLeftCorner(n_m, n_m);
      const Eigen::MatrixXd Hms = H.topRightCorner(n_m, n_s);
      const Eigen::VectorXd gm = g.head(n_m);
      Eigen::MatrixXd X;
      Eigen::VectorXd y;
      const Eigen::LLT<Eigen::MatrixXd> llt(Hmm);
      if (llt.info() == Eigen::Success) {
        X = llt.solve(Hms);
        y = llt.solve(gm);
      } else {
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Hmm);
        const Eigen::VectorXd& l = eig.eigenvalues();
        const double floor = 1e-12 * std::max(l.cwiseAbs().maxCoeff(), 1e-300);
        Eigen::VectorXd inv(l.size());
        for (Eigen::Index i = 0; i < l.size(); ++i) inv[i] = l[i] > floor ? 1 / l[i] : 0.0;
        const Eigen::MatrixXd& V = eig.eigenvectors();
        X = V * inv.asDiagonal() * (V.transpose() * Hms);
        y = V * inv.asDiagonal() * (V.transpose() * gm);
      }
      Hs -= Hms.transpose() * X;
      gs -= Hms.transpose() * y;
    }
    if (!Hs.allFinite() || !gs.allFinite()) {
      *why = "the marginal information is not finite";
      return false;
    }
    // Where the graph measures only relative quantities and its gauge leaves, the gauge moves
    // on: the global rigid motion is marginalised out of the prior too (what the prior said of
    // the separator's place in the world, relative to a gauge that is gone), and the lowest pose
    // of the separator is held where it is. A prior that kept the separator's place would know
    // it only as well as the whole past determines it, which after many poses drowns in the
    // rounding of its relative information (a 10 000-pose walk: some 1e-12 of it), and the window
    // would float.
    if (automatic && std::any_of(held.begin(), held.end(), [&](Key k) { return leaving.count(k) != 0; })) {
      Eigen::MatrixXd N;
      Key first_pose = 0;
      if (RigidMotionBasis(separator, estimate, &N, &first_pose)) {
        const Eigen::MatrixXd HN = Hs * N;
        const Eigen::LDLT<Eigen::MatrixXd> rigid(N.transpose() * HN);
        if (rigid.info() == Eigen::Success) {
          gs -= HN * rigid.solve(N.transpose() * gs);
          Hs -= HN * rigid.solve(HN.transpose());
          moving_gauge_ = first_pose;
          has_moving_gauge_ = true;
          new_gauge = true;
        }
      }
    }
    std::vector<VarType> types;
    std::vector<double> points;
    for (Key k : separator) {
      const VarType t = estimate.TypeOf(k);
      types.push_back(t);
      points.insert(points.end(), estimate.Params(k), estimate.Params(k) + AmbientDim(t));
    }
    try {
      prior = MarginalPrior::FromInformation(separator, types, points, 0.5 * (Hs + Hs.transpose()), gs);
    } catch (const InvalidArgument&) {
      prior.reset();  // the leaving factors said nothing about the separator
    }
  }

  // The window after: its factors, the prior, the variables that stay at their estimate, and
  // the held ones that stay held (a prior conditioned on them does not fix their directions).
  FactorGraph next;
  std::vector<FactorId> old_ids;
  for (std::size_t i : staying_factors) {
    next.Add(graph.at(i).Clone());
    old_ids.push_back(graph.id(i));
  }
  if (prior) next.Add(std::move(prior));
  for (Key k : held) {
    if (!leaving.count(k) && estimate.Has(k)) next.Fix(k);
  }
  if (new_gauge) next.Fix(moving_gauge_);
  Values values;
  for (Key k : estimate.keys()) {
    if (!leaving.count(k)) values.InsertParams(k, estimate.TypeOf(k), estimate.Params(k));
  }
  Values leaving_values;
  for (Key k : keys) leaving_values.InsertParams(k, estimate.TypeOf(k), estimate.Params(k));
  SmootherUpdate restart;
  try {
    restart = window_->Restart(std::move(next), std::move(values));
  } catch (const Error& e) {
    *why = e.what();
    return false;
  }
  for (Key k : keys) {
    taken_out_.InsertParams(k, leaving_values.TypeOf(k), leaving_values.Params(k));
    RememberMarginalized(k);
  }
  // The handles given out follow their factors into the restarted window.
  std::unordered_map<FactorId, FactorId> inner_of, outer_of;
  for (std::size_t j = 0; j < old_ids.size(); ++j) {
    auto it = outer_of_.find(old_ids[j]);
    if (it == outer_of_.end()) continue;
    inner_of[it->second] = restart.new_factor_ids[j];
    outer_of[restart.new_factor_ids[j]] = it->second;
  }
  inner_of_.swap(inner_of);
  outer_of_.swap(outer_of);
  return true;
}

}  // namespace tether
