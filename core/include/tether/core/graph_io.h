#pragma once
// Reading and writing graph files: g2o and TORO 2D.
//
// g2o: VERTEX_SE2, VERTEX_SE3:QUAT, VERTEX_XY, FIX, comments (#), and every edge tag in the
// registry. TORO 2D: VERTEX2, EDGE2 (information in TORO's order I11 I12 I22 I33 I13 I23),
// EQUIV ignored with a warning. Errors are ParseErrors starting with "file:line:".
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/registry.h"
#include "tether/core/sqrt_information.h"
#include "tether/core/values.h"

namespace tether {

enum class FileFormat { kAuto, kG2o, kToro };

/// Which edges of a file are marked as loop closures (Factor::loop_closure).
enum class LoopClosureRule {
  kNone,            ///< none
  kNonConsecutive,  ///< an edge between two poses whose ids are not consecutive (|i - j| != 1)
};

struct ReadOptions {
  FileFormat format = FileFormat::kAuto;  ///< kAuto: ".graph" (or VERTEX2/EDGE2 lines) is TORO
  InformationRepair repair = InformationRepair::kNone;
  /// Give vertices that have no VERTEX line initial values by composing edges along a
  /// spanning tree from the lowest id (only allowed where the file has no vertex lines at all
  /// or allow_partial_vertices is set).
  bool allow_partial_vertices = false;
  /// Default: edges between poses with non-consecutive ids are loop closures. The mark alone
  /// changes nothing in a solve; robust rules ("loop=huber:1") select by it.
  LoopClosureRule loop_closures = LoopClosureRule::kNonConsecutive;
};

struct GraphFile {
  Values values;
  FactorGraph graph;
  std::vector<std::string> warnings;
  int repaired_informations = 0;         ///< information matrices changed by the repair option
  int initialised_by_spanning_tree = 0;  ///< vertices that got their initial value from edges
  int loop_closures = 0;                 ///< factors marked as loop closures
};

/// Reads a file; throws ParseError ("file:line: problem; what to do") or IoError.
GraphFile ReadGraphFile(const std::string& path, const Registry& registry, const ReadOptions& options = {});
/// Reads from a stream; `name` is used in messages.
GraphFile ReadGraph(std::istream& in, const std::string& name, const Registry& registry,
                    const ReadOptions& options = {});

/// Writes g2o. The file is written to a temporary name and renamed, so a failure never
/// leaves half a file. Throws IoError.
void WriteG2oFile(const std::string& path, const Values& values, const FactorGraph& graph, const Registry& registry);
void WriteG2o(std::ostream& out, const Values& values, const FactorGraph& graph, const Registry& registry);

/// Connected pieces of the graph (variables linked through factors with two or more keys),
/// each sorted, pieces ordered by their lowest key.
std::vector<std::vector<Key>> ConnectedPieces(const Values& values, const FactorGraph& graph);

/// Gives every key used by `graph` but missing from `values` an initial value by composing
/// factor predictions outward (breadth first) from the variables already present, or from
/// the lowest key (set to the identity) when none is. Returns how many were initialised.
/// Throws InvalidArgument naming a key that cannot be reached.
int InitializeSpanningTree(const FactorGraph& graph, Values* values);

}  // namespace tether
