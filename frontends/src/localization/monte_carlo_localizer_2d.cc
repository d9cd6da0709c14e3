#include "tether/frontends/localization/monte_carlo_localizer_2d.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "tether/core/error.h"

namespace tether {
namespace localization {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNegInf = -std::numeric_limits<double>::infinity();

double Wrap(double a) { return std::remainder(a, 2 * kPi); }

// log(exp(a) + exp(b)) without overflow or underflow.
double LogAdd(double a, double b) {
  if (a == kNegInf) return b;
  if (b == kNegInf) return a;
  const double m = std::max(a, b);
  return m + std::log(std::exp(a - m) + std::exp(b - m));
}

bool Fail(std::string* why, const std::string& what) {
  if (why) *why = what;
  return false;
}

// The bins of the estimate's clusters and of KLD sampling.
struct Bins {
  double xy, theta;
  int theta_bins;
  Bins(double xy_size, double theta_size)
      : xy(xy_size), theta(theta_size), theta_bins(std::max(1, static_cast<int>(std::ceil(2 * kPi / theta_size)))) {}
  std::uint64_t Key(long long ix, long long iy, long long it) const {
    it = ((it % theta_bins) + theta_bins) % theta_bins;
    return (static_cast<std::uint64_t>(ix + (1LL << 21)) << 42) | (static_cast<std::uint64_t>(iy + (1LL << 21)) << 21) |
           static_cast<std::uint64_t>(it);
  }
  // Bins beyond 2^20 from the origin share the last one (a key holds 21 bits a coordinate).
  static long long Clamp(double v) { return static_cast<long long>(std::max(-1048576.0, std::min(1048575.0, v))); }
  void Cell(double x, double y, double t, long long* ix, long long* iy, long long* it) const {
    *ix = Clamp(std::floor(x / xy));
    *iy = Clamp(std::floor(y / xy));
    *it = std::min<long long>(theta_bins - 1, static_cast<long long>(std::floor((Wrap(t) + kPi) / theta)));
  }
};

// Bin keys to bin numbers for the clusters and KLD sampling: open addressing with linear
// probing in a power-of-two table kept at least twice the entries (std::unordered_map's node
// per entry took most of an update of particles spread over a map). No key is all ones
// (Bins::Key keeps every field below its top).
class BinIndex {
 public:
  explicit BinIndex(std::size_t expected) {
    std::size_t capacity = 16;
    while (capacity < 2 * expected) capacity <<= 1;
    Reset(capacity);
  }
  /// The value of `key`, set to `value` where it was absent; second: it was.
  std::pair<int, bool> Insert(std::uint64_t key, int value) {
    if (2 * (count_ + 1) > keys_.size()) Grow();
    for (std::size_t k = Slot(key);; k = (k + 1) & mask_) {
      if (keys_[k] == key) return {values_[k], false};
      if (keys_[k] == kEmpty) {
        keys_[k] = key;
        values_[k] = value;
        ++count_;
        return {value, true};
      }
    }
  }
  /// The value of `key`; -1 where absent.
  int Find(std::uint64_t key) const {
    for (std::size_t k = Slot(key);; k = (k + 1) & mask_) {
      if (keys_[k] == key) return values_[k];
      if (keys_[k] == kEmpty) return -1;
    }
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t Slot(std::uint64_t key) const { return static_cast<std::size_t>(RandomStream::Mix(key)) & mask_; }
  void Reset(std::size_t capacity) {
    keys_.assign(capacity, kEmpty);
    values_.assign(capacity, -1);
    mask_ = capacity - 1;
    count_ = 0;
  }
  void Grow() {
    const std::vector<std::uint64_t> keys = std::move(keys_);
    const std::vector<int> values = std::move(values_);
    Reset(2 * keys.size());
    for (std::size_t k = 0; k < keys.size(); ++k) {
      if (keys[k] != kEmpty) Insert(keys[k], values[k]);
    }
  }
  std::vector<std::uint64_t> keys_;
  std::vector<int> values_;
  std::size_t mask_ = 0;
  std::size_t count_ = 0;
};

}  // namespace

double NormalQuantile(double p) {
  double lo = -40, hi = 40;
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

double KldSampleCount(int k, double epsilon, double delta) {
  if (k <= 1) return 1;
  const double a = 2.0 / (9.0 * (k - 1));
  const double c = 1 - a + std::sqrt(a) * NormalQuantile(1 - delta);
  return (k - 1) / (2 * epsilon) * c * c * c;
}

bool MclOptions::IsValid(std::string* why) const {
  std::string w;
  if (particles < 1 || particles > kMaxParticles) {
    return Fail(why, "particles must lie in 1.." + std::to_string(kMaxParticles));
  }
  if (!motion.IsValid(&w) || !likelihood_field.IsValid(&w) || !beam.IsValid(&w)) return Fail(why, w);
  if (max_beams < 0) return Fail(why, "max_beams must be 0 (every beam) or more");
  if (!(range_cap >= 0) || !std::isfinite(range_cap)) return Fail(why, "range_cap must be 0 (none) or more");
  if (!(alpha_slow > 0 && alpha_slow < alpha_fast && alpha_fast <= 1)) {
    return Fail(why, "the recovery filters need 0 < alpha_slow < alpha_fast <= 1");
  }
  if (!(kld.epsilon > 0 && kld.epsilon < 1 && kld.delta > 0 && kld.delta < 1)) {
    return Fail(why, "KLD sampling's epsilon and delta must lie in (0, 1)");
  }
  if (kld.min_particles < 1 || kld.max_particles < kld.min_particles || kld.max_particles > kMaxParticles) {
    return Fail(why, "KLD sampling needs 1 <= min_particles <= max_particles <= " + std::to_string(kMaxParticles));
  }
  if (kld.enabled && (particles < kld.min_particles || particles > kld.max_particles)) {
    return Fail(why, "with KLD sampling the first particle count must lie in [min_particles, max_particles]");
  }
  if (!(robot_radius >= 0) || !std::isfinite(robot_radius)) return Fail(why, "robot_radius must be 0 or more");
  if (!(update_min_translation >= 0) || !(update_min_rotation >= 0)) {
    return Fail(why, "the update thresholds must be 0 or more");
  }
  if (!(cluster_xy > 0) || !(cluster_theta > 0) || !std::isfinite(cluster_xy) || !std::isfinite(cluster_theta)) {
    return Fail(why, "the cluster bins must be positive");
  }
  if (threads < 0) return Fail(why, "threads must be 0 (every core) or more");
  if (!(localised_weight >= 0 && localised_weight <= 1) || !(localised_spread >= 0)) {
    return Fail(why, "localised_weight must lie in [0, 1] and localised_spread be 0 or more");
  }
  if (!(min_effective_fraction >= 0 && min_effective_fraction <= 1)) {
    return Fail(why, "min_effective_fraction must lie in [0, 1]");
  }
  return true;
}

MonteCarloLocalizer2D::MonteCarloLocalizer2D(std::shared_ptr<const OccupancyMap2D> map, const MclOptions& options)
    : map_(std::move(map)),
      options_(options),
      random_(options.seed, 0x6d636c),
      log_w_slow_(kNegInf),
      log_w_fast_(kNegInf) {
  std::string why;
  if (!map_) throw InvalidArgument("MonteCarloLocalizer2D: no map");
  if (!options.IsValid(&why)) throw InvalidArgument("MonteCarloLocalizer2D: " + why);
  if (map_->free_cells().empty()) {
    throw InvalidArgument("MonteCarloLocalizer2D: the map has no free cell to put particles in");
  }
  if (options.method == MclMethod::kCostmap || options.method == MclMethod::kAcmcl ||
      options.method == MclMethod::kAuto) {
    costmap_ = std::make_unique<Costmap2D>(*map_, options.robot_radius);
    if (costmap_->valid_cells().empty()) {
      throw InvalidArgument("MonteCarloLocalizer2D: no free cell lies " + std::to_string(options.robot_radius) +
                            " m from the obstacles: the costmap has no valid cell (a smaller robot_radius?)");
    }
  }
  if (options.model == MeasurementModelType::kBeam) beam_model_ = std::make_unique<BeamModel>(*map_, options.beam);
}

Particle MonteCarloLocalizer2D::RandomParticle() {
  const std::vector<std::uint32_t>& cells = costmap_ ? costmap_->valid_cells() : map_->free_cells();
  const std::size_t pick =
      std::min(cells.size() - 1, static_cast<std::size_t>(random_.Uniform() * static_cast<double>(cells.size())));
  const std::uint32_t k = cells[pick];
  const int w = map_->width();
  const Eigen::Vector2d corner = map_->CellCentre(static_cast<int>(k % static_cast<std::uint32_t>(w)),
                                                  static_cast<int>(k / static_cast<std::uint32_t>(w))) -
                                 Eigen::Vector2d::Constant(0.5 * map_->resolution());
  Particle p;
  p.x = corner.x() + map_->resolution() * random_.Uniform();
  p.y = corner.y() + map_->resolution() * random_.Uniform();
  p.theta = random_.Uniform(-kPi, kPi);
  return p;
}

void MonteCarloLocalizer2D::InitializeGlobal() {
  particles_.assign(static_cast<std::size_t>(options_.particles), Particle());
  for (Particle& p : particles_) p = RandomParticle();
  SetParticles(particles_);
}

void MonteCarloLocalizer2D::InitializeGaussian(const SE2d& mean, const Eigen::Matrix3d& covariance) {
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  if (llt.info() != Eigen::Success || !covariance.allFinite()) {
    throw InvalidArgument("InitializeGaussian: the covariance is not symmetric positive definite");
  }
  const Eigen::Matrix3d l = llt.matrixL();
  particles_.assign(static_cast<std::size_t>(options_.particles), Particle());
  for (Particle& p : particles_) {
    const Eigen::Vector3d e = l * Eigen::Vector3d(random_.Normal(), random_.Normal(), random_.Normal());
    p.x = mean.x() + e[0];
    p.y = mean.y() + e[1];
    p.theta = Wrap(mean.theta() + e[2]);
  }
  SetParticles(particles_);
}

void MonteCarloLocalizer2D::SetParticles(const std::vector<Particle>& particles) {
  if (particles.empty()) throw InvalidArgument("SetParticles: no particle");
  particles_ = particles;
  double sum = 0;
  for (const Particle& p : particles_) sum += p.weight > 0 && std::isfinite(p.weight) ? p.weight : 0;
  for (Particle& p : particles_) {
    p.weight = sum > 0 ? (p.weight > 0 && std::isfinite(p.weight) ? p.weight / sum : 0)
                       : 1.0 / static_cast<double>(particles_.size());
  }
  before_motion_.clear();
  for (const Particle& p : particles_) before_motion_.push_back(p.pose());
  redrawn_.assign(particles_.size(), false);
  injected_.assign(particles_.size(), false);
  localised_ = options_.method == MclMethod::kAuto && Localised();
}

void MonteCarloLocalizer2D::Predict(const SE2d& odometry_from, const SE2d& odometry_to) {
  const OdometryMotion m = DecomposeOdometry(odometry_from, odometry_to);
  before_motion_.resize(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    Particle& p = particles_[i];
    before_motion_[i] = p.pose();
    const SE2d moved = options_.motion.Sample(before_motion_[i], m, &random_);
    p.x = moved.x();
    p.y = moved.y();
    p.theta = moved.theta();
  }
}

void MonteCarloLocalizer2D::Likelihoods(const lidar::LaserScan& scan, std::vector<double>* out,
                                        std::vector<double>* mean_p) {
  const bool beam = options_.model == MeasurementModelType::kBeam;
  const ScanBeams beams = SelectBeams(scan, options_.max_beams, beam, options_.range_cap);
  if (!beam && (!field_ || field_->range_max() != beams.range_max)) {
    field_ = std::make_unique<LikelihoodField>(*map_, options_.likelihood_field, beams.range_max);
  }
  const std::size_t n = particles_.size();
  std::vector<double> poses(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    poses[3 * i] = particles_[i].x;
    poses[3 * i + 1] = particles_[i].y;
    poses[3 * i + 2] = particles_[i].theta;
  }
  out->assign(n, 0.0);
  mean_p->assign(n, 0.0);
  const auto work = [&](std::size_t begin, std::size_t end) {
    if (beam) {
      for (std::size_t i = begin; i < end; ++i) {
        (*out)[i] = beam_model_->LogLikelihood(particles_[i].pose(), beams, &(*mean_p)[i]);
      }
    } else {
      field_->LogLikelihoods(poses.data() + 3 * begin, end - begin, beams, out->data() + begin, mean_p->data() + begin);
    }
  };
  std::size_t threads = options_.threads > 0 ? static_cast<std::size_t>(options_.threads)
                                             : std::max(1u, std::thread::hardware_concurrency());
  threads = std::max<std::size_t>(1, std::min(threads, n / 256));
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work, t * n / threads, (t + 1) * n / threads);
  work(0, n / threads);
  for (std::thread& t : pool) t.join();
}

void MonteCarloLocalizer2D::Update(const lidar::LaserScan& scan) {
  const std::string problem = lidar::ScanProblem(scan);
  if (!problem.empty()) throw InvalidArgument("MonteCarloLocalizer2D::Update: " + problem);
  redrawn_.assign(particles_.size(), false);
  if (costmap_ && (options_.method != MclMethod::kAuto || !localised_)) {
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      const Eigen::Vector2d from = i < before_motion_.size() ? before_motion_[i].translation()
                                                             : Eigen::Vector2d(particles_[i].x, particles_[i].y);
      if (costmap_->PathValid(from, Eigen::Vector2d(particles_[i].x, particles_[i].y))) continue;
      const double weight = particles_[i].weight;
      particles_[i] = RandomParticle();
      particles_[i].weight = weight;
      redrawn_[i] = true;
    }
  }
  std::vector<double> ll;
  std::vector<double> mean_p;
  Likelihoods(scan, &ll, &mean_p);
  // w_avg over the particles (acmcl: those not re-drawn), in logs. The recovery filters see
  // each particle's mean beam probability: a scan's beams that hit what the map does not hold
  // (people, open doors) lower it by their share, where they would swing the product of the
  // beams by orders of magnitude from one scan to the next.
  double log_sum = kNegInf;
  std::size_t counted = 0;
  for (std::size_t i = 0; i < ll.size(); ++i) {
    if ((options_.method == MclMethod::kAcmcl || options_.method == MclMethod::kAuto) && redrawn_[i]) continue;
    log_sum = LogAdd(log_sum, std::log(std::max(mean_p[i], 1e-300)));
    ++counted;
  }
  last_step_ = MclStep();
  if (counted > 0) {
    last_step_.w_avg = log_sum - std::log(static_cast<double>(counted));
    if (options_.method == MclMethod::kAugmented || options_.method == MclMethod::kAcmcl ||
        options_.method == MclMethod::kAuto) {
      UpdateRecoveryFilters(last_step_.w_avg);
    }
  }
  // The new weights: the old ones times the likelihoods raised to the tempering exponent,
  // normalised (shifted by the largest log).
  std::vector<double> prior(ll.size());
  for (std::size_t i = 0; i < ll.size(); ++i) {
    prior[i] = particles_[i].weight > 0 ? std::log(particles_[i].weight) : kNegInf;
  }
  const auto weigh = [&](double beta) {
    double top = kNegInf;
    for (std::size_t i = 0; i < ll.size(); ++i) top = std::max(top, prior[i] + beta * ll[i]);
    double sum = 0, squares = 0;
    for (std::size_t i = 0; i < ll.size(); ++i) {
      const double w = prior[i] == kNegInf ? 0.0 : std::exp(prior[i] + beta * ll[i] - top);
      particles_[i].weight = w;
      sum += w;
      squares += w * w;
    }
    return squares > 0 ? sum * sum / squares : 0.0;  // the effective sample size
  };
  double beta = 1;
  const double wanted = options_.min_effective_fraction * static_cast<double>(ll.size());
  if (weigh(1.0) < wanted) {
    // The largest exponent that keeps the effective sample size at the wanted share (the size
    // falls as the exponent grows), by bisection on a log scale.
    double lo = 1e-4, hi = 1;
    for (int k = 0; k < 30; ++k) {
      const double mid = std::sqrt(lo * hi);
      (weigh(mid) >= wanted ? lo : hi) = mid;
    }
    beta = lo;
    weigh(beta);
  }
  last_step_.tempering = beta;
  double sum = 0;
  for (const Particle& p : particles_) sum += p.weight;
  for (Particle& p : particles_) p.weight = sum > 0 ? p.weight / sum : 1.0 / static_cast<double>(particles_.size());
  last_step_.redrawn = static_cast<int>(std::count(redrawn_.begin(), redrawn_.end(), true));
  // auto: judged on the weighted set, before the resampling injects its random particles.
  if (options_.method == MclMethod::kAuto) {
    update_estimate_ = Estimate();
    localised_ = Localised(update_estimate_);
  }
  last_step_.w_slow = log_w_slow_;
  last_step_.w_fast = log_w_fast_;
}

void MonteCarloLocalizer2D::UpdateRecoveryFilters(double log_w_avg) {
  const auto filter = [log_w_avg](double log_w, double alpha) {
    if (log_w == kNegInf) return log_w_avg;  // the first update starts both filters at its average
    return LogAdd(std::log1p(-alpha) + log_w, std::log(alpha) + log_w_avg);
  };
  log_w_slow_ = filter(log_w_slow_, options_.alpha_slow);
  log_w_fast_ = filter(log_w_fast_, options_.alpha_fast);
}

void MonteCarloLocalizer2D::SetRecoveryFilters(double log_w_slow, double log_w_fast) {
  log_w_slow_ = log_w_slow;
  log_w_fast_ = log_w_fast;
}

double MonteCarloLocalizer2D::InjectionProbability() const {
  if (options_.method != MclMethod::kAugmented && options_.method != MclMethod::kAcmcl &&
      options_.method != MclMethod::kAuto) {
    return 0;
  }
  if (log_w_slow_ == kNegInf) return 0;
  return std::max(0.0, 1.0 - std::exp(log_w_fast_ - log_w_slow_));
}

void MonteCarloLocalizer2D::Resample() {
  const double inject = InjectionProbability();
  std::vector<double> weights(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i) weights[i] = particles_[i].weight;
  std::vector<Particle> next;
  std::vector<bool> injected;
  const auto add = [&](int index) {
    const bool random = inject > 0 && random_.Chance(inject);
    next.push_back(random ? RandomParticle() : particles_[static_cast<std::size_t>(index)]);
    injected.push_back(random);
  };
  if (!options_.kld.enabled) {
    for (const int index : LowVarianceResample(weights, options_.particles, random_.Uniform())) add(index);
  } else {
    std::vector<double> cumulative(weights.size());
    double c = 0;
    for (std::size_t i = 0; i < weights.size(); ++i) cumulative[i] = (c += weights[i]);
    const Bins bins(options_.cluster_xy, options_.cluster_theta);
    BinIndex filled(particles_.size());
    int bins_filled = 0;
    const KldOptions& k = options_.kld;
    while (static_cast<int>(next.size()) < k.max_particles) {
      const double u = random_.Uniform() * c;
      add(static_cast<int>(std::min<std::size_t>(
          weights.size() - 1,
          static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin()))));
      long long ix, iy, it;
      bins.Cell(next.back().x, next.back().y, next.back().theta, &ix, &iy, &it);
      if (filled.Insert(bins.Key(ix, iy, it), 0).second) ++bins_filled;
      const double needed = KldSampleCount(bins_filled, k.epsilon, k.delta);
      if (static_cast<int>(next.size()) >= k.min_particles && static_cast<double>(next.size()) >= needed) break;
    }
  }
  for (Particle& p : next) p.weight = 1.0 / static_cast<double>(next.size());
  particles_ = std::move(next);
  injected_ = std::move(injected);
  redrawn_.assign(particles_.size(), false);
  before_motion_.clear();
  for (const Particle& p : particles_) before_motion_.push_back(p.pose());
  last_step_.injected = static_cast<int>(std::count(injected_.begin(), injected_.end(), true));
}

bool MonteCarloLocalizer2D::Localised() const { return Localised(Estimate()); }

bool MonteCarloLocalizer2D::Localised(const PoseEstimate& e) const {
  return e.cluster_weight >= options_.localised_weight &&
         std::sqrt(e.covariance(0, 0) + e.covariance(1, 1)) <= options_.localised_spread;
}

PoseEstimate MonteCarloLocalizer2D::Estimate() const {
  PoseEstimate e;
  if (particles_.empty()) return e;
  const Bins bins(options_.cluster_xy, options_.cluster_theta);
  struct Bin {
    long long ix, iy, it;
    double weight = 0;
    int cluster = -1;
  };
  BinIndex index(particles_.size());
  std::vector<Bin> cells;
  std::vector<int> bin_of(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    Bin b;
    bins.Cell(particles_[i].x, particles_[i].y, particles_[i].theta, &b.ix, &b.iy, &b.it);
    const std::pair<int, bool> it = index.Insert(bins.Key(b.ix, b.iy, b.it), static_cast<int>(cells.size()));
    if (it.second) cells.push_back(b);
    bin_of[i] = it.first;
    cells[static_cast<std::size_t>(it.first)].weight += particles_[i].weight;
  }
  // Connected bins (26 neighbours, the heading's bins wrapping round) form the clusters.
  std::vector<double> cluster_weight;
  for (std::size_t s = 0; s < cells.size(); ++s) {
    if (cells[s].cluster >= 0) continue;
    const int id = static_cast<int>(cluster_weight.size());
    cluster_weight.push_back(0);
    std::vector<std::size_t> stack = {s};
    cells[s].cluster = id;
    while (!stack.empty()) {
      const Bin b = cells[stack.back()];
      stack.pop_back();
      cluster_weight[static_cast<std::size_t>(id)] += b.weight;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dt = -1; dt <= 1; ++dt) {
            const int found = index.Find(bins.Key(b.ix + dx, b.iy + dy, b.it + dt));
            if (found < 0 || cells[static_cast<std::size_t>(found)].cluster >= 0) continue;
            cells[static_cast<std::size_t>(found)].cluster = id;
            stack.push_back(static_cast<std::size_t>(found));
          }
    }
  }
  const int best =
      static_cast<int>(std::max_element(cluster_weight.begin(), cluster_weight.end()) - cluster_weight.begin());
  e.clusters = static_cast<int>(cluster_weight.size());
  double w = 0, sx = 0, sy = 0, sc = 0, ss = 0;
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    if (cells[static_cast<std::size_t>(bin_of[i])].cluster != best) continue;
    const Particle& p = particles_[i];
    w += p.weight;
    sx += p.weight * p.x;
    sy += p.weight * p.y;
    sc += p.weight * std::cos(p.theta);
    ss += p.weight * std::sin(p.theta);
  }
  if (!(w > 0)) {  // every weight 0 in the cluster: equal weights instead
    return e;
  }
  e.pose = SE2d(sx / w, sy / w, std::atan2(ss, sc));
  for (std::size_t i = 0; i < particles_.size(); ++i) {
    if (cells[static_cast<std::size_t>(bin_of[i])].cluster != best) continue;
    const Particle& p = particles_[i];
    const Eigen::Vector3d d(p.x - e.pose.x(), p.y - e.pose.y(), Wrap(p.theta - e.pose.theta()));
    e.covariance += p.weight / w * d * d.transpose();
  }
  e.cluster_weight = w;
  return e;
}

MclStep MonteCarloLocalizer2D::AddScan(const lidar::LaserScan& scan) {
  MclStep step;
  if (!has_last_update_) {
    if (particles_.empty()) InitializeGlobal();
  } else {
    const SE2d moved = last_update_odometry_.Inverse() * scan.odometry;
    if (moved.translation().norm() < options_.update_min_translation &&
        std::abs(moved.theta()) < options_.update_min_rotation) {
      step.estimate = last_estimate_;
      step.estimate.pose = last_estimate_.pose * moved;
      step.particles = static_cast<int>(particles_.size());
      step.w_slow = log_w_slow_;
      step.w_fast = log_w_fast_;
      return step;
    }
    Predict(last_update_odometry_, scan.odometry);
  }
  Update(scan);
  // auto's rule clustered the same weighted set in the update: its estimate serves.
  last_estimate_ = options_.method == MclMethod::kAuto ? update_estimate_ : Estimate();
  Resample();
  has_last_update_ = true;
  last_update_odometry_ = scan.odometry;
  step = last_step_;
  step.updated = true;
  step.particles = static_cast<int>(particles_.size());
  step.estimate = last_estimate_;
  return step;
}

}  // namespace localization
}  // namespace tether
