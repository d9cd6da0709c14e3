#pragma once
// The whole library in one include: core (Lie groups, keys, variable types, Values, factors,
// noise, the registry, g2o/TORO files, the Jacobian checker), the built-in factors, the
// plugin loader, and the solvers (Gauss-Newton, Levenberg-Marquardt, dog-leg, the Ceres
// adapter, initialisation, marginal covariances, the incremental smoother, the read ->
// initialise -> optimise -> write pipeline), with the trajectory error and the SVG plot.
//
//   #include "tether/tether.h"
//   tether::FactorGraph graph;
//   graph.Add<tether::BetweenSE2>(0, 1, tether::SE2d(1, 0, 0), tether::SqrtInformation::FromSigmas(sigmas));
//
// Finer-grained headers build faster; this one is for applications and first steps.
#include "tether/core/autodiff_factor.h"
#include "tether/core/error.h"
#include "tether/core/factor.h"
#include "tether/core/factor_graph.h"
#include "tether/core/graph_io.h"
#include "tether/core/jacobian_check.h"
#include "tether/core/key.h"
#include "tether/core/loss_function.h"
#include "tether/core/loss_registry.h"
#include "tether/core/registry.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/robust_rules.h"
#include "tether/core/se2.h"
#include "tether/core/se3.h"
#include "tether/core/so2.h"
#include "tether/core/so3.h"
#include "tether/core/sqrt_information.h"
#include "tether/core/svg_plot.h"
#include "tether/core/trajectory_error.h"
#include "tether/core/values.h"
#include "tether/core/variable.h"
#include "tether/core/version.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/marginal_prior.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/factors/switchable.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/ceres_adapter.h"
#include "tether/solvers/ceres_problem.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/fixed_lag_smoother.h"
#include "tether/solvers/gnc.h"
#include "tether/solvers/incremental_smoother.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"
#include "tether/solvers/pipeline.h"
#include "tether/solvers/solver_options.h"
#include "tether/solvers/step_strategy.h"
#include "tether/solvers/switchable.h"
