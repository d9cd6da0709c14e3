#pragma once
// Reading and writing graph files: g2o, TORO 2D and iSAM's 2D text format.
//
// g2o: VERTEX_SE2, VERTEX_SE3:QUAT, VERTEX_XY, VERTEX_TRACKXYZ, FIX, PARAMS_SE3OFFSET, comments
// (#), and every edge tag in the registry. TORO 2D: VERTEX2, EDGE2 (information in TORO's order
// I11 I12 I22 I33 I13 I23), BR (bearing-range landmark observations), EQUIV ignored with a
// warning. iSAM: ODOMETRY and EDGE2 (pose-pose) and LANDMARK (a point in the pose's frame), each
// with the upper triangle of its square-root information matrix R, row by row (information
// R^T R). Landmark ids of LANDMARK and BR lines are kept apart from pose ids by
// ReadOptions::landmark_key_offset. Errors are ParseErrors starting with "file:line:".
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/factor_graph.h"
#include "tether/core/registry.h"
#include "tether/core/sqrt_information.h"
#include "tether/core/values.h"

namespace tether {

/// How EDGE2 (and the other TORO and iSAM tags) are read; see docs/file-formats.md.
enum class FileFormat { kAuto, kG2o, kToro, kIsam };
inline constexpr EnumName<FileFormat> kFileFormatNames[] = {
    {FileFormat::kAuto, "auto"}, {FileFormat::kG2o, "g2o"}, {FileFormat::kToro, "toro"}, {FileFormat::kIsam, "isam"}};
constexpr const auto& EnumNames(FileFormat) { return kFileFormatNames; }

/// Which edges of a file are marked as loop closures (Factor::loop_closure).
enum class LoopClosureRule {
  kNone,            ///< none
  kNonConsecutive,  ///< an edge between two poses whose ids are not consecutive (|i - j| != 1)
};

/// What the noise numbers of iSAM's ODOMETRY, EDGE2 and LANDMARK lines are (the upper triangle
/// of a symmetric or triangular matrix, row by row: 6 numbers for a pose edge, 3 for a landmark).
enum class IsamNoise {
  kSquareRootInformation,  ///< iSAM's own reading: the upper-triangular square root R; information R^T R
  kCovariance,             ///< the covariance (GTSAM reads victoria_park.txt so); information its inverse
};
inline constexpr EnumName<IsamNoise> kIsamNoiseNames[] = {{IsamNoise::kSquareRootInformation, "sqrt-information"},
                                                          {IsamNoise::kCovariance, "covariance"}};
constexpr const auto& EnumNames(IsamNoise) { return kIsamNoiseNames; }

struct ReadOptions {
  /// kAuto: a ".graph" name is TORO; otherwise an ODOMETRY or LANDMARK line in the first 64 KiB
  /// makes the file iSAM (EDGE2 with iSAM's square-root information), else EDGE2 is TORO's.
  FileFormat format = FileFormat::kAuto;
  InformationRepair repair = InformationRepair::kNone;
  /// Give vertices that have no VERTEX line initial values by composing edges along a
  /// spanning tree from the lowest id (only allowed where the file has no vertex lines at all
  /// or allow_partial_vertices is set).
  bool allow_partial_vertices = false;
  /// Default: edges between poses with non-consecutive ids are loop closures. The mark alone
  /// changes nothing in a solve; robust rules ("loop=huber:1") select by it.
  LoopClosureRule loop_closures = LoopClosureRule::kNonConsecutive;
  /// Landmark ids of iSAM LANDMARK and TORO BR lines name landmarks apart from poses (iSAM's
  /// cityTrees10000 numbers landmarks 0..99 beside poses 0..9999): landmark id l becomes key
  /// l + landmark_key_offset. The default keeps the keys of files with fewer than 1e9 poses and
  /// 1.1e9 landmarks apart and below 2^31, so the graph written as g2o keeps ids g2o can read
  /// (its ids are int). Ids of g2o lines (VERTEX_XY, EDGE_SE2_XY, ...) are never offset.
  Key landmark_key_offset = 1000000000;
  /// How the noise numbers of iSAM lines are read (default: as iSAM itself reads them).
  IsamNoise isam_noise = IsamNoise::kSquareRootInformation;
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
