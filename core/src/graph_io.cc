#include "tether/core/graph_io.h"

#include <unistd.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>
#include <string_view>
#include <unordered_map>

#include "tether/core/error.h"
#include "tether/core/fields.h"
#include "tether/core/output_file.h"

namespace tether {

namespace {

// The tags this file reads itself; every other edge tag comes from the registry.
constexpr std::string_view kFix = "FIX";
constexpr std::string_view kToroVertex = "VERTEX2";
constexpr std::string_view kToroEdge = "EDGE2";
constexpr std::string_view kToroEquiv = "EQUIV";
constexpr std::string_view kToroBearingRange = "BR";
// iSAM's text format (EDGE2 shared with TORO, with another information layout).
constexpr std::string_view kIsamOdometry = "ODOMETRY";
constexpr std::string_view kIsamLandmark = "LANDMARK";
// g2o's sensor offset on a 3D pose, referred to by EDGE_SE3_TRACKXYZ and EDGE_SE3_PRIOR.
constexpr std::string_view kSe3Offset = "PARAMS_SE3OFFSET";

// At most this many pieces are described in the "disconnected" message.
constexpr std::size_t kPiecesListed = 5;

bool EndsWith(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Plural(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// What the reader knows about one id of the file.
struct IdInfo {
  VarType type = VarType::kSE2;
  long type_line = 0;         // the line that gave the id its type
  std::string_view type_tag;  // that line's tag (static or registry-owned storage)
  long vertex_line = 0;       // 0: no vertex line (yet)
  long first_edge_line = 0;   // 0: no edge uses it (yet)
  std::string_view first_edge_tag;
  bool landmark = false;  // named by a LANDMARK or BR line: needs no vertex line
};

class Reader {
 public:
  Reader(const std::string& name, const Registry& registry, const ReadOptions& options)
      : name_(name), registry_(registry), options_(options) {
    ctx_.repair = options.repair;
    toro_by_name_ =
        options.format == FileFormat::kToro || (options.format == FileFormat::kAuto && EndsWith(name, ".graph"));
    isam_ = options.format == FileFormat::kIsam;
    for (const auto& [vname, type] : registry.variable_types()) {
      const VariableType& d = Describe(type);
      if (d.tag.empty()) continue;
      std::string layout = "id";
      if (!d.parameter_names.empty()) {
        layout += " " + d.parameter_names;
      } else {
        for (int i = 0; i < d.ambient_dim; ++i) layout += " p" + std::to_string(i + 1);
      }
      vertex_tags_.push_back(VertexTag{d.tag, type, std::move(layout), 0, 0});
    }
  }

  void Line(long number, std::string_view text) {
    fields_.Reset(number, text);  // one Fields for every line: no allocation per line
    const Fields& f = fields_;
    if (f.size() == 0 || f.tag()[0] == '#') return;
    const std::string_view tag = f.tag();
    if (VertexTag* v = FindVertexTag(tag)) {
      ReadVertex(f, *v);
    } else if (tag == kFix) {
      if (f.size() < 2) f.Fail("FIX needs at least one id after the tag (FIX id [id ...]); fix or remove the line");
      for (std::size_t i = 1; i < f.size(); ++i) fixes_.push_back({f.Id(i), number});
    } else if (tag == kSe3Offset) {
      ReadSe3Offset(f);
    } else if (IsIsamTag(tag)) {
      IsamLine(f);
    } else if (IsToroTag(tag)) {
      ToroLine(f);
    } else if (const FactorType* type = registry_.FindByTag(std::string(tag))) {
      Edge(f, type->tag, registry_.Read(*type, f, ctx_));
    } else {
      UnknownTag(f);
    }
  }

  // kAuto, a name that does not say TORO: an ODOMETRY or LANDMARK line in the file's first
  // block makes it iSAM, so that its EDGE2 lines (often all before the first LANDMARK) are read
  // with iSAM's information layout.
  void Sniff(std::string_view block) {
    if (options_.format != FileFormat::kAuto || toro_by_name_) return;
    while (!block.empty()) {
      const std::size_t nl = block.find('\n');
      std::string_view line = block.substr(0, nl);
      const std::size_t start = line.find_first_not_of(" \t\r");
      if (start != std::string_view::npos) {
        line.remove_prefix(start);
        const std::string_view tag = line.substr(0, line.find_first_of(" \t\r"));
        if ((tag == kIsamOdometry || tag == kIsamLandmark) && IsIsamTag(tag)) {
          isam_ = true;
          return;
        }
      }
      if (nl == std::string_view::npos) break;
      block.remove_prefix(nl + 1);
    }
  }

  GraphFile Finish() {
    GraphFile out;
    if (out_values_.empty() && graph_.empty()) {
      throw ParseError(name_ + ": no vertices or edges found; is this a g2o or TORO graph file?");
    }
    for (const auto& [key, line] : fixes_) {
      if (ids_.count(key) == 0) {
        throw ParseError(name_ + ":" + std::to_string(line) + ": FIX names id " + std::to_string(key) +
                         ", which no vertex or edge uses; remove it from the FIX line or add its vertex");
      }
      graph_.Fix(key);
    }
    CheckMissingVertices();
    CheckConnected();
    const bool complete =
        std::all_of(ids_.begin(), ids_.end(), [](const auto& kv) { return kv.second.vertex_line != 0; });
    if (!complete) {
      try {
        out.initialised_by_spanning_tree = InitializeSpanningTree(graph_, &out_values_);
      } catch (const InvalidArgument& e) {
        throw ParseError(name_ + ": " + e.what());
      }
    }
    if (options_.isam_noise != ReadOptions().isam_noise && !isam_) {
      out.warnings.push_back(name_ + ": the iSAM noise reading '" + ToString(options_.isam_noise) +
                             "' changed nothing: the file was not read as iSAM's (no ODOMETRY or LANDMARK line; "
                             "give the iSAM format to read its EDGE2 lines so)");
    }
    if (equiv_lines_ > 0) {
      out.warnings.push_back(name_ + ": ignored " + Plural(equiv_lines_, "EQUIV line", "EQUIV lines") +
                             " (first at line " + std::to_string(first_equiv_line_) +
                             "): TORO's EQUIV says two ids are the same pose; tether does not merge them, so each "
                             "id stays a separate variable linked only by its edges");
    }
    for (const VertexTag& v : vertex_tags_) {
      if (v.canonicalized == 0) continue;
      out.warnings.push_back(name_ + ": " + Describe(v.type).canonicalize_note + " on " +
                             Plural(v.canonicalized, "line", "lines") + " " + v.tag + " (first at line " +
                             std::to_string(v.first_canonicalized_line) + ")");
    }
    if (ctx_.canonicalized_measurements > 0) {
      out.warnings.push_back(
          name_ + ": " + ctx_.canonicalize_note + " in " +
          Plural(static_cast<std::size_t>(ctx_.canonicalized_measurements), "edge measurement", "edge measurements") +
          " (first at line " + std::to_string(ctx_.first_canonicalized_line) + ")");
    }
    if (ctx_.repaired_informations > 0) {
      out.warnings.push_back(name_ + ": repaired " +
                             Plural(ctx_.repaired_informations, "information matrix", "information matrices") +
                             " that were not positive definite (first at line " +
                             std::to_string(ctx_.first_repaired_line) + ") with '" + ToString(ctx_.repair) + "'");
    }
    out.repaired_informations = ctx_.repaired_informations;
    if (options_.loop_closures == LoopClosureRule::kNonConsecutive) out.loop_closures = MarkLoopClosures();
    out.values = std::move(out_values_);
    out.graph = std::move(graph_);
    return out;
  }

 private:
  // Marks the factors between two poses whose ids are not consecutive as loop closures (only
  // two-key factors: a switchable edge, which carries its own switch, is not marked, so that
  // GNC or switchable constraints do not wrap it again).
  int MarkLoopClosures() {
    int marked = 0;
    std::size_t next_odometry = 0;  // odometry_factors_ is ascending
    for (std::size_t i = 0; i < graph_.size(); ++i) {
      if (next_odometry < odometry_factors_.size() && odometry_factors_[next_odometry] == i) {
        ++next_odometry;
        continue;
      }
      Factor& f = graph_.at(i);
      if (f.keys().size() != 2) continue;
      const Key a = f.keys()[0], b = f.keys()[1];
      if (!out_values_.Has(a) || !out_values_.Has(b)) continue;
      if (!IsPose(out_values_.TypeOf(a)) || !IsPose(out_values_.TypeOf(b))) continue;
      if ((a > b ? a - b : b - a) == 1) continue;
      f.set_loop_closure(true);
      ++marked;
    }
    return marked;
  }

  // A vertex tag of the registry, with what reading its lines needs.
  struct VertexTag {
    std::string tag;
    VarType type;
    std::string layout;  // "id x y theta", for messages
    std::size_t canonicalized;
    long first_canonicalized_line;
  };

  VertexTag* FindVertexTag(std::string_view tag) {
    for (VertexTag& v : vertex_tags_)
      if (v.tag == tag) return &v;
    return nullptr;
  }

  void ReadVertex(const Fields& f, VertexTag& v) {
    const VariableType& d = Describe(v.type);
    f.ExpectCount(1 + static_cast<std::size_t>(d.ambient_dim), v.layout);
    params_.resize(static_cast<std::size_t>(d.ambient_dim));
    for (int i = 0; i < d.ambient_dim; ++i) params_[i] = f.Double(2 + static_cast<std::size_t>(i));
    if (d.canonicalize) {
      bool changed = false;
      try {
        changed = d.canonicalize(params_.data());
      } catch (const InvalidArgument& e) {
        f.Fail(v.tag + " " + e.what() + "; fix the line");
      }
      if (changed && v.canonicalized++ == 0) v.first_canonicalized_line = f.line_number();
    }
    Vertex(f, v.tag, v.type, params_.data());
  }

  // PARAMS_SE3OFFSET id x y z qx qy qz qw: kept in the read context for the edges below it.
  void ReadSe3Offset(const Fields& f) {
    f.ExpectCount(8, "id x y z qx qy qz qw");
    const Key id = f.Id(1);
    std::vector<double> p(7);
    for (std::size_t i = 0; i < 7; ++i) p[i] = f.Double(2 + i);
    const double norm = Eigen::Map<const Eigen::Vector4d>(p.data() + 3).stableNorm();
    if (!(norm > 1e-12)) {
      f.Fail(std::string(kSe3Offset) +
             " quaternion (qx qy qz qw, fields 5 to 8) is zero; an offset needs a unit "
             "quaternion (0 0 0 1 for none), fix the line");
    }
    for (std::size_t i = 3; i < 7; ++i) p[i] /= norm;
    const auto [it, inserted] = ctx_.parameters.try_emplace(id);
    if (!inserted) {
      f.Fail("duplicate parameter id " + std::to_string(id) + ": line " + std::to_string(it->second.line) +
             " defines it already (" + it->second.tag + "); remove one of the two lines or renumber one");
    }
    it->second = ReadContext::Parameter{std::string(kSe3Offset), std::move(p), f.line_number()};
  }

  bool IsIsamTag(std::string_view tag) const {
    if (tag != kIsamOdometry && tag != kIsamLandmark) return false;
    if (options_.format == FileFormat::kG2o) return false;
    return options_.format == FileFormat::kIsam || registry_.FindByTag(std::string(tag)) == nullptr;
  }

  // The key of a landmark id in field `field` (iSAM LANDMARK, TORO BR).
  Key LandmarkKey(const Fields& f, std::size_t field) {
    const Key id = f.Id(field);
    const Key offset = options_.landmark_key_offset;
    if (id > std::numeric_limits<Key>::max() - offset) {
      f.Fail(std::string(f.tag()) + " field " + std::to_string(field) + ": landmark id " + std::to_string(id) +
             " plus the landmark key offset " + std::to_string(offset) +
             " passes the largest key; renumber the landmarks or read with a smaller "
             "ReadOptions::landmark_key_offset");
    }
    ++landmark_lines_;
    return id + offset;
  }

  // Adds a pose-landmark factor and marks its landmark as needing no vertex line.
  void LandmarkEdge(const Fields& f, std::string_view stable_tag, std::unique_ptr<Factor> factor) {
    const Key landmark = factor->keys()[1];
    Edge(f, stable_tag, std::move(factor));
    ids_.at(landmark).landmark = true;
  }

  const FactorType& BuiltinType(const Fields& f, const char* name) const {
    const FactorType* type = registry_.FindByName(name);
    if (!type || !type->make) {
      f.Fail(std::string(f.tag()) + " needs the factor type '" + name +
             "', which is not registered; call RegisterBuiltinFactors");
    }
    return *type;
  }

  // iSAM's noise, starting at field `first`: the upper triangle, row by row, of the square-root
  // information R (information R^T R) or, with IsamNoise::kCovariance, of the covariance.
  SqrtInformation IsamNoise(const Fields& f, std::size_t first, int dim) {
    Eigen::MatrixXd r = Eigen::MatrixXd::Zero(dim, dim);
    std::size_t k = first;
    for (int i = 0; i < dim; ++i)
      for (int j = i; j < dim; ++j) r(i, j) = f.Double(k++);
    if (options_.isam_noise == IsamNoise::kCovariance) {
      const Eigen::MatrixXd cov = r.selfadjointView<Eigen::Upper>();
      SqrtInformation check;
      std::string why;
      if (!SqrtInformation::TryFromInformation(cov, &check, &why)) {
        f.Fail(std::string(f.tag()) + ": the covariance (fields " + std::to_string(first) + " to " +
               std::to_string(k - 1) + ", read as a covariance: IsamNoise::kCovariance) is not usable: " + why +
               "; fix or remove the line");
      }
      const Eigen::MatrixXd omega = cov.llt().solve(Eigen::MatrixXd::Identity(dim, dim));
      return ctx_.FromInformation(f, 0.5 * (omega + omega.transpose()));
    }
    k = first;
    for (int i = 0; i < dim; ++i) {
      if (r(i, i) == 0) {
        f.Fail(std::string(f.tag()) + " field " + std::to_string(k) + " (R" + std::to_string(i + 1) +
               std::to_string(i + 1) +
               ", a diagonal entry of the square-root information) is 0, so the information R^T R is singular; "
               "fix or remove the line");
      }
      k += static_cast<std::size_t>(dim - i);
    }
    return ctx_.FromInformation(f, r.transpose() * r);
  }

  void IsamLine(const Fields& f) {
    // A file named or declared TORO keeps TORO's EDGE2 and reads the iSAM lines beside it.
    if (!isam_ && !toro_by_name_) {
      if (toro_edge2_line_ != 0) {
        f.Fail(std::string(f.tag()) +
               " is a tag of iSAM's format, whose EDGE2 lists the information otherwise than "
               "TORO's, but line " +
               std::to_string(toro_edge2_line_) +
               " was read as a TORO EDGE2 (no ODOMETRY or LANDMARK line in the first 64 KiB said the file is iSAM); "
               "read the file as iSAM (ReadOptions::format = FileFormat::kIsam), or move an iSAM line to its start");
      }
      isam_ = true;
    }
    if (f.tag() == kIsamOdometry) {
      IsamEdge(f, kIsamOdometry);
      return;
    }
    f.ExpectCount(7, "pose landmark dx dy R11 R12 R22 (square-root information, upper triangle row by row)");
    const Key pose = f.Id(1);
    const Key landmark = LandmarkKey(f, 2);
    const double z[2] = {f.Double(3), f.Double(4)};
    const SqrtInformation noise = IsamNoise(f, 5, 2);
    LandmarkEdge(f, kIsamLandmark, BuiltinType(f, "PosePoint2").make({pose, landmark}, z, noise));
  }

  // ODOMETRY, and EDGE2 of an iSAM file: id1 id2 dx dy dtheta R11 R12 R13 R22 R23 R33.
  void IsamEdge(const Fields& f, std::string_view stable_tag) {
    f.ExpectCount(11,
                  "id1 id2 dx dy dtheta R11 R12 R13 R22 R23 R33 (square-root information, upper triangle row "
                  "by row, iSAM's layout)");
    const std::vector<Key> keys = {f.Id(1), f.Id(2)};
    const double z[3] = {f.Double(3), f.Double(4), f.Double(5)};
    const SqrtInformation noise = IsamNoise(f, 6, 3);
    const FactorType& type = BuiltinType(f, "BetweenSE2");
    Edge(f, stable_tag, type.make(keys, z, noise));
    // iSAM's ODOMETRY says what the edge is; its pose ids may skip the numbers landmarks use.
    if (stable_tag == kIsamOdometry) odometry_factors_.push_back(graph_.size() - 1);
  }

  // BR pose landmark bearing range sigma_bearing sigma_range (TORO's landmark observation).
  void ToroBearingRange(const Fields& f) {
    f.ExpectCount(6, "pose landmark bearing range sigma_bearing sigma_range");
    const Key pose = f.Id(1);
    const Key landmark = LandmarkKey(f, 2);
    const double bearing = f.Double(3), range = f.Double(4);
    if (!(range > 0)) {
      f.Fail("BR range (field 4) is " + FormatDouble(range) +
             "; a range is a positive distance (at range 0 the landmark has no bearing); fix or remove the line");
    }
    const char* names[2] = {"sigma_bearing (field 5)", "sigma_range (field 6)"};
    double sigma[2];
    for (std::size_t i = 0; i < 2; ++i) {
      sigma[i] = f.Double(5 + i);
      if (!(sigma[i] > 0)) {
        f.Fail(std::string("BR ") + names[i] + " is " + FormatDouble(sigma[i]) +
               "; a standard deviation must be positive; fix or remove the line");
      }
    }
    // The factor's residual is (range, bearing).
    Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(2, 2);
    omega(0, 0) = 1.0 / (sigma[1] * sigma[1]);
    omega(1, 1) = 1.0 / (sigma[0] * sigma[0]);
    const SqrtInformation noise = ctx_.FromInformation(f, std::move(omega));
    const double z[2] = {range, bearing};
    LandmarkEdge(f, kToroBearingRange, BuiltinType(f, "RangeBearing2").make({pose, landmark}, z, noise));
  }

  bool IsToroTag(std::string_view tag) const {
    if (tag != kToroVertex && tag != kToroEdge && tag != kToroEquiv && tag != kToroBearingRange) return false;
    if (options_.format == FileFormat::kG2o) return false;
    // A plugin may define a g2o edge with a TORO name; in auto mode only a .graph name
    // gives the TORO meaning precedence.
    return toro_by_name_ || registry_.FindByTag(std::string(tag)) == nullptr;
  }

  void ToroLine(const Fields& f) {
    const std::string_view tag = f.tag();
    if (tag == kToroVertex) {
      f.ExpectCount(4, "id x y theta");
      const double p[3] = {f.Double(2), f.Double(3), SE2d(0, 0, f.Double(4)).theta()};
      Vertex(f, kToroVertex, VarType::kSE2, p);
    } else if (tag == kToroBearingRange) {
      ToroBearingRange(f);
    } else if (tag == kToroEdge && isam_) {
      IsamEdge(f, kToroEdge);
    } else if (tag == kToroEdge) {
      if (toro_edge2_line_ == 0) toro_edge2_line_ = f.line_number();
      f.ExpectCount(11, "id1 id2 dx dy dtheta I11 I12 I22 I33 I13 I23, TORO's order");
      const FactorType* type = registry_.FindByName("BetweenSE2");
      if (!type || !type->make) {
        f.Fail("EDGE2 needs the factor type 'BetweenSE2', which is not registered; call RegisterBuiltinFactors");
      }
      const std::vector<Key> keys = {f.Id(1), f.Id(2)};
      const double z[3] = {f.Double(3), f.Double(4), f.Double(5)};
      // TORO stores the upper triangle as I11 I12 I22 I33 I13 I23.
      Eigen::MatrixXd omega(3, 3);
      omega(0, 0) = f.Double(6);
      omega(0, 1) = omega(1, 0) = f.Double(7);
      omega(1, 1) = f.Double(8);
      omega(2, 2) = f.Double(9);
      omega(0, 2) = omega(2, 0) = f.Double(10);
      omega(1, 2) = omega(2, 1) = f.Double(11);
      const SqrtInformation noise = ctx_.FromInformation(f, std::move(omega));
      Edge(f, kToroEdge, type->make(keys, z, noise));
    } else {
      if (equiv_lines_++ == 0) first_equiv_line_ = f.line_number();
    }
  }

  void UnknownTag(const Fields& f) const {
    std::string known;
    for (const VertexTag& v : vertex_tags_) known += v.tag + " ";
    known += std::string(kFix) + " " + std::string(kSe3Offset);
    for (const auto& [name, type] : registry_.types())
      if (!type.tag.empty()) known += " " + type.tag;
    if (options_.format != FileFormat::kG2o) known += " VERTEX2 EDGE2 EQUIV BR ODOMETRY LANDMARK";
    std::string hint = "if it is a factor type, load the plugin that defines it";
    const std::string_view tag = f.tag();
    if (options_.format == FileFormat::kG2o &&
        (tag == kToroVertex || tag == kToroEdge || tag == kToroEquiv || tag == kToroBearingRange)) {
      hint = "it is a TORO tag: read the file as TORO (a .graph name or FileFormat::kToro)";
    }
    if (options_.format == FileFormat::kG2o && (tag == kIsamOdometry || tag == kIsamLandmark)) {
      hint = "it is an iSAM tag: read the file as iSAM (FileFormat::kIsam or FileFormat::kAuto)";
    }
    f.Fail("unknown tag " + QuoteToken(tag) + "; known tags: " + known + "; " + hint + ", or remove the line");
  }

  // Records that line f uses `key` as a variable of type t; checks the type agrees.
  IdInfo& UseId(const Fields& f, std::string_view stable_tag, Key key, VarType t) {
    const auto [it, inserted] = ids_.try_emplace(key);
    IdInfo& info = it->second;
    if (inserted) {
      info.type = t;
      info.type_line = f.line_number();
      info.type_tag = stable_tag;
    }
    if (!inserted && info.type != t) {
      f.Fail("id " + std::to_string(key) + " is used here as " + std::string(ToString(t)) + " (" +
             std::string(stable_tag) + "), but line " + std::to_string(info.type_line) + " (" +
             std::string(info.type_tag) + ") made it " + std::string(ToString(info.type)) +
             "; one id names one variable of one type, renumber one of them" +
             (landmark_lines_ > 0
                  ? " (the ids of LANDMARK and BR landmarks are offset by " +
                        std::to_string(options_.landmark_key_offset) + ": ReadOptions::landmark_key_offset)"
                  : std::string()));
    }
    return info;
  }

  void Vertex(const Fields& f, std::string_view stable_tag, VarType t, const double* params) {
    const Key key = f.Id(1);
    IdInfo& info = UseId(f, stable_tag, key, t);
    if (info.vertex_line != 0) {
      f.Fail("duplicate vertex id " + std::to_string(key) + ": line " + std::to_string(info.vertex_line) +
             " defines it already; remove one of the two lines");
    }
    info.vertex_line = f.line_number();
    ++vertex_lines_;
    out_values_.InsertParams(key, t, params);
  }

  void Edge(const Fields& f, std::string_view stable_tag, std::unique_ptr<Factor> factor) {
    const std::vector<Key>& keys = factor->keys();
    const std::vector<VarType> types = factor->variable_types();
    if (types.size() != keys.size()) {
      f.Fail("factor type '" + factor->type_name() + "' made a factor with " + std::to_string(keys.size()) +
             " keys but " + std::to_string(types.size()) + " variable types; this is a bug in its plugin");
    }
    for (std::size_t i = 0; i < keys.size(); ++i) {
      for (std::size_t j = 0; j < i; ++j) {
        if (keys[i] == keys[j]) {
          f.Fail(std::string(f.tag()) + " connects id " + std::to_string(keys[i]) +
                 " to itself; fix or remove the line");
        }
      }
    }
    for (std::size_t i = 0; i < keys.size(); ++i) {
      IdInfo& info = UseId(f, stable_tag, keys[i], types[i]);
      if (info.first_edge_line == 0) {
        info.first_edge_line = f.line_number();
        info.first_edge_tag = stable_tag;
      }
    }
    graph_.Add(std::move(factor));
  }

  // Where the file has vertex lines, every id an edge uses needs one.
  void CheckMissingVertices() const {
    if (vertex_lines_ == 0 || options_.allow_partial_vertices) return;
    std::size_t missing = 0;
    const std::pair<const Key, IdInfo>* first = nullptr;
    for (const auto& kv : ids_) {
      if (kv.second.vertex_line != 0 || kv.second.landmark) continue;
      ++missing;
      if (!first || kv.second.first_edge_line < first->second.first_edge_line) first = &kv;
    }
    if (!first) return;
    std::string m = name_ + ":" + std::to_string(first->second.first_edge_line) + ": " +
                    std::string(first->second.first_edge_tag) + " uses id " + std::to_string(first->first) +
                    ", which has no vertex line, though the file has " +
                    Plural(vertex_lines_, "vertex line", "vertex lines");
    if (missing > 1) m += " (" + std::to_string(missing) + " ids lack one)";
    m += "; add the missing vertices, or initialise them from the edges (tether optimize "
         "--allow-partial-vertices, ReadOptions::allow_partial_vertices)";
    throw ParseError(m);
  }

  void CheckConnected() const {
    std::vector<std::vector<Key>> pieces = ConnectedPieces(out_values_, graph_);
    if (pieces.size() <= 1) return;
    std::stable_sort(pieces.begin(), pieces.end(),
                     [](const std::vector<Key>& a, const std::vector<Key>& b) { return a.size() > b.size(); });
    std::string m = name_ + ": the graph falls into " + std::to_string(pieces.size()) + " disconnected pieces: ";
    for (std::size_t i = 0; i < pieces.size() && i < kPiecesListed; ++i) {
      if (i > 0) m += ", ";
      m += Plural(pieces[i].size(), "variable", "variables") + " from id " + std::to_string(pieces[i].front());
    }
    if (pieces.size() > kPiecesListed) m += ", and " + std::to_string(pieces.size() - kPiecesListed) + " more";
    m += "; nothing ties the pieces to each other, so their relative placement is undetermined. Add edges "
         "that "
         "link them, or split the file into one graph per piece";
    if (equiv_lines_ > 0) {
      m += " (the file's " + Plural(equiv_lines_, "EQUIV line was", "EQUIV lines were") + " ignored)";
    }
    throw ParseError(m);
  }

  const std::string& name_;
  const Registry& registry_;
  const ReadOptions& options_;
  Fields fields_{name_, 0, {}};
  bool toro_by_name_ = false;
  bool isam_ = false;         // EDGE2 in iSAM's layout
  long toro_edge2_line_ = 0;  // first EDGE2 read in TORO's layout (0: none)
  std::size_t landmark_lines_ = 0;
  std::vector<std::size_t> odometry_factors_;  // graph indices of ODOMETRY edges
  ReadContext ctx_;
  Values out_values_;
  FactorGraph graph_;
  std::unordered_map<Key, IdInfo> ids_;
  std::vector<std::pair<Key, long>> fixes_;
  std::size_t vertex_lines_ = 0;
  std::size_t equiv_lines_ = 0;
  long first_equiv_line_ = 0;
  std::vector<VertexTag> vertex_tags_;
  std::vector<double> params_;  // one vertex line's parameters (reused)
};

// Appends a vertex line (with its newline) to *line.
void AppendVertex(std::string* line, Key k, VarType t, const double* p) {
  const VariableType& d = Describe(t);
  if (d.tag.empty()) {
    throw InvalidArgument("cannot write variable " + KeyToString(k) + " of type '" + d.name +
                          "': the type has no g2o vertex tag, so g2o files cannot hold it");
  }
  for (int i = 0; i < d.ambient_dim; ++i) {
    if (!std::isfinite(p[i])) {
      throw InvalidArgument("cannot write variable " + KeyToString(k) + " (" + d.name + "): parameter " +
                            std::to_string(i) + " is not finite, and the file could not be read back");
    }
  }
  line->append(d.tag);
  line->push_back(' ');
  AppendKey(line, k);
  for (int i = 0; i < d.ambient_dim; ++i) {
    line->push_back(' ');
    AppendDouble(line, p[i]);
  }
  line->push_back('\n');
}

std::string ErrnoText() { return std::strerror(errno); }

}  // namespace

GraphFile ReadGraph(std::istream& in, const std::string& name, const Registry& registry, const ReadOptions& options) {
  Reader reader(name, registry, options);
  // Blocks of 64 KiB split at '\n' (getline per line cost more than parsing the line); a
  // line cut by the block's end is carried over to the next block.
  constexpr std::size_t kBlock = 1 << 16;
  std::string buf;
  std::size_t begin = 0;  // first unprocessed byte of buf
  long number = 0;
  auto line = [&](std::string_view text) {
    if (number == 0 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 byte order mark
    reader.Line(++number, text);
  };
  for (;;) {
    buf.erase(0, begin);
    begin = 0;
    const std::size_t old = buf.size();
    buf.resize(old + kBlock);
    in.read(&buf[old], kBlock);
    buf.resize(old + static_cast<std::size_t>(in.gcount()));
    const bool end = in.gcount() == 0;
    if (number == 0 && old == 0) reader.Sniff(buf);
    std::size_t nl;
    while ((nl = buf.find('\n', begin)) != std::string::npos) {
      line(std::string_view(buf.data() + begin, nl - begin));
      begin = nl + 1;
    }
    if (end) break;
  }
  if (in.bad()) throw IoError(name + ": read error after line " + std::to_string(number) + "; check the file");
  if (begin < buf.size()) line(std::string_view(buf.data() + begin, buf.size() - begin));  // no final '\n'
  return reader.Finish();
}

GraphFile ReadGraphFile(const std::string& path, const Registry& registry, const ReadOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw IoError(path + ": is a directory, not a graph file; give the path of a .g2o or .graph file");
  }
  std::ifstream in(path);
  if (!in) throw IoError(path + ": cannot open: " + ErrnoText() + "; check the path and its permissions");
  return ReadGraph(in, path, registry, options);
}

void WriteG2o(std::ostream& out, const Values& values, const FactorGraph& graph, const Registry& registry) {
  // Lines are gathered in one buffer, handed to the stream every 64 KiB or so.
  std::string buf;
  buf.reserve(1 << 17);
  const auto flush = [&](bool always) {
    if (always || buf.size() >= (1 << 16)) {
      out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
      buf.clear();
    }
  };
  // Parameter lines the edges refer to come first, each once, in the order first needed.
  std::vector<const std::string*> preambles;
  std::string last_type;  // consecutive factors are mostly of one type: one lookup for them
  for (const auto& f : graph.factors()) {
    std::string name = f->type_name();
    if (name == last_type) continue;
    last_type = std::move(name);
    const FactorType* type = registry.FindByName(last_type);
    if (type == nullptr || type->preamble.empty()) continue;
    const auto same = [&](const std::string* p) { return *p == type->preamble; };
    if (std::none_of(preambles.begin(), preambles.end(), same)) preambles.push_back(&type->preamble);
  }
  for (const std::string* p : preambles) {
    buf.append(*p);
    buf.push_back('\n');
  }
  for (Key k : values.keys()) {
    AppendVertex(&buf, k, values.TypeOf(k), values.Params(k));
    flush(false);
  }
  for (Key k : graph.fixed()) {
    buf.append(kFix);
    buf.push_back(' ');
    AppendKey(&buf, k);
    buf.push_back('\n');
    flush(false);
  }
  // Whatever is written must read back: a file with some vertices is read only where every id
  // an edge or FIX names has one (one with none gets them composed from its edges).
  const auto missing = [&](Key k) { return !values.empty() && !values.Has(k); };
  for (Key k : graph.fixed()) {
    if (missing(k)) {
      throw InvalidArgument("cannot write FIX " + KeyToString(k) +
                            ": the variable has no value, and the file could not be read back; insert a value for "
                            "it or unfix it");
    }
  }
  for (std::size_t i = 0; i < graph.size(); ++i) {
    for (Key k : graph.at(i).keys()) {
      if (missing(k)) {
        throw InvalidArgument("cannot write factor #" + std::to_string(i) + " (" + graph.at(i).type_name() +
                              "): variable " + KeyToString(k) +
                              " has no value, and the file could not be read back; insert a value for it or "
                              "remove the factor");
      }
    }
    try {
      registry.AppendLine(graph.at(i), &buf);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("factor #" + std::to_string(i) + ": " + e.what());
    }
    buf.push_back('\n');
    flush(false);
  }
  flush(true);
  if (!out) throw IoError("writing the g2o graph failed (stream error); check the disk space and the output");
}

void WriteG2oFile(const std::string& path, const Values& values, const FactorGraph& graph, const Registry& registry) {
  OutputFile out(path, "g2o graph");
  out.Stage([&](std::ostream& s) { WriteG2o(s, values, graph, registry); });
  out.Commit();
}

std::vector<std::vector<Key>> ConnectedPieces(const Values& values, const FactorGraph& graph) {
  // Union-find over dense indices; a hash map turns keys (which may be huge) into indices.
  std::unordered_map<Key, std::uint32_t> index;
  std::vector<Key> keys;
  const auto add = [&](Key k) {
    if (index.emplace(k, static_cast<std::uint32_t>(keys.size())).second) keys.push_back(k);
  };
  for (Key k : values.keys()) add(k);
  for (const auto& f : graph.factors())
    for (Key k : f->keys()) add(k);
  std::vector<std::uint32_t> parent(keys.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const auto& f : graph.factors()) {
    const std::vector<Key>& fk = f->keys();
    for (std::size_t j = 1; j < fk.size(); ++j) {
      const std::uint32_t a = find(index.at(fk[0])), b = find(index.at(fk[j]));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::unordered_map<std::uint32_t, std::size_t> piece_of_root;
  std::vector<std::vector<Key>> pieces;
  for (std::uint32_t i = 0; i < keys.size(); ++i) {
    const auto [it, inserted] = piece_of_root.emplace(find(i), pieces.size());
    if (inserted) pieces.emplace_back();
    pieces[it->second].push_back(keys[i]);
  }
  for (auto& p : pieces) std::sort(p.begin(), p.end());
  std::sort(pieces.begin(), pieces.end(),
            [](const std::vector<Key>& a, const std::vector<Key>& b) { return a.front() < b.front(); });
  return pieces;
}

int InitializeSpanningTree(const FactorGraph& graph, Values* values) {
  if (values == nullptr) {
    throw InvalidArgument("InitializeSpanningTree: values is a null pointer; pass the Values to initialise");
  }
  // Most graphs come with every value: nothing to build then.
  const bool any_missing = std::any_of(graph.factors().begin(), graph.factors().end(), [&](const auto& f) {
    return std::any_of(f->keys().begin(), f->keys().end(), [&](Key k) { return !values->Has(k); });
  });
  if (!any_missing) return 0;
  struct Node {
    VarType type;
    std::vector<std::uint32_t> factors;  // factors with two or more keys that use this key
  };
  std::unordered_map<Key, Node> nodes;
  for (std::uint32_t i = 0; i < graph.size(); ++i) {
    const Factor& f = graph.at(i);
    const std::vector<VarType> types = f.variable_types();
    for (std::size_t j = 0; j < f.keys().size() && j < types.size(); ++j) {
      Node& n = nodes.try_emplace(f.keys()[j], Node{types[j], {}}).first->second;
      if (f.keys().size() >= 2) n.factors.push_back(i);
    }
  }
  std::vector<Key> missing;
  for (const auto& kv : nodes)
    if (!values->Has(kv.first)) missing.push_back(kv.first);
  if (missing.empty()) return 0;
  std::sort(missing.begin(), missing.end());

  // New values are collected aside and inserted at the end, in key order, so that a failure
  // leaves `values` untouched.
  // Their parameters back to back in one array (offsets by key): no allocation per variable.
  std::unordered_map<Key, std::size_t> fresh;
  std::vector<double> fresh_params;
  const auto add_fresh = [&](Key k, const double* p, int n) {
    fresh.emplace(k, fresh_params.size());
    fresh_params.insert(fresh_params.end(), p, p + n);
  };
  const auto known = [&](Key k) -> const double* {
    if (values->Has(k)) return values->Params(k);
    const auto it = fresh.find(k);
    return it == fresh.end() ? nullptr : fresh_params.data() + it->second;
  };
  std::deque<Key> queue;
  for (Key k : values->keys())
    if (nodes.count(k)) queue.push_back(k);
  if (queue.empty()) {
    const Key anchor = missing.front();
    std::vector<double> a(static_cast<std::size_t>(AmbientDim(nodes.at(anchor).type)));
    IdentityParams(nodes.at(anchor).type, a.data());
    add_fresh(anchor, a.data(), static_cast<int>(a.size()));
    queue.push_back(anchor);
  }
  std::vector<double> kp, out;  // reused for every step
  while (!queue.empty()) {
    const Key k = queue.front();
    queue.pop_front();
    const VarType kt = nodes.at(k).type;
    kp.assign(known(k), known(k) + AmbientDim(kt));  // a copy: fresh_params may grow below
    for (std::uint32_t fi : nodes.at(k).factors) {
      const Factor& f = graph.at(fi);
      const std::vector<Key>& fk = f.keys();
      const std::size_t at = static_cast<std::size_t>(std::find(fk.begin(), fk.end(), k) - fk.begin());
      for (std::size_t u = 0; u < fk.size(); ++u) {
        if (u == at || known(fk[u])) continue;
        out.resize(static_cast<std::size_t>(AmbientDim(nodes.at(fk[u]).type)));
        if (!f.Predict(at, kp.data(), u, out.data())) continue;
        if (!std::all_of(out.begin(), out.end(), [](double v) { return std::isfinite(v); })) continue;
        add_fresh(fk[u], out.data(), static_cast<int>(out.size()));
        queue.push_back(fk[u]);
      }
    }
  }
  std::size_t unreached = 0;
  Key first_unreached = 0;
  for (Key k : missing) {
    if (fresh.count(k)) continue;
    if (unreached++ == 0) first_unreached = k;
  }
  if (unreached > 0) {
    std::string m = "cannot give id " + std::to_string(first_unreached) + " an initial value";
    if (unreached > 1) m += " (nor " + std::to_string(unreached - 1) + " other ids)";
    m += ": no chain of factors that can predict one variable from another links it to a variable with a "
         "value; give it an initial value (a vertex line) or add edges that link it";
    throw InvalidArgument(m);
  }
  for (Key k : missing) values->InsertParams(k, nodes.at(k).type, fresh_params.data() + fresh.at(k));
  return static_cast<int>(missing.size());
}

}  // namespace tether
