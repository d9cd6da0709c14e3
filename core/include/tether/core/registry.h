#pragma once
// Registry: factor types by name and g2o tag, with their factories, readers and writers.
//
// Built-in factors register through exactly the same calls a plugin uses
// (tether/factors/builtin.h: RegisterBuiltinFactors). A standard g2o edge line reads
//   TAG id_1 .. id_k  measurement[measurement_size]  information upper triangle, row by row
// and types that follow that layout only need `make`; others give their own read/write.
#include <Eigen/Core>
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
  /// Parses an information matrix stored as its upper triangle (row by row) starting at
  /// field `first`, applies the repair policy, and returns its square root. Throws a
  /// ParseError naming the line if it is not positive definite and repair is off.
  SqrtInformation ReadUpperInformation(const Fields& f, std::size_t first, int dim);
  /// The same checks and repair for a matrix a reader assembled itself (any field order).
  SqrtInformation FromInformation(const Fields& f, Eigen::MatrixXd omega);
};

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
  std::function<std::unique_ptr<Factor>(std::vector<Key>, const double* measurement, SqrtInformation)> make;
  /// Measurement of an existing factor of this type, for writing (standard layout).
  std::function<std::vector<double>(const Factor&)> measurement;
  /// Optional custom reader/writer replacing the standard layout.
  std::function<std::unique_ptr<Factor>(const Fields&, ReadContext&)> read;
  std::function<std::string(const Factor&)> write;

  /// Fields after the tag in the standard layout.
  std::size_t StandardFieldCount() const { return variable_types.size() + measurement_size + dim * (dim + 1) / 2; }
};

class Registry {
 public:
  /// Adds a type. Throws InvalidArgument if the name or tag is taken (naming both owners),
  /// or the description is incomplete.
  void Register(FactorType type);
  /// Removes every type registered by `owner`; returns how many.
  int RemoveOwner(const std::string& owner);
  /// Removes the type of that name (and its tag); false if there is none. Only safe once no
  /// factor of the type exists.
  bool Remove(const std::string& name);

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
  std::map<std::string, FactorType> by_name_;
  std::map<std::string, std::string> tag_to_name_;
};

/// Formats a double with enough digits to read back the same value.
std::string FormatDouble(double v);
/// The same text appended to *s.
void AppendDouble(std::string* s, double v);
/// A key's decimal text appended to *s.
void AppendKey(std::string* s, Key k);

}  // namespace tether
