#pragma once
// Initial guesses for the nonlinear solvers, computed from the measurements alone.
//
//   kFile          keep the values as they are (the file's vertices; a file with edges only
//                  has had its missing vertices composed along a spanning tree when read).
//   kSpanningTree  discard the poses' and points' values and compose the measurements outward
//                  (breadth first) from an anchor of each connected piece: a fixed variable,
//                  or else the lowest key, kept where it was.
//   kChordal       rotations first, by linear least squares on the chordal distance
//                  ||R_j - R_i R_ij||_F^2 over every pose-pose measurement, projected back onto
//                  SO(2)/SO(3); then translations by linear least squares with those rotations
//                  held; then points from the poses that observe them. Anchored like the
//                  spanning tree. See docs/initialisation.md.
//
// Every method works on any factor type that implements Factor::Predict (the built-in ones
// and plugins that do); factors that cannot predict (unary priors, say) are ignored here and
// only enter in the nonlinear solve.
#include <string>

#include "tether/core/enum_names.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

enum class InitMethod { kFile, kSpanningTree, kChordal };
inline constexpr EnumName<InitMethod> kInitMethodNames[] = {
    {InitMethod::kFile, "file"}, {InitMethod::kSpanningTree, "spanning-tree"}, {InitMethod::kChordal, "chordal"}};
constexpr const auto& EnumNames(InitMethod) { return kInitMethodNames; }

struct InitSummary {
  InitMethod method = InitMethod::kFile;
  double seconds = 0;
  int poses_set = 0;   ///< poses given a new value
  int points_set = 0;  ///< points given a new value
  int anchors = 0;     ///< variables kept where they were (one per piece at least)
  /// Pose-pose measurements used (chordal: in the rotation and translation systems).
  int measurements_used = 0;
  std::string message;  ///< one line for reports
};

/// Replaces the values of the variables used by `graph` by an initial guess made with
/// `method`. Values not used by any factor are left alone. Throws InvalidArgument (and leaves
/// `values` untouched) when a variable used by the graph has no value and cannot be reached,
/// or when a linear system is singular.
InitSummary Initialize(const FactorGraph& graph, Values* values, InitMethod method);
/// As above; where `linear_solver` names a solver that spans the processes of an MPI job
/// ("petsc", "petsc-iterative"; tether/solvers/distributed.h), the chordal start's rotation
/// and translation systems are solved by it, every process taking part and getting the same
/// start. Any other name: as above (the default sparse Cholesky).
InitSummary Initialize(const FactorGraph& graph, Values* values, InitMethod method,
                       const LinearSolverType& linear_solver);

}  // namespace tether
