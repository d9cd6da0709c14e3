#include "tether/frontends/lidar/mapping/submap_2d.h"

#include <algorithm>
#include <cmath>

#include "tether/core/error.h"
#include "tether/core/registry.h"

namespace tether {
namespace lidar {

bool SubmapOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (!(std::isfinite(resolution) && resolution > 0)) {
    return fail("resolution is " + FormatDouble(resolution) + " m; it must be finite and positive (e.g. 0.05)");
  }
  if (scans_per_submap < 1) {
    return fail("scans_per_submap is " + std::to_string(scans_per_submap) + "; a submap holds at least one scan");
  }
  if (!(std::isfinite(max_submap_travel) && max_submap_travel >= 0)) {
    return fail("max_submap_travel is " + FormatDouble(max_submap_travel) +
                " m; it must be finite and not negative (0: finish by scans only)");
  }
  if (!(min_probability > 0 && min_probability < max_probability && max_probability < 1)) {
    return fail("the probability range [" + FormatDouble(min_probability) + ", " + FormatDouble(max_probability) +
                "] must satisfy 0 < min < max < 1");
  }
  return insert.IsValid(why);
}

Submap2D::Submap2D(const SE2d& local_pose, const SubmapOptions& options)
    : local_pose_(local_pose),
      grid_(std::make_shared<ProbabilityGrid>(options.resolution, local_pose.translation(), options.min_probability,
                                              options.max_probability)) {}

std::shared_ptr<Submap2D> Submap2D::Restored(const SE2d& local_pose, std::shared_ptr<ProbabilityGrid> grid,
                                             int num_scans) {
  if (grid == nullptr) throw InvalidArgument("Submap2D::Restored: the grid is null");
  if (num_scans < 0) throw InvalidArgument("Submap2D::Restored: " + std::to_string(num_scans) + " scans");
  SubmapOptions options;
  options.resolution = grid->resolution();
  options.min_probability = grid->min_probability();
  options.max_probability = grid->max_probability();
  auto submap = std::make_shared<Submap2D>(local_pose, options);
  submap->grid_ = std::move(grid);
  submap->num_scans_ = num_scans;
  submap->finished_ = true;
  return submap;
}

void Submap2D::InsertScan(const ProbabilityGridInserter& inserter, const Eigen::Vector2d& origin,
                          const std::vector<Eigen::Vector2d>& points, InsertedCells* cells) {
  if (finished_) {
    throw InvalidArgument("Submap2D: the submap is finished (it holds " + std::to_string(num_scans_) +
                          " scans) and frozen; insert into an active submap");
  }
  inserter.Insert(grid_.get(), origin, points, cells);
  ++num_scans_;
}

namespace {
SubmapOptions Checked(const SubmapOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("SubmapOptions: " + why);
  return options;
}
}  // namespace

ActiveSubmaps2D::ActiveSubmaps2D(const SubmapOptions& options)
    : options_(Checked(options)), inserter_(options.insert, options.min_probability, options.max_probability) {}

InsertedSubmaps ActiveSubmaps2D::InsertScan(const SE2d& scan_pose, const Eigen::Vector2d& origin,
                                            const std::vector<Eigen::Vector2d>& points) {
  const double step = any_scan_ ? (scan_pose.translation() - last_position_).norm() : 0.0;
  any_scan_ = true;
  last_position_ = scan_pose.translation();
  for (const auto& s : active_) s->travel_ += step;
  if (start_new_) {
    submaps_.push_back(std::make_shared<Submap2D>(scan_pose, options_));
    active_.push_back(submaps_.back());
    start_new_ = false;
  }
  // The active submaps are the newest ones, in order of creation.
  InsertedSubmaps inserted;
  int index = dropped_ + static_cast<int>(submaps_.size() - active_.size());
  for (const auto& s : active_) {
    s->InsertScan(inserter_, origin, points);
    inserted.emplace_back(index++, s);
  }
  const double cap = options_.max_submap_travel;
  const Submap2D& older = *active_.front();
  if (older.num_scans() >= options_.scans_per_submap || (cap > 0 && older.travel() >= cap)) {
    active_.front()->Finish();
    active_.erase(active_.begin());
  }
  const int half = std::max(1, options_.scans_per_submap / 2);
  const bool half_full =
      !active_.empty() && (active_.back()->num_scans() >= half || (cap > 0 && active_.back()->travel() >= 0.5 * cap));
  if (active_.empty() || (active_.size() == 1 && half_full)) start_new_ = true;
  return inserted;
}

InsertedSubmaps ActiveSubmaps2D::FinishActive() {
  InsertedSubmaps finished;
  int index = dropped_ + static_cast<int>(submaps_.size() - active_.size());
  for (const auto& s : active_) {
    s->Finish();
    finished.emplace_back(index++, s);
  }
  active_.clear();
  start_new_ = true;
  return finished;
}

void ActiveSubmaps2D::KeepNewest(int n) {
  const std::size_t keep = std::max({static_cast<std::size_t>(std::max(n, 1)), active_.size()});
  if (submaps_.size() <= keep) return;
  const std::size_t drop = submaps_.size() - keep;
  submaps_.erase(submaps_.begin(), submaps_.begin() + static_cast<std::ptrdiff_t>(drop));
  dropped_ += static_cast<int>(drop);
}

std::shared_ptr<const Submap2D> ActiveSubmaps2D::matching_submap() const {
  if (!active_.empty()) return active_.front();
  if (!submaps_.empty()) return submaps_.back();
  return nullptr;
}

}  // namespace lidar
}  // namespace tether
