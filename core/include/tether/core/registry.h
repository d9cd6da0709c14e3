#pragma once
// Registry: variable and factor types by name and g2o tag, with their factories, readers and
// writers.
//
// Built-in types register through exactly the same calls a plugin uses: every Registry
// starts with the four built-in variable types (variable.h), and
// tether/factors/builtin.h: RegisterBuiltinFactors adds the built-in factors. A standard g2o edge line reads
//   TAG id_1 .. id_k  measurement[measurement_size]  information upper triangle, row by row
// and types that follow that layout only need `make`; others give their own read/write.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/fields.h"
#include "tether/core/sqrt_information.h"

namespace tether {

/// Settings and counters shared by the readers of one file.
struct ReadContext {
  InformationRepair repair = InformationRepair::kNone;
  int repaired_informations = 0;  ///< how many information matrices were changed by `repair`
  long first_repaired_line = 0;   ///< line of the first repaired matrix (0: none)
  /// Edge measurements brought to their canonical form noticeably (a quaternion far from unit
  /// length normalised), with the line of the first and what was done, for one warning a file.
  int canonicalized_measurements = 0;
  long first_canonicalized_line = 0;
  std::string canonicalize_note;
  /// A g2o parameter line (`PARAMS_SE3OFFSET id x y z qx qy qz qw`): its tag, its numbers as
  /// read (the quaternion normalised, as g2o does) and its line, for the edges that refer to it.
  struct Parameter {
    std::string tag;
    std::vector<double> values;
    long line = 0;
  };
  /// The parameter lines read so far, by id (an edge refers to one defined above it).
  std::map<std::uint64_t, Parameter> parameters;
  /// Parses an information matrix stored as its upper triangle (row by row) starting at
  /// field `first`, applies the repair policy, and returns its square root. Throws a
  /// ParseError naming the line if it is not positive definite and repair is off.
  SqrtInformation ReadUpperInformation(const Fields& f, std::size_t first, int dim);
  /// The same checks and repair for a matrix a reader assembled itself (any field order).
  SqrtInformation FromInformation(const Fields& f, Eigen::MatrixXd omega);
};

using FactorMaker =
    std::function<std::unique_ptr<Factor>(std::vector<Key>, const double* measurement, SqrtInformation)>;

struct FactorType {
  std::string name;               ///< unique type name, e.g. "BetweenSE2"
  std::string tag;                ///< g2o tag, e.g. "EDGE_SE2" (may be empty: no file form)
  std::string owner = "builtin";  ///< who registered it (plugin name for plugins)
  int dim = 0;                    ///< residual dimension
  std::vector<VarType> variable_types;
  int measurement_size = 0;  ///< number of measurement fields in the standard layout
  /// Optional names of the measurement fields for messages, e.g. "x y theta". Where empty,
  /// the parameter names of the last variable type are used when the sizes agree, else m1..mk.
  std::string measurement_layout;
  /// Creates a factor from keys, measurement and noise (the standard layout's factory).
  FactorMaker make;
  /// Measurement of an existing factor of this type, for writing (standard layout).
  std::function<std::vector<double>(const Factor&)> measurement;
  /// Optional custom reader/writer replacing the standard layout.
  std::function<std::unique_ptr<Factor>(const Fields&, ReadContext&)> read;
  std::function<std::string(const Factor&)> write;
  /// A line the g2o writer puts once, before the vertices, into a file that holds factors of
  /// this type: the parameter line its written edges refer to (g2o's EDGE_SE3_TRACKXYZ and
  /// EDGE_SE3_PRIOR are written with "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1"). Empty: none.
  std::string preamble;

  /// Fields after the tag in the standard layout.
  std::size_t StandardFieldCount() const { return variable_types.size() + measurement_size + dim * (dim + 1) / 2; }
};

/// True where `t`'s measurement is a value of its last variable's type (a relative pose, a
/// pose prior, a point seen from a pose): as many numbers as that type's parameters and no
/// layout of its own, or that type's parameter names; `type` (may be null) is then that type.
/// The rule the standard layout's messages use to name the measurement's fields.
bool MeasurementIsAValue(const FactorType& t, VarType* type);

/// A registry entry for the TypedFactor (or AutoDiffFactor) F in the standard layout: name,
/// residual size and variable types come from the class itself.
template <class F>
FactorType DescribeFactor(std::string tag, int measurement_size, FactorMaker make) {
  FactorType t;
  t.name = F::kTypeName;
  t.tag = std::move(tag);
  t.dim = F::kResidualDim;
  t.variable_types = F::VariableTypes();
  t.measurement_size = measurement_size;
  t.make = std::move(make);
  t.measurement = [](const Factor& f) { return f.Measurement(); };
  return t;
}

class Registry {
 public:
  /// A registry with the four built-in variable types (and no factor types).
  Registry();
  Registry(const Registry& other);
  Registry& operator=(const Registry& other);
  ~Registry();

  /// Adds a factor type. Throws InvalidArgument if the name or tag is taken (naming both
  /// owners), the description is incomplete, a variable type is unknown, or a probe factor
  /// made by `make` disagrees with the entry (its type_name(), residual_dim() or
  /// variable_types(); the message names the field).
  void Register(FactorType type);
  /// Adds a variable type: puts it into the process-wide table (variable.h) and its g2o tag
  /// into this registry's vertex tags. Throws InvalidArgument if the name or tag is taken here,
  /// or the description is incomplete. Returns its id.
  VarType RegisterVariable(const VariableType& type);
  /// The same for a value type with a VariableTraits specialisation.
  template <class V>
  VarType RegisterVariable() {
    return RegisterVariable(DescribeVariable<V>());
  }
  /// Removes every factor and variable type registered by `owner`; returns how many.
  int RemoveOwner(const std::string& owner);
  /// Removes the factor type of that name (and its tag); false if there is none. Only safe
  /// once no factor of the type exists.
  bool Remove(const std::string& name);
  /// Removes the variable type of that name from this registry (its id stays valid).
  bool RemoveVariable(const std::string& name);

  /// The variable type whose vertex tag is `tag`; false where none is.
  bool FindVariableByTag(const std::string& tag, VarType* type) const;
  /// Variable types registered here, by name.
  const std::map<std::string, VarType>& variable_types() const { return variables_; }
  /// Owner of a variable type registered here ("" where it is not).
  std::string VariableOwner(const std::string& name) const;

  /// The pointers stay valid until that type's owner is removed (RemoveOwner) or the registry
  /// is destroyed; registering other types does not move them.
  const FactorType* FindByTag(const std::string& tag) const;
  const FactorType* FindByName(const std::string& name) const;
  const std::map<std::string, FactorType>& types() const { return by_name_; }

  /// Reads one edge line with its registered reader (standard layout unless overridden).
  std::unique_ptr<Factor> Read(const FactorType& type, const Fields& f, ReadContext& ctx) const;
  /// Writes a factor as one g2o line (without newline); throws if its type has no tag.
  std::string Write(const Factor& factor) const;
  /// The same line appended to *line (a buffer the caller reuses: no string per call).
  void AppendLine(const Factor& factor, std::string* line) const;

 private:
  void CheckAgainstProbe(const FactorType& type) const;

  std::map<std::string, FactorType> by_name_;
  std::map<std::string, std::string> tag_to_name_;
  std::map<std::string, VarType> variables_;               // by name
  std::map<std::string, std::string> variable_owner_;      // by name
  std::map<std::string, std::string> variable_tag_;        // by name: the tag registered here
  std::map<std::string, std::string> vertex_tag_to_name_;  // g2o vertex tag -> variable name
};

/// Formats a double with enough digits to read back the same value.
std::string FormatDouble(double v);
/// Formats a double with `digits` digits after the point (std::fixed), for reports.
std::string FormatFixed(double v, int digits);
/// The same text appended to *s.
void AppendDouble(std::string* s, double v);
/// A key's decimal text appended to *s.
void AppendKey(std::string* s, Key k);

}  // namespace tether
