#include "tether/frontends/ekf/experiment.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/svg_writer.h"
#include "tether/core/timing.h"
#include "tether/frontends/ekf/consistency.h"
#include "tether/frontends/ekf/ekf_slam.h"
#include "tether/frontends/ekf/fast_slam.h"
#include "tether/frontends/ekf/invariant_ekf_slam.h"
#include "tether/frontends/ekf/landmark_graph.h"
#include "tether/frontends/ekf/ukf_slam.h"

namespace tether {

namespace {

using ekf::Track;

ekf::LandmarkWorldOptions WorldOptions(int experiment, std::uint64_t seed, const EkfDemoSetup& setup) {
  ekf::LandmarkWorldOptions o;
  o.seed = seed;
  o.steps = setup.steps;
  o.measurement_sigma = Eigen::Vector2d(setup.range_sigma, setup.bearing_sigma);
  if (experiment == 2) o.control_sigma *= 2;
  return o;
}

// The filters' options (the invariant EKF changes its min_range and iterations).
ekf::FilterOptions FilterOptionsFor(const ekf::LandmarkWorldOptions& w, bool nn, const EkfDemoSetup& setup) {
  ekf::FilterOptions f;
  f.min_range = setup.min_range;
  f.control_cov = w.control_sigma.cwiseAbs2().asDiagonal();
  f.measurement_cov = w.measurement_sigma.cwiseAbs2().asDiagonal();
  f.association = nn ? ekf::DataAssociation::kNearestNeighbour : ekf::DataAssociation::kKnown;
  return f;
}

ekf::LandmarkGraphOptions GraphOptionsFor(const ekf::FilterOptions& f) {
  ekf::LandmarkGraphOptions g;
  g.odometry.control = f.control_cov;
  g.measurement_cov = f.measurement_cov;
  return g;
}

// Every track of one seed: the filters' and the graphs they seed.
struct SeedRun {
  ekf::LandmarkWorld world;
  std::vector<std::pair<std::string, Track>> tracks;
  std::vector<double> seconds;
};

// Runs one method on a seed's world and adds its figures to its row (made on first use).
struct Recorder {
  std::vector<EkfDemoRow>* rows;
  SeedRun* run;
  const EkfDemoSetup* setup;
  std::uint64_t seed;
  std::vector<double> online_nees;  // a graph's online NEES, filled while it is smoothed

  void operator()(const std::string& name, const std::function<Track()>& make) {
    EkfDemoRow* row = nullptr;
    for (EkfDemoRow& r : *rows) {
      if (r.method == name) row = &r;
    }
    if (row == nullptr) {
      rows->push_back(EkfDemoRow{});
      row = &rows->back();
      row->method = name;
    }
    const auto t0 = std::chrono::steady_clock::now();
    try {
      Track t = make();
      row->seconds.push_back(SecondsSince(t0));
      row->trajectory_rmse.push_back(ekf::TrajectoryRmse(t.poses, run->world.truth));
      const double landmark_rmse = ekf::LandmarkRmse(t, run->world.landmarks);
      if (std::isfinite(landmark_rmse)) row->landmark_rmse.push_back(landmark_rmse);  // none seen: no figure
      row->wrong_associations.push_back(t.wrong_associations);
      if (setup->consistency) {
        std::vector<double> nees = std::move(online_nees);
        online_nees.clear();
        if (nees.empty() && t.pose_cov.size() == t.poses.size()) {  // a filter's
          for (std::size_t k = 0; k < t.poses.size(); ++k)
            nees.push_back(ekf::Nees(t.poses[k], t.pose_cov[k], run->world.truth[k]));
        }
        if (!nees.empty()) {
          row->step_nees.resize(nees.size(), 0.0);
          for (std::size_t k = 0; k < nees.size(); ++k) row->step_nees[k] += nees[k];
          ++row->nees_runs;
        }
      }
      run->tracks.emplace_back(name, std::move(t));
    } catch (const Error& e) {
      if (row->failures++ == 0) row->failure_note = "seed " + std::to_string(seed) + ": " + e.what();
    }
  }
};

ekf::FastSlamOptions FastSlamOptionsFor(const ekf::FilterOptions& fo, ekf::FastSlamVersion v, int particles,
                                        std::uint64_t seed) {
  ekf::FastSlamOptions so;
  so.filter = fo;
  so.version = v;
  so.particles = particles;
  so.seed = seed;  // the world's: a row is repeatable on its own
  return so;
}

std::string FastSlamName(ekf::FastSlamVersion v, int particles) {
  return std::string("FastSLAM ") + (v == ekf::FastSlamVersion::kOne ? "1.0" : "2.0") + " (" +
         std::to_string(particles) + " particles)";
}

SeedRun RunSeed(int experiment, bool nn, std::uint64_t seed, const EkfDemoSetup& setup, std::vector<EkfDemoRow>* rows) {
  const ekf::LandmarkWorldOptions wo = WorldOptions(experiment, seed, setup);
  SeedRun run;
  run.world = ekf::SimulateLandmarkWorld(wo);
  const ekf::FilterOptions fo = FilterOptionsFor(wo, nn, setup);
  ekf::LandmarkGraphOptions go = GraphOptionsFor(fo);
  go.record_online = setup.consistency;
  Recorder record{rows, &run, &setup, seed, {}};
  const auto track_of = [&](const std::string& name) -> const Track* {
    for (const auto& [n, t] : run.tracks) {
      if (n == name) return &t;
    }
    return nullptr;
  };
  const auto smoothed = [&](const Track& seed_track) {
    ekf::SmoothedTrack s = ekf::SmoothLandmarkRun(run.world, seed_track, go);
    s.track.wrong_associations = seed_track.wrong_associations;
    for (std::size_t k = 0; k < s.online_poses.size(); ++k)
      record.online_nees.push_back(ekf::TangentNees(s.online_poses[k], s.online_pose_cov[k], run.world.truth[k]));
    return s.track;
  };
  // Dead reckoning places its landmarks by the known association, whichever the filters use.
  record(nn ? "dead reckoning (known association)" : "dead reckoning",
         [&] { return ekf::DeadReckoningTrack(run.world); });
  record("EKF", [&] {
    ekf::EkfSlam f(SE2d(), Eigen::Matrix3d::Zero(), fo);
    return ekf::RunFilter(&f, run.world);
  });
  record("UKF", [&] {
    ekf::UkfSlam f(SE2d(), Eigen::Matrix3d::Zero(), fo);
    return ekf::RunFilter(&f, run.world);
  });
  record("invariant EKF", [&] {
    ekf::FilterOptions io = fo;
    io.min_range = setup.invariant_min_range >= 0 ? setup.invariant_min_range : 1.5 * setup.range_sigma;
    io.update_iterations = setup.invariant_iterations;
    ekf::InvariantEkfSlam f(SE2d(), Eigen::Matrix3d::Zero(), io);
    return ekf::RunFilter(&f, run.world);
  });
  for (const int n : setup.fastslam_particles) {
    for (const ekf::FastSlamVersion v : {ekf::FastSlamVersion::kOne, ekf::FastSlamVersion::kTwo}) {
      if (!(v == ekf::FastSlamVersion::kOne ? setup.fastslam_one : setup.fastslam_two)) continue;
      record(FastSlamName(v, n), [&] {
        ekf::FastSlam f(SE2d(), Eigen::Matrix3d::Zero(), FastSlamOptionsFor(fo, v, n, seed));
        return ekf::RunFastSlam(&f, run.world);
      });
    }
  }
  // The graphs, each seeded by a filter's run and built with its associations: (row, seed track).
  std::vector<std::pair<std::string, std::string>> seeds = {
      {"graph (EKF seed)", "EKF"}, {"graph (UKF seed)", "UKF"}, {"graph (dead reckoning seed)", "dead reckoning"}};
  if (nn) seeds.pop_back();  // dead reckoning associates nothing
  if (setup.fastslam_two && !setup.fastslam_particles.empty()) {
    seeds.emplace_back("graph (FastSLAM 2.0 seed)",
                       FastSlamName(ekf::FastSlamVersion::kTwo, setup.fastslam_particles.front()));
  }
  for (const auto& [row, seeded] : seeds) {
    if (!setup.graphs) break;
    const Track* t = track_of(seeded);
    if (t == nullptr) continue;  // that filter failed on this seed
    const Track copy = *t;
    record(row, [&] { return smoothed(copy); });
  }
  return run;
}

std::string MeanStd(const std::vector<double>& v, int digits) {
  if (v.empty()) return "-";
  double mean = 0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double var = 0;
  for (double x : v) var += (x - mean) * (x - mean);
  const double sd = v.size() > 1 ? std::sqrt(var / static_cast<double>(v.size() - 1)) : 0.0;
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << mean << " ± " << sd;
  return s.str();
}

// ---- the picture ----

struct Frame {
  double min_x, max_y, scale;
  svg::Pt operator()(const Eigen::Vector2d& p) const {
    return {40 + (p.x() - min_x) * scale, 40 + (max_y - p.y()) * scale};
  }
};

std::string Ellipse(const Frame& f, const Eigen::Vector2d& c, const Eigen::Matrix2d& cov, const char* colour) {
  // 2-sigma: the points c + 2 L (cos t, sin t), L L^T = cov.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  const Eigen::Vector2d ev = eig.eigenvalues().cwiseMax(0.0);
  svg::PathData d;
  for (int k = 0; k <= 36; ++k) {
    const double t = 2 * 3.14159265358979323846 * k / 36;
    const Eigen::Vector2d p =
        c + 2 * eig.eigenvectors() * Eigen::Vector2d(std::sqrt(ev[0]) * std::cos(t), std::sqrt(ev[1]) * std::sin(t));
    if (k == 0) {
      d.MoveTo(f(p));
    } else {
      d.LineTo(f(p));
    }
  }
  return "<path d=\"" + d.str() + "\" fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"1\"/>\n";
}

// The poses as one path, in order.
std::string PosePath(const Frame& f, const std::vector<SE2d>& poses) {
  svg::PathData d;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i == 0) {
      d.MoveTo(f(poses[i].translation()));
    } else {
      d.LineTo(f(poses[i].translation()));
    }
  }
  return d.str();
}

// FastSLAM 2.0's particles at a few steps, for the picture.
struct Clouds {
  int particles = 0;  // 0: none
  std::vector<std::vector<Eigen::Vector2d>> at;
};

std::string DemoSvg(const SeedRun& run, const std::string& title, const Clouds& clouds) {
  const std::vector<std::pair<std::string, const char*>> colours = {
      {"truth", "#2ca02c"},
      {"dead reckoning", "#999999"},
      {"EKF", "#d62728"},
      {"UKF", "#ff7f0e"},
      {"invariant EKF", "#9467bd"},
      {"graph (EKF seed)", "#1f77b4"},
      {FastSlamName(ekf::FastSlamVersion::kTwo, clouds.particles), "#e377c2"}};
  std::vector<std::pair<std::string, const Track*>> shown;
  Track truth;
  truth.poses = run.world.truth;
  shown.emplace_back("truth", &truth);
  for (const auto& [name, t] : run.tracks) {
    for (const auto& c : colours) {
      if (c.first == name) shown.emplace_back(name, &t);
    }
  }
  Eigen::Vector2d lo = run.world.truth.front().translation(), hi = lo;
  const auto grow = [&](const Eigen::Vector2d& p) {
    if (!p.allFinite() || p.norm() > 1e4) return;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& l : run.world.landmarks) grow(l);
  for (const auto& [name, t] : shown) {
    for (const SE2d& p : t->poses) grow(p.translation());
    for (std::size_t j = 0; j < t->landmarks.size(); ++j) {
      const double r = j < t->landmark_cov.size() ? 2 * std::sqrt(t->landmark_cov[j].trace()) : 0.0;
      grow(t->landmarks[j] + Eigen::Vector2d(r, r));
      grow(t->landmarks[j] - Eigen::Vector2d(r, r));
    }
  }
  const double size = 800;
  const double span = std::max(hi.x() - lo.x(), hi.y() - lo.y()) + 1e-9;
  const Frame f{lo.x(), hi.y(), size / span};
  const double w = 80 + (hi.x() - lo.x()) * f.scale + 320, h = 80 + (hi.y() - lo.y()) * f.scale;
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + svg::Num(w) + "\" height=\"" + svg::Num(h) +
                  "\" font-family=\"sans-serif\" font-size=\"13\">\n<rect width=\"100%\" height=\"100%\" "
                  "fill=\"white\"/>\n<text x=\"40\" y=\"24\">" +
                  svg::Escape(title) + "</text>\n";
  double legend_y = 60;
  const double legend_x = 60 + (hi.x() - lo.x()) * f.scale;
  for (const auto& [name, t] : shown) {
    const char* colour = "#000";
    for (const auto& c : colours) {
      if (c.first == name) colour = c.second;
    }
    const bool wide = name == "truth";
    s += "<path d=\"" + PosePath(f, t->poses) + "\" fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"" +
         (wide ? "4" : "1.3") + "\" stroke-opacity=\"" + (wide ? "0.5" : "0.9") + "\"/>\n";
    // Landmarks and their 2-sigma ellipses (filters), estimates (graph).
    for (std::size_t j = 0; j < t->landmarks.size(); ++j) {
      if (!t->landmarks[j].allFinite()) continue;
      const svg::Pt p = f(t->landmarks[j]);
      s += "<circle cx=\"" + svg::Num(p.x) + "\" cy=\"" + svg::Num(p.y) + "\" r=\"2.5\" fill=\"" + colour + "\"/>\n";
      if (j < t->landmark_cov.size()) s += Ellipse(f, t->landmarks[j], t->landmark_cov[j], colour);
    }
    if (!t->pose_cov.empty()) {
      s += Ellipse(f, t->poses.back().translation(), t->pose_cov.back().topLeftCorner<2, 2>(), colour);
    }
    s += "<line x1=\"" + svg::Num(legend_x) + "\" y1=\"" + svg::Num(legend_y - 4) + "\" x2=\"" +
         svg::Num(legend_x + 24) + "\" y2=\"" + svg::Num(legend_y - 4) + "\" stroke=\"" + colour +
         "\" stroke-width=\"3\"/>\n<text x=\"" + svg::Num(legend_x + 30) + "\" y=\"" + svg::Num(legend_y) + "\">" +
         svg::Escape(name) + " (RMSE " + svg::Label(ekf::TrajectoryRmse(t->poses, run.world.truth), 3) + " m)</text>\n";
    legend_y += 20;
  }
  for (const auto& cloud : clouds.at) {
    for (const Eigen::Vector2d& q : cloud) {
      const svg::Pt p = f(q);
      s += "<circle cx=\"" + svg::Num(p.x) + "\" cy=\"" + svg::Num(p.y) +
           "\" r=\"1\" fill=\"#e377c2\" fill-opacity=\"0.6\"/>\n";
    }
  }
  for (const Eigen::Vector2d& l : run.world.landmarks) {
    const svg::Pt p = f(l);
    s += "<path d=\"M" + svg::Num(p.x - 5) + " " + svg::Num(p.y - 5) +
         "l10 10m0 -10l-10 10\" stroke=\"#000\" "
         "stroke-width=\"1.5\"/>\n";
  }
  s += "<text x=\"" + svg::Num(legend_x) + "\" y=\"" + svg::Num(legend_y) +
       "\">x true landmarks; ellipses: 2 sigma</text>\n";
  if (!clouds.at.empty()) {
    s += "<text x=\"" + svg::Num(legend_x) + "\" y=\"" + svg::Num(legend_y + 20) +
         "\">dots: FastSLAM's particles every 50 steps</text>\n";
  }
  s += "</svg>\n";
  return s;
}

}  // namespace

EkfDemoConfig RunEkfExperiment(int experiment, bool nearest_neighbour, int seeds, std::uint64_t first_seed,
                               const EkfDemoSetup& setup) {
  EkfDemoConfig c;
  c.experiment = experiment;
  c.nearest_neighbour = nearest_neighbour;
  c.setup = setup;
  for (int k = 0; k < seeds; ++k) {
    const SeedRun run =
        RunSeed(experiment, nearest_neighbour, first_seed + static_cast<std::uint64_t>(k), setup, &c.rows);
    for (const auto& step : run.world.observations) c.observations += static_cast<double>(step.size()) / seeds;
  }
  return c;
}

std::string EkfDemoTable(const std::vector<EkfDemoConfig>& configs) {
  std::ostringstream s;
  s << "| experiment | association | method | trajectory RMSE [m] | landmark RMSE [m] | wrong associations (of "
       "observations) | time [ms] | failed runs |\n|---|---|---|---|---|---|---|---|\n";
  for (const EkfDemoConfig& c : configs) {
    for (const EkfDemoRow& r : c.rows) {
      std::vector<double> ms;
      for (double t : r.seconds) ms.push_back(1e3 * t);
      s << "| " << c.experiment << " | " << (c.nearest_neighbour ? "nearest neighbour" : "known") << " | " << r.method
        << " | " << MeanStd(r.trajectory_rmse, 3) << " | " << MeanStd(r.landmark_rmse, 3) << " | "
        << MeanStd(r.wrong_associations, 1) << " (of " << std::lround(c.observations) << ") | " << MeanStd(ms, 1)
        << " | " << r.failures << " |\n";
    }
  }
  return s.str();
}

std::string EkfDemoConsistencyTable(const std::vector<EkfDemoConfig>& configs) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s << "| experiment | association | method | runs | average NEES, mean over steps | steps inside the 95% "
       "interval | at step 10 | 50 | 100 | last |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const EkfDemoConfig& c : configs) {
    for (const EkfDemoRow& r : c.rows) {
      if (r.nees_runs == 0 || r.step_nees.size() < 3) continue;
      const ekf::NeesInterval bounds = ekf::AverageNeesInterval(r.nees_runs, 3);
      double mean = 0;
      int inside = 0;
      const std::size_t n = r.step_nees.size();
      for (std::size_t k = 2; k < n; ++k) {
        const double a = r.step_nees[k] / r.nees_runs;
        mean += a / static_cast<double>(n - 2);
        if (bounds.Contains(a)) ++inside;
      }
      const auto at = [&](std::size_t k) {
        std::ostringstream v;
        v.setf(std::ios::fixed);
        v.precision(2);
        if (k < n)
          v << r.step_nees[k] / r.nees_runs;
        else
          v << "-";
        return v.str();
      };
      s.precision(2);
      s << "| " << c.experiment << " | " << (c.nearest_neighbour ? "nearest neighbour" : "known") << " | " << r.method
        << " | " << r.nees_runs << " | " << mean << " | " << inside << " of " << n - 2 << " in [" << bounds.lower
        << ", " << bounds.upper << "] | " << at(10) << " | " << at(50) << " | " << at(100) << " | " << at(n - 1)
        << " |\n";
    }
  }
  return s.str();
}

std::string EkfDemoSvg(int experiment, bool nearest_neighbour, std::uint64_t seed, const EkfDemoSetup& setup) {
  std::vector<EkfDemoRow> rows;
  const SeedRun run = RunSeed(experiment, nearest_neighbour, seed, setup, &rows);
  // FastSLAM 2.0's particles every 50 steps, from the same run as its row (the same seed).
  Clouds clouds;
  if (setup.fastslam_two && !setup.fastslam_particles.empty()) {
    clouds.particles = setup.fastslam_particles.front();
    const ekf::LandmarkWorldOptions wo = WorldOptions(experiment, seed, setup);
    ekf::FastSlam f(SE2d(), Eigen::Matrix3d::Zero(),
                    FastSlamOptionsFor(FilterOptionsFor(wo, nearest_neighbour, setup), ekf::FastSlamVersion::kTwo,
                                       clouds.particles, seed));
    for (std::size_t k = 0; k < run.world.odometry.size(); ++k) {
      f.Predict(run.world.odometry[k], run.world.dt);
      f.Update(run.world.observations[k]);
      if ((k + 1) % 50 == 0 || k + 1 == run.world.odometry.size()) {
        std::vector<Eigen::Vector2d> cloud;
        for (int i = 0; i < f.particle_count(); ++i) cloud.push_back(f.particle_pose(i).translation());
        clouds.at.push_back(std::move(cloud));
      }
    }
  }
  return DemoSvg(run,
                 "experiment " + std::to_string(experiment) + ", " +
                     (nearest_neighbour ? "nearest-neighbour" : "known") + " association, seed " + std::to_string(seed),
                 clouds);
}

}  // namespace tether
